"""Which nodes of a material are the add-on's: recognised by their stamps, never by their names.

The add-on stamps each node it makes (:data:`~.stored_keys.ROLE_KEY`, and the name it had then
under :data:`~.stored_keys.NAME_KEY`, so that a Shift+D copy, which keeps the stamp but not the
name, is told apart); a shader node from before stamps is recognised by the node group or the
OSL text it runs.
"""
from __future__ import annotations

import re

from ..backends import node_group as node_group_builder
from .stored_keys import NAME_KEY, ROLE_KEY, SHADER_NODE, TEXT_KEY

_OSL_TEXT = re.compile(r"layered_brdf_.*\.osl")
#: The role of the Add Shader that adds a clear base (a Transparent BSDF tinted by the shader's
#: Transmittance, role "base") to the shader's BSDF, between it and what it fed.
CLEAR_BASE_ADD = "base_add"


def carries_shader(node) -> bool:
    """A node running the add-on's shader: a group stamped with its version, or its OSL text."""
    if node.bl_idname == "ShaderNodeGroup":
        return node.node_tree is not None and node.node_tree.get(node_group_builder.STAMP_KEY) is not None
    if node.bl_idname == "ShaderNodeScript":
        return node.script is not None and (node.script.get(TEXT_KEY) is not None
                                            or _OSL_TEXT.fullmatch(node.script.name) is not None)
    return False


def _feeds_something(node) -> bool:
    return any(sock.is_linked for sock in node.outputs)


def pick(candidates, *preferences):
    """The one of ``candidates`` the add-on owns: the only one, else the first preference that
    singles one out (a Shift+D copy keeps the stamp but not the name it was stamped with)."""
    if len(candidates) <= 1:
        return candidates[0] if candidates else None
    for prefer in (lambda n: n.get(NAME_KEY) == n.name, *preferences):
        chosen = [n for n in candidates if prefer(n)]
        if len(chosen) == 1:
            return chosen[0]
        if chosen:
            candidates = chosen
    return candidates[0]


def shader_node(mat):
    """The add-on's shader node in ``mat`` (group or script), or None.

    Recognised by its stamp (``node["layered_brdf_role"] == "shader"``), never by its name; a
    node from before stamps is recognised by the node group or OSL text it runs."""
    if mat.node_tree is None:
        return None
    nodes = mat.node_tree.nodes
    stamped = [n for n in nodes if n.get(ROLE_KEY) == "shader"]
    if stamped:
        return pick(stamped, _feeds_something)
    legacy = [n for n in nodes if carries_shader(n)]
    return pick(legacy, lambda n: n.name == SHADER_NODE, _feeds_something)


def stamp(node, role: str) -> None:
    """Mark ``node`` as the add-on's, in ``role`` ("shader", "aov" or "base")."""
    node[ROLE_KEY] = role
    node[NAME_KEY] = node.name


def active_output(tree):
    """The tree's active Material Output (the first one when none is active), or None."""
    outs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    return next((n for n in outs if n.is_active_output), outs[0] if outs else None)
