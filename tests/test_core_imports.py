"""The shipped core imports none of the test oracles and none of their heavy dependencies: a fresh
interpreter that imports ``layered_brdf_addon.model``, ``.fit`` or ``.backends`` (each with every
module of theirs) holds no ``layered_brdf_reference``, colour-science, SciPy or tmm, and the model
and the fit hold no bpy."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ORACLES = ("layered_brdf_reference", "colour", "scipy", "tmm")

# Imports the package and every module in it, then prints the modules loaded.
PROBE = """
import importlib, json, pkgutil, sys
package = importlib.import_module(sys.argv[1])
for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
    importlib.import_module(info.name)
print(json.dumps(sorted(sys.modules)))
"""


def loaded_by(package: str) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", PROBE, package], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.splitlines()[-1])


def offending(modules: list[str], roots) -> list[str]:
    return [m for m in modules if m.split(".")[0] in roots]


@pytest.mark.parametrize("package, forbidden", [
    ("layered_brdf_addon.model", ORACLES + ("bpy",)),
    ("layered_brdf_addon.fit", ORACLES + ("bpy",)),
    ("layered_brdf_addon.backends", ORACLES),  # the node group is built with bpy
])
def test_the_core_loads_no_oracle(package, forbidden):
    modules = loaded_by(package)
    assert package in modules
    bad = offending(modules, forbidden)
    assert not bad, f"importing {package} loads {', '.join(bad)}"


def test_the_add_on_package_loads_only_itself():
    """Blender imports the package first: it must not pull in bpy-side modules or any oracle."""
    proc = subprocess.run([sys.executable, "-c", "import json, sys, layered_brdf_addon; print(json.dumps(sorted("
                           "sys.modules)))"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    modules = json.loads(proc.stdout.splitlines()[-1])
    bad = offending(modules, ORACLES + ("bpy", "numpy"))
    assert not bad, f"importing layered_brdf_addon loads {', '.join(bad)}"


def test_the_check_names_what_it_finds():
    assert offending(["numpy", "scipy.optimize", "colour", "colourful", "layered_brdf_reference.spectral"],
                     ORACLES) == ["scipy.optimize", "colour", "layered_brdf_reference.spectral"]
