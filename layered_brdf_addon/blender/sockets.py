"""The shader node's input sockets: where each parameter's value lives, read and written.

Float parameters live in the add-on's shader node's input sockets (keyframes and drivers on
them animate final renders).  The node group's sockets are named for people ("Thickness
Min", the base colour's "Base Color"), the OSL shader's after the parameters ("d_min",
"BaseColor"); a node an older version built has one float socket per parameter, named after
it, and a "Base Color" that tinted its base colour channels.
"""
from __future__ import annotations

from ..backends import node_group as node_group_builder
from ..backends.osl_shader import SOCKET_NAMES
from ..model import ops_numpy
from ..model.params import (BASE_COLOR_SOCKET, LayeredParams, ParameterError, group_socket_name,
                            iter_sockets, socket_name, socket_units)
from ..model.shading.inputs import parameter_value
from ..model.socket_units import to_socket
from .stored_keys import BASE_CHANNELS

# The node group's socket names and the OSL shader's, either way round; a float parameter's
# socket in the group ("Thickness Min", "Upper Roughness") and in the OSL shader ("d_min",
# "upper_roughness"); the names of older versions ("e0", "Upper Exponent", "Tilt (°)") lead to the group's.
_SOCKET_ALIASES = {k: v for k, v in SOCKET_NAMES.items() if k != v}
_SOCKET_ALIASES.update({socket_name(spec): group_socket_name(spec) for spec in iter_sockets()
                        if spec.component is None})
_SOCKET_ALIASES.update({v: k for k, v in list(_SOCKET_ALIASES.items())})
_SOCKET_ALIASES.update({old: group_socket_name(spec) for spec in iter_sockets() if spec.component is None
                        for old in (spec.name, *spec.legacy_labels) if old != socket_name(spec)})


def find_socket(sockets, name):
    """The socket of ``sockets`` (a node's inputs or outputs) named ``name`` in the node group
    or in the OSL shader, or None."""
    return sockets.get(name) or sockets.get(_SOCKET_ALIASES.get(name, ""))


def param_socket(node, name: str):
    """``(socket, channel)`` of parameter ``name`` on the add-on's shader node (``channel``: the
    parameter's channel of a colour socket, else None), or ``(None, None)``.

    The node group's sockets are named for people ("Thickness Min", the base colour one "Base
    Color"), the OSL shader's after the parameters ("d_min", "BaseColor"); a node an older
    version built has one float socket per parameter, named after it."""
    spec = LayeredParams.spec(name)
    sock = node.inputs.get(spec.name)
    if sock is not None:
        return sock, None
    if spec.component is not None and has_channel_sockets(node):
        return None, None  # an older node's "Base Color" is its tint, not this channel
    label = group_socket_name(spec)
    for candidate in (label, SOCKET_NAMES.get(label, ""), socket_name(spec), *spec.legacy_labels):
        sock = node.inputs.get(candidate)
        if sock is not None:
            return sock, spec.component
    return None, None


def held_units(node, spec, sock) -> str:
    """What ``sock``, the add-on's node's socket of ``spec``, holds (:mod:`..model.socket_units`): a
    socket under this version's name holds its backend's units (the group's Roughness, its angles in
    radians), one under an older name ("e0", "Upper Exponent", "Tilt (°)") the parameter's."""
    if node.bl_idname == "ShaderNodeGroup":
        return socket_units(spec, "nodes") if sock.name == group_socket_name(spec) else ""
    # A script node's socket shows the parameter's label; its identifier is the parameter's name.
    return socket_units(spec, "osl") if sock.identifier == socket_name(spec) else ""


def socket_parameter(node, sock):
    """``(spec, units)`` of the float parameter that ``sock``, an input of the add-on's node, holds,
    or ``(None, "")``."""
    for spec in iter_sockets():
        if spec.component is None and param_socket(node, spec.name)[0] == sock:
            return spec, held_units(node, spec, sock)
    return None, ""


def has_channel_sockets(node) -> bool:
    """Whether ``node`` is an older node with one float socket per base colour channel."""
    return any(node.inputs.get(c) is not None for c in BASE_CHANNELS)


def legacy_tint(node):
    """An older node's tint ("Base Color" multiplied its base_r, base_g, base_b), or None."""
    if not has_channel_sockets(node):
        return None
    return find_socket(node.inputs, BASE_COLOR_SOCKET)


def _built_by_this_version(node) -> bool:
    """Whether ``node`` runs a node group this version of the add-on built (stamp and code)."""
    return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
        node.node_tree.get(node_group_builder.STAMP_KEY) == node_group_builder.build_stamp()


def missing_inputs(node) -> list[str]:
    """The parameters the add-on's shader node should have an input for and has not (the artist
    deleted or renamed a socket of its group).

    A node of this version has one for every parameter.  A node an older version built may lack
    the parameters that came after it, each addition whole (:attr:`ParamSpec.added`: the lower
    medium's r2 and k2 came with physical optics): such a node has none of an addition's inputs,
    and an upgrade gives them the material's values; the first version's parameters it must have."""
    specs = list(iter_sockets())
    present = {spec.name for spec in specs if param_socket(node, spec.name)[0] is not None}
    if _built_by_this_version(node):
        return [spec.name for spec in specs if spec.name not in present]
    additions_held = {spec.added for spec in specs if spec.added and spec.name in present}
    return [spec.name for spec in specs
            if spec.name not in present and (not spec.added or spec.added in additions_held)]


def node_damage(node) -> str | None:
    """What the add-on's shader node lacks (a parameter's input, its BSDF output), or None."""
    lacks = [f"the input of '{n}' ({group_socket_name(LayeredParams.spec(n))})" for n in missing_inputs(node)]
    if find_socket(node.outputs, "BSDF") is None:
        lacks.append("its BSDF output")
    return ", ".join(lacks) or None


def check_node(mat, node) -> None:
    """Raise ParameterError naming what ``mat``'s shader node lacks: such a node is rebuilt only
    when the material is applied again (a Rebuild, a preset), never behind the artist's back."""
    damage = node_damage(node)
    if damage is not None:
        raise ParameterError("material", mat.name, f"a Layered BRDF node with every socket: its node "
                             f"'{node.name}' lacks {damage}; Rebuild or load a preset to repair it")


def set_inputs(node, params: LayeredParams) -> None:
    """Write parameter values into the shader node's input sockets (the source of truth)."""
    for spec in iter_sockets():
        sock, channel = param_socket(node, spec.name)
        if sock is None:
            raise ParameterError("node", node.name, f"a Layered BRDF node with an input for every parameter: "
                                 f"it lacks the input of '{spec.name}' ({group_socket_name(spec)}); Rebuild or "
                                 "load a preset to repair it")
        value = float(getattr(params, spec.name))
        if channel is None:
            sock.default_value = to_socket(held_units(node, spec, sock), value)
        else:
            colour = list(sock.default_value)
            colour[channel] = value
            sock.default_value = colour


def input_value(node, name: str) -> float:
    """The value of parameter ``name`` in the shader node's sockets (an older node's base colour
    times its tint, as it rendered)."""
    sock, channel = param_socket(node, name)
    if channel is None:
        spec = LayeredParams.spec(name)
        units = held_units(node, spec, sock)
        if units:  # the parameter's value as the shader takes it from the socket
            return float(parameter_value(ops_numpy, spec, units, float(sock.default_value)))
    value = float(sock.default_value if channel is None else sock.default_value[channel])
    tint = legacy_tint(node) if name in BASE_CHANNELS else None
    if tint is not None and not tint.is_linked:
        value *= float(tint.default_value[BASE_CHANNELS.index(name)])
    return value


def input_linked(node, name: str) -> bool:
    """Whether a link feeds parameter ``name``'s socket."""
    sock, _ = param_socket(node, name)
    return sock is not None and sock.is_linked


def as_rendered(spec, value: float) -> float:
    """The value the shader renders for ``value`` in ``spec``'s socket: its input stage clamps to
    the parameter's range, and a NaN is the lower bound (so +inf the upper bound, -inf the lower)."""
    return float(ops_numpy.clamp_input(value, spec.min, spec.max))


def read_inputs(node, base: LayeredParams | None = None) -> LayeredParams:
    """Parameters from the shader node's sockets (enums from the material's stored settings), each
    as the shader renders it (:func:`as_rendered`: a NaN, an infinity or a value out of range, in a
    file of any version, reads as the bound the shader uses); a parameter newer than the node (a
    file saved before it existed) keeps ``base``'s value."""
    values = {spec.name: as_rendered(spec, input_value(node, spec.name)) for spec in iter_sockets()
              if param_socket(node, spec.name)[0] is not None}
    return LayeredParams.from_dict(values, base=base or LayeredParams())


def socket_parameters(node, socket_name: str) -> list[str]:
    """The parameters an input socket of the shader node holds (a colour socket: three)."""
    return [spec.name for spec in iter_sockets()
            if (sock := param_socket(node, spec.name)[0]) is not None and sock.name == socket_name]
