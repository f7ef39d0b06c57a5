"""The shading program's backends implement its declared interface (model/backend.py):
every operation the program uses is declared, and numpy, the node group and the OSL writer
each implement every declared operation."""
from __future__ import annotations

import ast
import importlib
import inspect
import pkgutil

import numpy as np
import pytest

from layered_brdf_addon.backends.node_group import GroupOps
from layered_brdf_addon.backends.node_ops import NodeOps
from layered_brdf_addon.backends.osl_ops import OslOps
from layered_brdf_addon.backends.osl_shader import ShaderOps
from layered_brdf_addon.model import ops_numpy, program, shading
from layered_brdf_addon.model.backend import ShadingOps, SurfaceOps, TableOps, members
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.sphere import shading_point


def program_modules() -> list:
    """The shading program's modules: its top and every part of it."""
    parts = [importlib.import_module(f"{shading.__name__}.{m.name}") for m in pkgutil.iter_modules(shading.__path__)]
    return [program, *parts]


def used_by_program() -> set[str]:
    """Every ``ops.NAME`` in the shading program."""
    used = set()
    for module in program_modules():
        tree = ast.parse(inspect.getsource(module))
        used |= {n.attr for n in ast.walk(tree)
                 if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "ops"}
    return used


def test_the_scan_covers_the_whole_program():
    """Every step the program's top offers is defined in a module the scan reads."""
    scanned = {m.__name__ for m in program_modules()}
    steps = [getattr(program, name) for name in program.__all__]
    defined_in = {step.__module__ for step in steps if inspect.isfunction(step) or inspect.isclass(step)}
    assert defined_in <= scanned, defined_in - scanned


def test_every_operation_the_program_uses_is_declared():
    assert used_by_program() - set(members(TableOps)) == set()
    assert set(members(ShadingOps)) < set(members(SurfaceOps)) < set(members(TableOps))


def numpy_point():
    n0 = np.array([[0.0, 0.0, 1.0]])
    return shading_point(LayeredParams(), n0, n0)


BACKENDS = {
    "numpy": (ops_numpy, numpy_point),
    "node group": (NodeOps, lambda: GroupOps),
    "OSL": (OslOps, lambda: ShaderOps),
}


@pytest.mark.parametrize("backend", list(BACKENDS))
def test_every_backend_implements_every_operation(backend):
    arithmetic, surface = BACKENDS[backend]
    point = surface()
    for protocol, impl in ((ShadingOps, arithmetic), (SurfaceOps, point)):
        missing = [name for name in members(protocol) if not callable(getattr(impl, name, None))]
        assert not missing, f"{backend} lacks {missing} of {protocol.__name__}"
    assert callable(getattr(point, "table", None)), f"{backend} reads no baked tables"
