import os
import sys
import types

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("ci", deadline=None, derandomize=True, max_examples=200,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci")

os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def _uses_blender(module) -> bool:
    """Whether a test module imports bpy or the add-on's Blender layer at its top level."""
    for value in vars(module).values():
        name = value.__name__ if isinstance(value, types.ModuleType) else getattr(value, "__module__", None)
        if isinstance(name, str) and (name.split(".")[0] == "bpy" or name.startswith("layered_brdf_addon.blender")):
            return True
    return False


@pytest.fixture(autouse=True)
def blender_factory_state(request):
    """Factory settings and an empty file before each test of a module that uses Blender.

    Pure-numpy modules never import bpy through this.  A test that reads a scene built by a
    module-scoped fixture is marked ``keeps_scene`` and starts from that scene instead.
    """
    if "bpy" in sys.modules and request.module is not None and _uses_blender(request.module) \
            and request.node.get_closest_marker("keeps_scene") is None:
        from layered_brdf_addon.blender.scene import reset_blender

        reset_blender()
    yield
