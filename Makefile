# Two commands: `make demo` renders the gallery, `make test` runs the suite.
# Both create .venv and install the pinned dependencies when needed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cksum pyproject.toml | cut -d' ' -f1)
EXT_TOOL = $(shell $(PY) -c "import bpy, os; print(os.path.join(os.path.dirname(bpy.__file__), '5.0', 'scripts', 'addons_core', 'bl_pkg', 'cli', 'blender_ext.py'))")

.PHONY: demo test bench extension clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m layered_brdf_addon

test: $(STAMP)
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) benchmarks/bench_reference.py

extension: $(STAMP)
	mkdir -p dist
	$(PY) $(EXT_TOOL) build --source-dir . --output-dir dist
	$(PY) $(EXT_TOOL) validate dist/layered_brdf-*.zip

clean:
	rm -rf dist out .pytest_cache
