"""The layered material from a script: :func:`apply_layered_material`, the one function the UI, the
command line and the tests call, and what reads a layered material back.

The work is done in the modules named below; this module gathers their public names:

* :mod:`.build`: building the material; :func:`apply_layered_material` here builds it, writes the
  settings it applied and installs the handlers of :mod:`.freshness`, so that a script that never
  registers the add-on renders what it sets, keys, drives or links;
* :mod:`.own_nodes`: finding the add-on's shader node (:func:`shader_node`);
* :mod:`.sockets`: the parameters' values in the node's sockets;
* :mod:`.animation`: which parameters are animated, driven or linked;
* :mod:`.slots`: the object's slot (:func:`remove_layered_material` puts back what Apply replaced);
* :mod:`.targets`: which objects and materials can take it;
* :mod:`.unused_data`: the add-on's node groups and texts nothing uses any more;
* :mod:`.stored_keys`: the custom-property keys and names saved in files.
"""
from __future__ import annotations

import functools
import warnings

import bpy

from . import build, freshness, sync
from . import osl as osl_backend
from ..model.policy import OSLSceneWarning
from .animation import animated_parameters
from .build import tree_current
from .own_nodes import shader_node
from .slots import displaced_material, remove_layered_material
from .sockets import (as_rendered, check_node, input_linked, input_value, missing_inputs, node_damage, param_socket,
                      read_inputs, set_inputs, socket_parameters)
from .stored_keys import (AOV_LOWER_NORMAL, AOV_THICKNESS, AOV_UPPER_NORMAL, BACKEND_KEY, DISPLACED_KEY, MATERIAL_KEY,
                          NAME_KEY, ROLE_KEY, SHADER_NODE, SLOT_KEY, SUBGROUP_KEY, TEXT_KEY)
from .targets import SURFACE_KINDS, SURFACE_OBJECTS, DataBlockError, object_problem, takes_layered_material
from .unused_data import remove_unused_own_data


def _warn_osl_scene(mat) -> None:
    scene = bpy.context.scene
    ok, reason = osl_backend.scene_supports_osl(scene)
    if not ok:
        warnings.warn(OSLSceneWarning(
            f"Layered BRDF: material '{mat.name}' runs OSL, but scene '{scene.name}' renders it black: {reason}. "
            "Set scene.render.engine = 'CYCLES' and scene.cycles.shading_system = True (and render on the CPU "
            "or OptiX), or apply with backend='nodes'"), stacklevel=3)


@functools.wraps(build.apply_layered_material)
def apply_layered_material(*args, **kwargs):
    mat = build.apply_layered_material(*args, **kwargs)
    sync.follow_build(mat)  # the panel's settings say what the script applied: the handlers keep it
    freshness.install()  # the render shows what a script does to the material next, registered or not
    if mat.get(BACKEND_KEY) == "osl":
        _warn_osl_scene(mat)
    return mat


__all__ = [
    "AOV_LOWER_NORMAL", "AOV_THICKNESS", "AOV_UPPER_NORMAL", "DISPLACED_KEY", "DataBlockError", "MATERIAL_KEY",
    "NAME_KEY", "OSLSceneWarning", "ROLE_KEY", "SHADER_NODE", "SLOT_KEY", "SUBGROUP_KEY", "SURFACE_KINDS", "SURFACE_OBJECTS",
    "TEXT_KEY", "animated_parameters", "apply_layered_material", "as_rendered", "check_node", "displaced_material",
    "input_linked", "input_value", "missing_inputs", "node_damage", "object_problem", "param_socket", "read_inputs",
    "remove_layered_material", "remove_unused_own_data", "set_inputs", "shader_node", "socket_parameters",
    "takes_layered_material", "tree_current",
]
