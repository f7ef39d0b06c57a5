"""The animation of the shader node's inputs: which parameters vary (keyframed, driven or fed by a
link), and keeping the artist's keyframes and drivers on the node when a rebuild replaces it.

A material's animation lives on its node tree (paths ``nodes["Layered BRDF"].inputs[3]...``)
or on the material itself (the same paths after ``node_tree.``): in its action, in the actions
of its NLA strips, and in its drivers.
"""
from __future__ import annotations

import re

from ..model.params import iter_sockets
from ..model.policy import THICKNESS_LINKED
from .own_nodes import shader_node
from .sockets import find_socket, input_linked, param_socket, socket_parameter, socket_parameters
from .unit_conversion import convert_fcurve

_STASH = "__layered_brdf_rebuild__"  # a placeholder node name while the shader is replaced
_SOCKET_PATH = re.compile(r'nodes\["(?P<node>(?:[^"\\]|\\.)*)"\]\.inputs\[(?P<index>\d+|"(?:[^"\\]|\\.)*")\]'
                          r'\.default_value')
_INPUT_INDEX = re.compile(r'\.inputs\[(\d+)\]')
_INPUT_NAME = re.compile(r'\.inputs\["((?:[^"\\]|\\.)*)"\]')


def _owners(mat):
    """(owner, the prefix of a node path from it) of the material's animation."""
    return ((mat.node_tree, ""), (mat, "node_tree."))


def _fcurves(owner):
    """The fcurves of ``owner``'s animation: its action's, its NLA strips' actions', its drivers."""
    ad = owner.animation_data
    if ad is None:
        return
    actions = [ad.action] + [strip.action for track in ad.nla_tracks for strip in track.strips]
    for action in actions:
        if action is None:
            continue
        for layer in action.layers:
            for strip in layer.strips:
                for bag in strip.channelbags:
                    yield from bag.fcurves
    yield from ad.drivers


def animated_paths(owner):
    """The data paths ``owner`` (a material or its node tree) animates or drives."""
    for fc in _fcurves(owner):
        yield fc.data_path


# --- which parameters vary -----------------------------------------------------------------------
def animated_parameters(mat, node=None) -> set[str]:
    """Shader inputs whose value varies: keyframed, driven, or fed by a link (of ``node``, a copy of the
    shader node in ``mat``; default the material's shader node)."""
    node = shader_node(mat) if node is None else node
    if node is None:
        return set()
    names = {s.name for s in iter_sockets() if input_linked(node, s.name)}
    for owner, prefix in _owners(mat):
        for path in animated_paths(owner):
            if not path.startswith(prefix):
                continue
            m = _SOCKET_PATH.fullmatch(path[len(prefix):])
            if m is None or m.group("node") != node.name:
                continue
            index = m.group("index")
            if index.isdigit():
                i = int(index)
                if i < len(node.inputs):
                    names.update(socket_parameters(node, node.inputs[i].name))
            else:
                key = index[1:-1]
                sock = find_socket(node.inputs, key)
                names.update(socket_parameters(node, sock.name) if sock is not None else [key])
    names &= {s.name for s in iter_sockets()}
    thickness = find_socket(node.inputs, THICKNESS_LINKED)
    if thickness is not None and thickness.is_linked:
        names.add(THICKNESS_LINKED)
    return names


# --- keeping the artist's animation across a rebuild ---------------------------------------------
def _node_prefix(name: str) -> str:
    return 'nodes["' + name.replace("\\", "\\\\").replace('"', '\\"') + '"]'


def stash_animation(mat, name: str) -> list:
    """Point the fcurves and drivers of node ``name`` at a placeholder, so removing the node
    (which deletes the animation of a node) leaves them; :func:`restore_animation` re-points them."""
    stashed = []
    for owner, prefix in _owners(mat):
        head = prefix + _node_prefix(name)
        for fc in _fcurves(owner):
            if fc.data_path.startswith(head):
                rest = fc.data_path[len(head):]
                fc.data_path = prefix + _node_prefix(_STASH) + rest
                stashed.append((fc, prefix, rest))
    return stashed


def restore_animation(mat, stashed, node, old_inputs) -> None:
    """Re-point stashed fcurves at ``node``, input sockets by name (their order may differ).
    ``old_inputs``: (name, units) of the old node's inputs; an fcurve of a socket whose units
    changed (an exponent that is now a Roughness) is converted (:mod:`.unit_conversion`)."""
    params = {spec.name for spec in iter_sockets()}
    old_units = dict(old_inputs)
    drivers = {fc.as_pointer() for owner, _ in _owners(mat) if owner.animation_data
               for fc in owner.animation_data.drivers}

    def new_input(old_name):
        if old_name in params:  # an older node's socket of a parameter: maybe a colour's channel now
            return param_socket(node, old_name)
        return find_socket(node.inputs, old_name), None

    for fc, prefix, rest in stashed:
        m = _INPUT_INDEX.match(rest)
        sock, channel, old_name = None, None, None
        if m is not None:
            i = int(m.group(1))
            if i < len(old_inputs):
                old_name = old_inputs[i][0]
                sock, channel = new_input(old_name)
            if sock is not None:
                index = next(k for k, s in enumerate(node.inputs) if s == sock)
                rest = f".inputs[{index}]" + rest[m.end():]
        else:
            m = _INPUT_NAME.match(rest)
            if m is not None:
                old_name = m.group(1)
                sock, channel = new_input(old_name)
                if sock is not None:
                    rest = f'.inputs["{sock.name}"]' + rest[m.end():]
        fc.data_path = prefix + _node_prefix(node.name) + rest
        if channel is not None:
            fc.array_index = channel
        if sock is not None and channel is None:
            spec, units = socket_parameter(node, sock)
            if spec is not None:
                convert_fcurve(fc, old_units.get(old_name, ""), units, fc.as_pointer() in drivers)
