# Two commands: `make demo` renders the look-dev sheet (out/lookdev.png), `make test` runs the suite.
# Both pick the newest supported Blender/Python pair on this machine -- Blender 5.2 LTS
# (bpy 5.2.3) on Python 3.13 if a python3.13 runs (on PATH or through pyenv), else
# Blender 5.0 (bpy 5.0.1) on Python 3.11 -- and create one venv per pair (.venv-5.2,
# .venv-5.0), installing the pinned dependencies when needed.
# Choose a pair with `make test BLENDER=5.0` (or 5.2); choose the interpreter with PYTHON=...

# The first command that runs and reports the wanted version, as a real executable path
# (pyenv's shims only run when a version is selected, so try pyenv's own versions too).
find_python = $(shell for p in python$(1) $$(pyenv root 2>/dev/null)/versions/$(1)*/bin/python$(1) python3; do \
    "$$p" -c 'import sys; sys.exit(sys.version_info[:2] != ($(subst .,$(comma),$(1))))' 2>/dev/null && \
    { "$$p" -c 'import sys; print(sys.executable)'; break; }; done)
comma := ,

ifndef BLENDER
  PYTHON313 := $(call find_python,3.13)
  BLENDER := $(if $(PYTHON313),5.2,5.0)
endif

ifeq ($(BLENDER),5.2)
  PYTHON ?= $(or $(PYTHON313),$(call find_python,3.13))
else ifeq ($(BLENDER),5.0)
  PYTHON ?= $(or $(call find_python,3.11),python3)
else
  $(error BLENDER=$(BLENDER): supported are 5.2 (Python 3.13) and 5.0 (Python 3.11))
endif

VENV := .venv-$(BLENDER)
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-$(shell cksum pyproject.toml | cut -d' ' -f1)
EXT_ZIP = dist/layered_brdf-$(shell sed -n 's/^version *= *"\(.*\)"/\1/p' blender_manifest.toml).zip
WHICH = $(PY) -c "import importlib.metadata as m, platform; \
    print('Blender', m.version('bpy'), '(bpy) on Python', platform.python_version(), 'in $(VENV)')"

.PHONY: demo test bench bench-scene gpu-check extension clean which generated band-fit albedo-fit looks-sheet

$(STAMP): pyproject.toml
	@test -n "$(PYTHON)" || { echo "Blender $(BLENDER) needs Python $(if $(filter 5.2,$(BLENDER)),3.13,3.11), not found" >&2; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	rm -f $(VENV)/.installed-*
	touch $(STAMP)

which: $(STAMP)
	@$(WHICH)

demo: $(STAMP)
	@$(WHICH)
	$(PY) -m layered_brdf_addon

# The suite runs in TEST_JOBS processes (pytest-xdist; a test file's tests stay in one process, so its
# module fixtures and scene are built once); TEST_JOBS=1 runs it in this one.
TEST_JOBS ?= 2
test: $(STAMP)
	@$(WHICH)
	$(PY) -m pytest $(if $(filter-out 0 1,$(TEST_JOBS)),-n $(TEST_JOBS) --dist loadfile) $(PYTEST_ARGS)

# Rewrite osl/layered_brdf.osl and node_groups/*.json from the shading program, docs/options.md from the
# command line's option table.
generated: $(STAMP)
	$(PY) -m layered_brdf_addon.backends.generated
	$(PY) -m layered_brdf_addon.cli.option_docs

# Refit the analytic mode's closed form (model/data/band_fit.json) from the CIE tables, a few minutes.
band-fit: $(STAMP)
	$(PY) -m layered_brdf_reference.band_fitting

# Refit the closed form of Cycles' Beckmann closure's albedo (model/data/closure_albedo.json), seconds.
albedo-fit: $(STAMP)
	$(PY) -m layered_brdf_reference.lobe_albedo

bench: $(STAMP)
	$(PY) benchmarks/bench_reference.py

# Render cost per sample on a realistic scene (Suzanne, HDRI + sun; Cycles CPU and EEVEE), about 25 min.
bench-scene: $(STAMP)
	$(PY) benchmarks/bench_scene.py $(BENCH_ARGS)

# On a machine with a GPU: the reference spheres rendered there against the CPU, pixel by pixel, and
# the scene's cost per sample there (benchmarks/results/gpu_check.json); says so and passes without one.
gpu-check: $(STAMP)
	$(PY) benchmarks/gpu_check.py $(GPU_ARGS)

# Every preset next to its nearest Principled BSDF + Thin Film on the look-dev shader ball:
# docs/images/presets-vs-principled-thin-film.png (docs/looks.md), a minute or two.
looks-sheet: $(STAMP)
	$(PY) benchmarks/looks_sheet.py $(LOOKS_ARGS)

# Blender's extension tool and its tags file are found in the installed bpy.
extension: $(STAMP)
	mkdir -p $(dir $(EXT_ZIP))
	rm -f $(EXT_ZIP)
	eval "$$($(PY) -m layered_brdf_addon.blender.paths --shell)" && \
	$(PY) "$$tool" build --source-dir . --output-filepath $(EXT_ZIP) --valid-tags "$$tags" && \
	$(PY) "$$tool" validate $(EXT_ZIP) --valid-tags "$$tags"

clean:
	rm -rf dist out .pytest_cache

# The Asset Browser library of looks (a material asset per preset, with previews) in ASSETS_DIR;
# add that folder in Blender's Preferences > File Paths > Asset Libraries.
ASSETS_DIR ?= out/assets
.PHONY: assets
assets: $(STAMP)
	@$(WHICH)
	$(PY) -m layered_brdf_addon.blender.asset_library $(ASSETS_DIR) $(ASSETS_ARGS)
