# Two commands: `make demo` renders the gallery, `make test` runs the suite.
# Both create .venv and install the pinned dependencies when needed.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cksum pyproject.toml | cut -d' ' -f1)
EXT_ZIP = dist/layered_brdf-$(shell sed -n 's/^version *= *"\(.*\)"/\1/p' blender_manifest.toml).zip

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
	mkdir -p $(dir $(EXT_ZIP))
	rm -f $(EXT_ZIP)
	scripts="$$($(PY) -c "import bpy; print(bpy.utils.system_resource('SCRIPTS'))")" && \
	tool="$$scripts/addons_core/bl_pkg/cli/blender_ext.py" && \
	tags="$$scripts/modules/_bpy_internal/extensions/tags.py" && \
	$(PY) "$$tool" build --source-dir . --output-filepath $(EXT_ZIP) --valid-tags "$$tags" && \
	$(PY) "$$tool" validate $(EXT_ZIP) --valid-tags "$$tags"

clean:
	rm -rf dist out .pytest_cache
