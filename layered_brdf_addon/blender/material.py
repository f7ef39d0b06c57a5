"""apply_layered_material: the one function the UI, the CLI and the tests call."""
from __future__ import annotations

import re

import bpy

from ..model.params import ParameterError, LayeredParams, group_socket_name, iter_sockets
from ..model.plan import EffectPlan
from ..model import policy
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


def _material_for(target, name):
    if isinstance(target, bpy.types.Material):
        if target.library is not None:
            raise ParameterError("target", target.name, "a local material (it is linked from "
                                 f"{target.library.filepath}); make it local first")
        return target
    obj = target
    if isinstance(target, str):
        obj = bpy.data.objects.get(target)
        if obj is None:
            raise ParameterError("target", target, "the name of an object in the file: "
                                 + ", ".join(sorted(o.name for o in bpy.data.objects))[:400])
    if not hasattr(obj, "data") or not hasattr(obj.data, "materials"):
        raise ParameterError("target", obj.name, "an object that can hold materials (mesh, curve, ...)")
    mat = None
    if obj.active_material is not None and obj.active_material.get(MATERIAL_KEY):
        mat = obj.active_material
    if mat is not None and mat.library is not None:
        raise ParameterError("target", obj.name, "an object whose material is local (it is linked from "
                             f"{mat.library.filepath}); make it local first")
    if mat is None:
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
    label = group_socket_name(spec)
    for candidate in (label, SOCKET_NAMES.get(label, "")):
        sock = node.inputs.get(candidate)
        if sock is not None:
            return sock, spec.component
    return None, None


def _legacy_tint(node):
    """An older node's tint ("Base Color" multiplied its base_r, base_g, base_b), or None."""
    if node.inputs.get("base_r") is None:
        return None
    return _socket(node.inputs, "Base Color")


def set_inputs(node, params: LayeredParams) -> None:
    """Write parameter values into the shader node's input sockets (the source of truth)."""
    for spec in iter_sockets():
        sock, channel = param_socket(node, spec.name)
        if sock is None:
            raise RuntimeError(f"shader node lacks the input of '{spec.name}' ({group_socket_name(spec)})")
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


def read_inputs(node, base: LayeredParams | None = None) -> LayeredParams:
    """Parameters from the shader node's sockets (enums from the material's stored settings); a
    parameter newer than the node (a file saved before it existed) keeps ``base``'s value."""
    values = {spec.name: input_value(node, spec.name) for spec in iter_sockets()
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
        legacy_base = _legacy_base_links(old)
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
        group = node_group_builder.ensure_group(plan)
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


def _legacy_base_links(old):
    """An older node whose base colour channels or tint are linked: ``(channels, tint)``, each a
    linked output socket or the socket's value; None when nothing there is linked (then the
    values carry over through :func:`read_inputs`)."""
    tint = _legacy_tint(old)
    if tint is None:
        return None
    socks = [old.inputs[c] for c in BASE_CHANNELS]
    if not tint.is_linked and not any(sock.is_linked for sock in socks):
        return None
    source = lambda sock: sock.links[0].from_socket if sock.is_linked else tuple(sock.default_value) \
        if sock.type == "RGBA" else float(sock.default_value)
    return [source(sock) for sock in socks], source(tint)


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

    Idempotent: applying again reuses the material and the node group, rebuilds the
    material's tree only when the backend or the plan of active effects changed, and
    otherwise only writes the parameter values into the shader's input sockets.
    ``plan`` defaults to :func:`plan_effects` of ``params`` (``EffectPlan.full()`` gives
    the always-full shader).  Returns the material.
    """
    params = (params or LayeredParams()).validate()
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


def _node_current(node, backend, plan) -> bool:
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
    """Remove the add-on's material from ``obj``'s active slot (else its first layered slot) and
    put back the material it replaced there; True when one was removed."""
    slots = list(obj.material_slots)
    order = [obj.active_material_index] + list(range(len(slots))) if slots else []
    i = next((i for i in order if i < len(slots) and slots[i].material is not None
              and slots[i].material.get(MATERIAL_KEY)), None)
    if i is None:
        return False
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
