"""apply_layered_material: the one function the UI, the CLI and the tests call."""
from __future__ import annotations

import re
from collections.abc import Mapping

import bpy

from ..model.params import LOWER_MEDIUM_KEYS, ParameterError, LayeredParams, group_socket_name, iter_sockets
from ..model.plan import EffectPlan
from ..model import ops_numpy, policy
from ..model.policy import plan_effects
from ..model.base_layers import base_node
from . import osl as osl_backend
from ..backends import node_group as node_group_builder
from ..backends.osl_shader import SOCKET_NAMES

MATERIAL_KEY = "layered_brdf"  # custom property marking materials made by the add-on
AOV_THICKNESS = "layer_thickness"
AOV_LOWER_NORMAL = "lower_normal"
AOV_UPPER_NORMAL = "upper_normal"  # Cycles' Normal pass averages closure normals: not n0 here
SHADER_NODE = "Layered BRDF"  # the name of a new shader node (the artist may rename it)
ROLE_KEY = "layered_brdf_role"  # on the add-on's nodes: "shader", "aov" or "base" (never matched by name)
NAME_KEY = "layered_brdf_name"  # on the add-on's nodes: their name when stamped (a Shift+D copy differs)
TEXT_KEY = "layered_brdf_text"  # on the OSL texts the add-on writes
DISPLACED_KEY = "layered_brdf_displaced"  # the artist's material the layered one replaced in its slot
SLOT_KEY = "layered_brdf_slot"  # how the slot got the layered material: "added", "filled" or "replaced"
SUBGROUP_KEY = "layered_brdf_stamp"  # on the sub-groups the node groups use
_OSL_TEXT = re.compile(r"layered_brdf_.*\.osl")


class DataBlockError(ParameterError):
    """An object or material that cannot take the layered material, said in its own words
    ("object 'Empty' (EMPTY) has no material slots: ..."): a ParameterError, so the panel, the
    operators and the command line treat it as invalid input; ``name`` is ``"object"`` or
    ``"material"``, ``value`` the data block's name."""

    def __init__(self, kind: str, data_block, allowed: str, message: str):
        super().__init__(kind, data_block.name, allowed)
        self.args = (message,)


class _Shown:
    """A value of the wrong type as a message shows it: its type, never a long repr."""

    def __init__(self, value):
        self.text = f"<{type(value).__name__}>"

    def __repr__(self) -> str:
        return self.text


def _shown(value):
    """``value`` itself when its repr is short (None, a number), else :class:`_Shown`."""
    return value if value is None or isinstance(value, (bool, int, float)) else _Shown(value)


# The object types that render a material's surface shader. Grease Pencil objects take Grease
# Pencil materials, not shader node materials; a volume renders only a material's Volume output.
SURFACE_OBJECTS = frozenset({"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD"})
SURFACE_KINDS = "a mesh, curve, surface, metaball, text, hair curves or point cloud object"
_GREASE_PENCIL = ("GREASEPENCIL", "GPENCIL")


def takes_layered_material(obj) -> bool:
    """Whether ``obj`` is of a type that renders the layered material (a mesh, curve, text...)."""
    return obj is not None and obj.type in SURFACE_OBJECTS and hasattr(obj.data, "materials")


def _kind_problem(obj) -> str | None:
    """Why an object of ``obj``'s type cannot carry the layered material, or None."""
    if takes_layered_material(obj):
        return None
    head = f"object '{obj.name}' ({obj.type})"
    if obj.type in _GREASE_PENCIL:
        return f"{head} is a Grease Pencil object: its materials are Grease Pencil materials, " \
               f"not shader node materials; choose {SURFACE_KINDS}"
    if obj.type == "VOLUME":
        return f"{head} renders only a material's Volume output, not a surface shader; choose {SURFACE_KINDS}"
    return f"{head} has no material slots: choose {SURFACE_KINDS}"


def _linked_problem(obj, index: int | None = None) -> str | None:
    """Why a material cannot be written into ``obj``'s slot ``index`` (None: the active slot, or a
    new one when it has none), or None: edits to linked data are not saved (reopening the file
    reads the library again), so a linked object, and a slot (or a new slot) of linked object data,
    are refused; a library override's own slot (a slot linked to the Object) and an overridden
    mesh's existing slot keep the edit."""
    if obj.library is not None:
        return f"object '{obj.name}' is linked from {obj.library.filepath}: make it local first " \
               "(edits to linked data are not saved)"
    data = obj.data
    slots = obj.material_slots
    if slots and slots[obj.active_material_index if index is None else index].link == "OBJECT":
        return None
    if data.library is not None:
        where = "the slot is linked to the data" if slots else "a new slot would go in the data"
        return f"object '{obj.name}': its data '{data.name}' is linked from {data.library.filepath} " \
               f"and {where}; make the data local first, or link the slot to the Object " \
               "(edits to linked data are not saved)"
    if not slots and data.override_library is not None:
        return f"object '{obj.name}': its data '{data.name}' is a library override, which cannot keep " \
               "a new material slot; add the slot in the library, or make the data local first"
    return None


def object_problem(obj) -> str | None:
    """Why ``obj`` cannot be given the layered material now, or None."""
    return _kind_problem(obj) or _linked_problem(obj)


def _check_object(obj) -> None:
    """Raise DataBlockError unless ``obj`` is a local object of a type that renders the material."""
    problem = _kind_problem(obj)
    if problem is not None:
        raise DataBlockError("object", obj, SURFACE_KINDS, problem)
    if obj.library is not None:
        raise DataBlockError("object", obj, "a local object", _linked_problem(obj))


def _check_local_material(mat) -> None:
    if mat.library is not None:
        raise DataBlockError("material", mat, "a local material",
                             f"material '{mat.name}' is linked from {mat.library.filepath}: make it local first "
                             "(edits to linked data are not saved)")


def _object_argument(value, argument: str):
    """The object ``value`` names (an object or its name), or ParameterError naming ``argument``."""
    if isinstance(value, bpy.types.Object):
        return value
    if isinstance(value, str):
        obj = bpy.data.objects.get(value)
        if obj is None:
            raise ParameterError(argument, value, "the name of an object in the file: "
                                 + ", ".join(sorted(o.name for o in bpy.data.objects))[:400])
        return obj
    raise ParameterError(argument, _shown(value), "an object (bpy.types.Object) or its name"
                         + (", or a material" if argument == "target" else ""))


def _params_argument(params) -> LayeredParams:
    """``params`` as validated parameters: a LayeredParams, a mapping of parameter values (checked
    by the parameter table, unknown names refused) or None for the defaults."""
    if params is None:
        return LayeredParams().validate()
    if isinstance(params, LayeredParams):
        return params.validate()
    if isinstance(params, Mapping):
        return LayeredParams.from_dict(dict(params))
    raise ParameterError("params", _shown(params), "a LayeredParams, a dict of parameter values or None")


def _material_for(target, name):
    if isinstance(target, bpy.types.Material):
        _check_local_material(target)
        return target
    obj = _object_argument(target, "target")
    _check_object(obj)
    mat = None
    if obj.active_material is not None and obj.active_material.get(MATERIAL_KEY):
        mat = obj.active_material
    if mat is not None and mat.library is not None:
        raise DataBlockError("object", obj, "an object whose material is local",
                             f"object '{obj.name}': its material '{mat.name}' is linked from "
                             f"{mat.library.filepath}: make it local first (edits to linked data are not saved)")
    if mat is not None:
        return mat
    problem = _linked_problem(obj)
    if problem is not None:
        raise DataBlockError("object", obj, "an object whose slot can be saved", problem)
    mat = bpy.data.materials.new(name)
    mat[MATERIAL_KEY] = True
    mat.node_tree.nodes.clear()  # a new material's default Principled BSDF is not ours to keep
    if obj.material_slots:
        # The slot the object renders: the object's own when the slot is linked to the Object.
        slot = obj.material_slots[obj.active_material_index]
        displaced = slot.material
        slot.material = mat
        if displaced is not None:
            mat[DISPLACED_KEY] = displaced  # an ID pointer: a user, so it is saved; Remove puts it back
        mat[SLOT_KEY] = "replaced" if displaced is not None else "filled"
    else:
        obj.data.materials.append(mat)
        mat[SLOT_KEY] = "added"
    return mat


def _carries_shader(node) -> bool:
    """A node running the add-on's shader: a group stamped with its version, or its OSL text."""
    if node.bl_idname == "ShaderNodeGroup":
        return node.node_tree is not None and node.node_tree.get(node_group_builder.STAMP_KEY) is not None
    if node.bl_idname == "ShaderNodeScript":
        return node.script is not None and (node.script.get(TEXT_KEY) is not None
                                            or _OSL_TEXT.fullmatch(node.script.name) is not None)
    return False


def _feeds_something(node) -> bool:
    return any(sock.is_linked for sock in node.outputs)


def _pick(candidates, *preferences):
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
        return _pick(stamped, _feeds_something)
    legacy = [n for n in nodes if _carries_shader(n)]
    return _pick(legacy, lambda n: n.name == SHADER_NODE, _feeds_something)


def _stamp(node, role: str) -> None:
    node[ROLE_KEY] = role
    node[NAME_KEY] = node.name


def _helper_nodes(tree, shader) -> list:
    """The add-on's AOV outputs and base shader around ``shader`` (stamped, or unstamped ones
    an older version made: linked to ``shader`` and named as it named them)."""
    own = []
    aovs = {}
    for n in tree.nodes:
        if n.get(ROLE_KEY) == "aov":
            aovs.setdefault(n.aov_name if n.bl_idname == "ShaderNodeOutputAOV" else "", []).append(n)
    linked_from_shader = lambda n: any(l.from_node == shader for s in n.inputs for l in s.links)
    for group in aovs.values():
        own.append(_pick(group, linked_from_shader))
    own += [_pick([n for n in tree.nodes if n.get(ROLE_KEY) == "base"],
                  lambda n: any(l.to_node == shader for s in n.outputs for l in s.links))]
    if shader is not None and shader.get(ROLE_KEY) is None:  # made before stamps
        for sock in shader.outputs:
            for link in sock.links:
                n = link.to_node
                if n.bl_idname == "ShaderNodeOutputAOV" and n.name.startswith(OWN_PREFIX) and \
                        n.aov_name in (AOV_THICKNESS, AOV_LOWER_NORMAL, AOV_UPPER_NORMAL):
                    own.append(n)
        base_in = _socket(shader.inputs, "Base Shader")
        for link in (base_in.links if base_in is not None else ()):
            n = link.from_node
            if n.bl_idname == "ShaderNodeBsdfTransparent" and n.name.startswith(OWN_PREFIX):
                own.append(n)
    return list(dict.fromkeys(n for n in own if n is not None))


def _claim(mat):
    """Stamp the add-on's own nodes in ``mat`` (adopting those made before stamps) and unstamp
    the artist's copies of them; returns (shader node or None, all the add-on's nodes)."""
    tree = mat.node_tree
    shader = shader_node(mat)
    own = ([shader] if shader is not None else []) + _helper_nodes(tree, shader)
    for n in own:
        if n.get(ROLE_KEY) is None:
            _stamp(n, "shader" if n == shader else "aov" if n.bl_idname == "ShaderNodeOutputAOV" else "base")
        elif n.get(NAME_KEY) != n.name:
            n[NAME_KEY] = n.name  # renamed by the artist: still ours
    for n in tree.nodes:
        if n.get(ROLE_KEY) is not None and n not in own:  # a copy the artist made: theirs
            del n[ROLE_KEY]
            if NAME_KEY in n:
                del n[NAME_KEY]
    if shader is not None and shader.bl_idname == "ShaderNodeScript" and shader.script is not None \
            and shader.script.get(TEXT_KEY) is None:
        shader.script[TEXT_KEY] = True
    return shader, own


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
    if spec.component is not None and _has_channel_sockets(node):
        return None, None  # an older node's "Base Color" is its tint, not this channel
    label = group_socket_name(spec)
    for candidate in (label, SOCKET_NAMES.get(label, "")):
        sock = node.inputs.get(candidate)
        if sock is not None:
            return sock, spec.component
    return None, None


def _has_channel_sockets(node) -> bool:
    """Whether ``node`` is an older node with one float socket per base colour channel."""
    return any(node.inputs.get(c) is not None for c in BASE_CHANNELS)


def _legacy_tint(node):
    """An older node's tint ("Base Color" multiplied its base_r, base_g, base_b), or None."""
    if not _has_channel_sockets(node):
        return None
    return _socket(node.inputs, "Base Color")


def _built_by_this_version(node) -> bool:
    """Whether ``node`` runs a node group this version of the add-on built (stamp and code)."""
    return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
        node.node_tree.get(node_group_builder.STAMP_KEY) == node_group_builder.build_stamp()


def missing_inputs(node) -> list[str]:
    """The parameters the add-on's shader node should have an input for and has not (the artist
    deleted or renamed a socket of its group).

    A node of this version has one for every parameter.  A node an older version built may lack
    the lower medium's (r2, k2, added with physical optics; it then has none of them, and an
    upgrade gives them the material's values); every other parameter was in the first version."""
    lower = [k for k in LOWER_MEDIUM_KEYS if param_socket(node, k)[0] is not None]
    expected = [s.name for s in iter_sockets()
                if s.name not in LOWER_MEDIUM_KEYS or lower or _built_by_this_version(node)]
    return [name for name in expected if param_socket(node, name)[0] is None]


def node_damage(node) -> str | None:
    """What the add-on's shader node lacks (a parameter's input, its BSDF output), or None."""
    lacks = [f"the input of '{n}' ({group_socket_name(LayeredParams.spec(n))})" for n in missing_inputs(node)]
    if _socket(node.outputs, "BSDF") is None:
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
            sock.default_value = value
        else:
            colour = list(sock.default_value)
            colour[channel] = value
            sock.default_value = colour


def input_value(node, name: str) -> float:
    """The value of parameter ``name`` in the shader node's sockets (an older node's base colour
    times its tint, as it rendered)."""
    sock, channel = param_socket(node, name)
    value = float(sock.default_value if channel is None else sock.default_value[channel])
    tint = _legacy_tint(node) if name in BASE_CHANNELS else None
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


OWN_PREFIX = "Layered BRDF"  # nodes the add-on creates (and may delete); the artist's are kept
BASE_CHANNELS = ("base_r", "base_g", "base_b")
# The node group's socket names and the OSL shader's, either way round; a float parameter's
# socket in the group ("Thickness Min") and in the OSL shader and older groups ("d_min").
_SOCKET_ALIASES = {k: v for k, v in SOCKET_NAMES.items() if k != v}
_SOCKET_ALIASES.update({spec.name: group_socket_name(spec) for spec in iter_sockets() if spec.component is None})
_SOCKET_ALIASES.update({v: k for k, v in list(_SOCKET_ALIASES.items())})


def _socket(sockets, name):
    return sockets.get(name) or sockets.get(_SOCKET_ALIASES.get(name, ""))


def _active_output(tree):
    outs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"]
    return next((n for n in outs if n.is_active_output), outs[0] if outs else None)


def _build_tree(mat, params: LayeredParams, backend: str, plan: EffectPlan, old, own):
    """(Re)build the add-on's nodes (``old`` the shader node, ``own`` every node of the add-on)
    in ``mat``.  The artist's nodes are kept, and so are their links to and from the shader
    node: the new node feeds whatever the old one fed (a Mix Shader, the Material Output)."""
    tree = mat.node_tree
    keep_in, keep_out = [], []
    name, label, width, parent, location = SHADER_NODE, SHADER_NODE, 220, None, None
    legacy_base = None
    if old is not None:
        for sock in old.inputs:
            for link in sock.links:
                if link.from_node not in own:
                    keep_in.append((link.from_socket, sock.name))
        for sock in old.outputs:
            for link in sock.links:
                if link.to_node not in own:
                    keep_out.append((sock.name, link.to_socket))
        name, label, width, parent = old.name, old.label, old.width, old.parent
        location = tuple(old.location)
        old_inputs = [sock.name for sock in old.inputs]
        stashed = _stash_animation(mat, old.name)
        legacy_base = _legacy_base_links(old, params)
        if legacy_base is not None:
            handled = {*BASE_CHANNELS, _legacy_tint(old).name}
            keep_in = [(src, sock_name) for src, sock_name in keep_in if sock_name not in handled]
    for n in own:
        tree.nodes.remove(n)
    out = _active_output(tree)
    if out is None:
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.location = (400, 0)
    if backend == "nodes":
        group = _group_for(plan)
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
    else:
        node = tree.nodes.new("ShaderNodeScript")
        node.mode = "INTERNAL"
        text = osl_backend.text_for(plan)
        text[TEXT_KEY] = True
        osl_backend.compile_script_node(node, script=text)
    node.name = name
    node.label = label
    node.width = width
    if parent is not None:
        node.parent = parent
    node.location = location if location is not None else (out.location[0] - 300, out.location[1])
    _stamp(node, "shader")
    if old is None:  # a first build: the material shows the layered shader
        tree.links.new(_socket(node.outputs, "BSDF"), out.inputs["Surface"])
    for from_socket, sock_name in keep_in:
        target = _socket(node.inputs, sock_name)
        if target is not None:
            tree.links.new(from_socket, target)
    for sock_name, to_socket in keep_out:
        source = _socket(node.outputs, sock_name)
        if source is not None:
            tree.links.new(source, to_socket)
    if old is not None:
        _restore_animation(mat, stashed, node, old_inputs)
    if legacy_base is not None:
        _link_legacy_base(tree, node, *legacy_base)
    base_in = _socket(node.inputs, "Base Shader")
    spec = base_node(params)
    if spec is not None and base_in is not None and not base_in.is_linked:
        base = tree.nodes.new(spec.node_type)
        base.name = base.label = f"{OWN_PREFIX} {spec.label}"
        base.location = (node.location[0] - 250, node.location[1] - 300)
        if parent is not None:
            base.parent = parent
        _stamp(base, "base")
        tree.links.new(base.outputs[0], base_in)
    for k, (aov_name, socket_name, kind) in enumerate(((AOV_THICKNESS, "Thickness", "Value"),
                                                       (AOV_LOWER_NORMAL, "Lower Normal", "Color"),
                                                       (AOV_UPPER_NORMAL, "Upper Normal", "Color"))):
        src = _socket(node.outputs, socket_name)
        if src is None:
            continue
        aov = tree.nodes.new("ShaderNodeOutputAOV")
        aov.name = aov.label = f"{OWN_PREFIX} AOV {aov_name}"
        aov.aov_name = aov_name
        aov.location = (out.location[0], out.location[1] - 200 - 150 * k)
        _stamp(aov, "aov")
        tree.links.new(src, aov.inputs[kind])
    return node


def _legacy_base_links(old, params: LayeredParams):
    """An older node whose base colour channels or tint are linked: ``(channels, tint)``, each a
    linked output socket or the socket's value (a channel whose socket is gone: its value in
    ``params``); None when nothing there is linked (then the values carry over through
    :func:`read_inputs`)."""
    tint = _legacy_tint(old)
    if tint is None:
        return None
    socks = [old.inputs.get(c) for c in BASE_CHANNELS]
    if not tint.is_linked and not any(sock is not None and sock.is_linked for sock in socks):
        return None
    source = lambda sock: sock.links[0].from_socket if sock.is_linked else tuple(sock.default_value) \
        if sock.type == "RGBA" else float(sock.default_value)
    channels = [source(sock) if sock is not None else float(getattr(params, c))
                for sock, c in zip(socks, BASE_CHANNELS)]
    return channels, source(tint)


def _link_legacy_base(tree, node, channels, tint) -> None:
    """What fed an older node's base colour channels and tint, rebuilt as the artist's own nodes
    (Combine Color, times the tint) feeding the one Base Color socket: the same colour."""
    target = _socket(node.inputs, "Base Color")
    x, y = node.location[0] - 420, node.location[1] - 200
    combine = tree.nodes.new("ShaderNodeCombineColor")
    combine.label = "Base Color (from an older Layered BRDF)"
    combine.location = (x, y)
    made = [combine]
    for k, value in enumerate(channels):
        if isinstance(value, float):
            combine.inputs[k].default_value = value
        else:
            tree.links.new(value, combine.inputs[k])
    result = combine.outputs[0]
    if not isinstance(tint, tuple) or tint[:3] != (1.0, 1.0, 1.0):
        mix = tree.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        mix.blend_type = "MULTIPLY"
        mix.label = "Base tint (from an older Layered BRDF)"
        mix.location = (x + 200, y)
        made.append(mix)
        mix.inputs["Factor"].default_value = 1.0
        tree.links.new(result, mix.inputs[6])
        if isinstance(tint, tuple):
            mix.inputs[7].default_value = tint
        else:
            tree.links.new(tint, mix.inputs[7])
        result = mix.outputs[2]
    for n in made:
        n.parent = node.parent
    tree.links.new(result, target)


def _shader_output(node):
    return next((s for s in node.outputs if s.type == "SHADER"), None)


def _end_of_chain(node):
    """Following shader links from ``node``: the last node whose shader output feeds nothing."""
    seen = set()
    while node is not None and node.as_pointer() not in seen:
        seen.add(node.as_pointer())
        sock = _shader_output(node)
        if sock is None:
            return None
        if not sock.is_linked:
            return node
        node = sock.links[0].to_node
    return None


def _repair(mat, node) -> None:
    """Make a damaged tree render the layered shader again, touching none of the artist's nodes:
    a Material Output when there is none, fed by the end of the shader's chain; the shader's
    BSDF linked to the output's Surface when it feeds nothing and the Surface is free."""
    tree = mat.node_tree
    bsdf = _socket(node.outputs, "BSDF")
    out = _active_output(tree)
    if out is None:
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.location = (node.location[0] + 300, node.location[1])
        if node.parent is not None:
            out.parent = node.parent
        end = _end_of_chain(node)
        if end is not None:
            tree.links.new(_shader_output(end), out.inputs["Surface"])
        return
    if bsdf is not None and not bsdf.is_linked and not out.inputs["Surface"].is_linked:
        tree.links.new(bsdf, out.inputs["Surface"])


# --- keeping the artist's animation across a rebuild -----------------------------------------
_STASH = "__layered_brdf_rebuild__"  # a placeholder node name while the shader is replaced


def _node_prefix(name: str) -> str:
    return 'nodes["' + name.replace("\\", "\\\\").replace('"', '\\"') + '"]'


def _fcurve_owners(mat):
    """(owner, path prefix, fcurves) of the material's and its node tree's animation and drivers."""
    for owner, prefix in ((mat.node_tree, ""), (mat, "node_tree.")):
        ad = owner.animation_data
        if ad is None:
            continue
        actions = [ad.action] + [strip.action for track in ad.nla_tracks for strip in track.strips]
        for action in actions:
            if action is None:
                continue
            for layer in action.layers:
                for strip in layer.strips:
                    for bag in strip.channelbags:
                        yield prefix, bag.fcurves
        yield prefix, ad.drivers


def _stash_animation(mat, name: str) -> list:
    """Point the fcurves and drivers of node ``name`` at a placeholder, so removing the node
    (which deletes the animation of a node) leaves them; :func:`_restore_animation` re-points them."""
    stashed = []
    for prefix, fcurves in _fcurve_owners(mat):
        head = prefix + _node_prefix(name)
        for fc in fcurves:
            if fc.data_path.startswith(head):
                rest = fc.data_path[len(head):]
                fc.data_path = prefix + _node_prefix(_STASH) + rest
                stashed.append((fc, prefix, rest))
    return stashed


_INPUT_INDEX = re.compile(r'\.inputs\[(\d+)\]')
_INPUT_NAME = re.compile(r'\.inputs\["((?:[^"\\]|\\.)*)"\]')


def _restore_animation(mat, stashed, node, old_inputs) -> None:
    """Re-point stashed fcurves at ``node``, input sockets by name (their order may differ)."""
    params = {spec.name for spec in iter_sockets()}

    def new_input(old_name):
        if old_name in params:  # an older node's socket of a parameter: maybe a colour's channel now
            return param_socket(node, old_name)
        return _socket(node.inputs, old_name), None

    for fc, prefix, rest in stashed:
        m = _INPUT_INDEX.match(rest)
        sock, channel = None, None
        if m is not None:
            i = int(m.group(1))
            if i < len(old_inputs):
                sock, channel = new_input(old_inputs[i])
            if sock is not None:
                index = next(k for k, s in enumerate(node.inputs) if s == sock)
                rest = f".inputs[{index}]" + rest[m.end():]
        else:
            m = _INPUT_NAME.match(rest)
            if m is not None:
                sock, channel = new_input(m.group(1))
                if sock is not None:
                    rest = f'.inputs["{sock.name}"]' + rest[m.end():]
        fc.data_path = prefix + _node_prefix(node.name) + rest
        if channel is not None:
            fc.array_index = channel


# --- the add-on's own data blocks -------------------------------------------------------------
def _script_texts_in_use() -> set:
    trees = [m.node_tree for m in bpy.data.materials if m.node_tree is not None]
    trees += list(bpy.data.node_groups)
    used = set()
    for tree in trees:
        for n in tree.nodes:
            if n.bl_idname == "ShaderNodeScript" and n.script is not None:
                used.add(n.script.name)
    for screen in bpy.data.screens:
        for area in screen.areas:
            for space in area.spaces:
                if space.type == "TEXT_EDITOR" and space.text is not None:
                    used.add(space.text.name)
    return used


def remove_unused_own_data() -> list[str]:
    """Remove the add-on's node groups and OSL texts (stamped) that nothing uses any more.

    A group counts as unused when its only user is its fake user (asset marking sets one);
    a text when no Script node runs it and no Text Editor shows it.  Unstamped, linked or
    used data blocks are never touched.  Returns the names removed."""
    removed = []
    while True:
        stale = [g for g in bpy.data.node_groups
                 if g.library is None and (g.get(node_group_builder.STAMP_KEY) is not None
                                           or g.get(SUBGROUP_KEY) is not None)
                 and g.users - int(g.use_fake_user) <= 0]
        if not stale:
            break
        for g in stale:
            removed.append(g.name)
            bpy.data.node_groups.remove(g)
    used = _script_texts_in_use()
    for t in [t for t in bpy.data.texts if t.library is None and t.get(TEXT_KEY) is not None
              and t.name not in used]:
        removed.append(t.name)
        bpy.data.texts.remove(t)
    return removed


_SOCKET_PATH = re.compile(r'nodes\["(?P<node>(?:[^"\\]|\\.)*)"\]\.inputs\[(?P<index>\d+|"(?:[^"\\]|\\.)*")\]'
                          r'\.default_value')


def _action_paths(action):
    if action is None:
        return
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                for fc in bag.fcurves:
                    yield fc.data_path


def _animated_paths(owner):
    ad = owner.animation_data
    if ad is None:
        return
    yield from _action_paths(ad.action)
    for track in ad.nla_tracks:
        for strip in track.strips:
            yield from _action_paths(strip.action)
    for fc in ad.drivers:
        yield fc.data_path


def animated_parameters(mat) -> set[str]:
    """Shader inputs whose value varies: keyframed, driven, or fed by a link."""
    node = shader_node(mat)
    if node is None:
        return set()
    names = {s.name for s in iter_sockets() if input_linked(node, s.name)}
    prefixes = ((mat.node_tree, ""), (mat, "node_tree."))
    for owner, prefix in prefixes:
        for path in _animated_paths(owner):
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
                sock = _socket(node.inputs, key)
                names.update(socket_parameters(node, sock.name) if sock is not None else [key])
    return names & {s.name for s in iter_sockets()}


def apply_layered_material(target, params: LayeredParams | None = None, backend: str = "nodes",
                           plan: EffectPlan | None = None, name: str = "Layered BRDF"):
    """Give ``target`` (an object, its name, or a material) the layered material.

    ``params``: a LayeredParams, a dict of parameter values (validated like a preset file) or
    None (the defaults).  A wrong type, an object of a type that renders no surface shader (an
    Empty, a Grease Pencil object...) or linked data raises ParameterError, with nothing changed.
    Idempotent: applying again reuses the material and the node group, rebuilds the
    material's tree only when the backend or the plan of active effects changed, and
    otherwise only writes the parameter values into the shader's input sockets.
    ``plan`` defaults to :func:`plan_effects` of ``params`` (``EffectPlan.full()`` gives
    the always-full shader).  Returns the material.
    """
    params = _params_argument(params)
    if plan is not None and not isinstance(plan, EffectPlan):
        raise ParameterError("plan", _shown(plan), "an EffectPlan or None (the plan of the parameters)")
    if not isinstance(name, str) or not name:
        raise ParameterError("name", name if isinstance(name, str) else _shown(name), "a material name (text)")
    policy.check_backend(backend, params.lobe)
    mat = _material_for(target, name)
    plan = plan or plan_effects(params, animated_parameters(mat))
    if plan.lobe != params.lobe:
        plan = EffectPlan(**{**plan.to_dict(), "lobe": params.lobe})
    node, own = _claim(mat)
    key = f"{backend}:{plan.key}:{params.base_layer}"
    if node is None or mat.get("layered_brdf_build") != key or not _node_current(node, backend, plan):
        node = _build_tree(mat, params, backend, plan, node, own)
        mat["layered_brdf_build"] = key
        remove_unused_own_data()
    _repair(mat, node)
    set_inputs(node, params)
    _set_base_inputs(node, params)
    mat["layered_brdf_backend"] = backend
    mat["layered_brdf_enums"] = {s.name: getattr(params, s.name) for s in LayeredParams.specs() if s.kind == "enum"}
    return mat


def _set_base_inputs(node, params: LayeredParams) -> None:
    """Write the values of the add-on's base node (a metal's colour and roughness follow the
    parameters) when the add-on's own base node feeds ``node``'s Base Shader input."""
    spec = base_node(params)
    base_in = _socket(node.inputs, "Base Shader")
    if spec is None or base_in is None:
        return
    for link in base_in.links:
        base = link.from_node
        if base.get(ROLE_KEY) == "base" and base.bl_idname == spec.node_type:
            for name, value in spec.inputs.items():
                base.inputs[name].default_value = value


def _group_lacks_sockets(group) -> bool:
    """Whether the add-on's node group lacks a socket it builds for a parameter, or its BSDF output."""
    items = [i for i in group.interface.items_tree if i.item_type == "SOCKET"]
    inputs = {i.name for i in items if i.in_out == "INPUT"}
    outputs = {i.name for i in items if i.in_out == "OUTPUT"}
    return "BSDF" not in outputs or any(group_socket_name(s) not in inputs for s in iter_sockets())


def _group_for(plan: EffectPlan):
    """The node group for ``plan`` (:func:`node_group_builder.ensure_group`). A group stamped as
    current that lacks a socket (the artist deleted one) is marked stale first, so it is rebuilt,
    or set aside while other materials still use it (each is repaired when applied again)."""
    group = node_group_builder.ensure_group(plan)
    if _group_lacks_sockets(group):
        del group[node_group_builder.PLAN_KEY]
        group = node_group_builder.ensure_group(plan)
    return group


def _node_current(node, backend, plan) -> bool:
    if node_damage(node) is not None:
        return False
    if backend == "nodes":
        return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
            node_group_builder.is_current(node.node_tree, plan)
    return node.bl_idname == "ShaderNodeScript" and node.script is not None and \
        node.script.as_string() == osl_backend.source(plan)


def displaced_material(mat):
    """The artist's material that ``mat`` replaced in an object's slot (Remove puts it back), or None."""
    other = mat.get(DISPLACED_KEY)
    return other if isinstance(other, bpy.types.Material) else None


def remove_layered_material(obj) -> bool:
    """Remove the add-on's material from ``obj`` (an object or its name): from its active slot,
    else its first layered slot, and put back the material it replaced there; True when one was
    removed.  A linked object is refused (the edit would not be saved)."""
    obj = _object_argument(obj, "obj")
    if obj.library is not None:
        raise DataBlockError("object", obj, "a local object", _linked_problem(obj))
    slots = list(obj.material_slots)
    order = [obj.active_material_index] + list(range(len(slots))) if slots else []
    i = next((i for i in order if i < len(slots) and slots[i].material is not None
              and slots[i].material.get(MATERIAL_KEY)), None)
    if i is None:
        return False
    problem = _linked_problem(obj, i)
    if problem is not None:
        raise DataBlockError("object", obj, "an object whose slot can be saved", problem)
    slot = slots[i]
    mat = slot.material
    displaced = displaced_material(mat)
    how = mat.get(SLOT_KEY)
    if displaced is not None:
        slot.material = displaced
    elif how in ("replaced", "filled") or slot.link == "OBJECT":
        slot.material = None
    else:  # the slot was added for it (or the material predates this record)
        _remove_slot(obj, i)
    for key in (DISPLACED_KEY, SLOT_KEY):
        if key in mat:
            del mat[key]
    return True


def _remove_slot(obj, index: int) -> None:
    """Remove material slot ``index`` of ``obj`` (popping the mesh's material leaves the object a slot)."""
    active = obj.active_material_index
    obj.active_material_index = index
    try:
        with bpy.context.temp_override(object=obj):
            done = bpy.ops.object.material_slot_remove() == {"FINISHED"}
    except RuntimeError:
        done = False
    if not done:
        obj.data.materials.pop(index=index)
    obj.active_material_index = min(active if active < index else max(active - 1, 0),
                                    max(len(obj.material_slots) - 1, 0))
