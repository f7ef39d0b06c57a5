"""Trees made by older versions, or damaged by edits, brought back in step without touching the
artist's nodes: the add-on's nodes adopted (stamped) and the artist's copies of them released,
an older node's base colour channels rebuilt as a colour, and a tree that lost its output fed
again.
"""
from __future__ import annotations

from ..model.params import BASE_COLOR_SOCKET, LayeredParams
from .own_nodes import CLEAR_BASE_ADD, active_output, pick, shader_node, stamp
from .sockets import find_socket, legacy_tint
from .stored_keys import AOVS, BASE_CHANNELS, NAME_KEY, OWN_PREFIX, ROLE_KEY, TEXT_KEY


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
        own.append(pick(group, linked_from_shader))
    own += [pick([n for n in tree.nodes if n.get(ROLE_KEY) == "base"],
                  lambda n: any(l.to_node == shader for s in n.outputs for l in s.links),
                  lambda n: any(l.to_node.get(ROLE_KEY) == CLEAR_BASE_ADD for s in n.outputs for l in s.links))]
    own += [pick([n for n in tree.nodes if n.get(ROLE_KEY) == CLEAR_BASE_ADD],
                  lambda n: any(l.from_node == shader for s in n.inputs for l in s.links))]
    if shader is not None and shader.get(ROLE_KEY) is None:  # made before stamps
        for sock in shader.outputs:
            for link in sock.links:
                n = link.to_node
                if n.bl_idname == "ShaderNodeOutputAOV" and n.name.startswith(OWN_PREFIX) and \
                        n.aov_name in AOVS:
                    own.append(n)
        base_in = find_socket(shader.inputs, "Base Shader")
        for link in (base_in.links if base_in is not None else ()):
            n = link.from_node
            if n.bl_idname == "ShaderNodeBsdfTransparent" and n.name.startswith(OWN_PREFIX):
                own.append(n)
    return list(dict.fromkeys(n for n in own if n is not None))


def claim(mat):
    """Stamp the add-on's own nodes in ``mat`` (adopting those made before stamps) and unstamp
    the artist's copies of them; returns (shader node or None, all the add-on's nodes)."""
    tree = mat.node_tree
    shader = shader_node(mat)
    own = ([shader] if shader is not None else []) + _helper_nodes(tree, shader)
    for n in own:
        if n.get(ROLE_KEY) is None:
            stamp(n, "shader" if n == shader else "aov" if n.bl_idname == "ShaderNodeOutputAOV" else "base")
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


def legacy_base_links(old, params: LayeredParams):
    """An older node whose base colour channels or tint are linked: ``(channels, tint)``, each a
    linked output socket or the socket's value (a channel whose socket is gone: its value in
    ``params``); None when nothing there is linked (then the values carry over through
    :func:`~.sockets.read_inputs`)."""
    tint = legacy_tint(old)
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


def link_legacy_base(tree, node, channels, tint) -> None:
    """What fed an older node's base colour channels and tint, rebuilt as the artist's own nodes
    (Combine Color, times the tint) feeding the one Base Color socket: the same colour."""
    target = find_socket(node.inputs, BASE_COLOR_SOCKET)
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


def repair(mat, node) -> None:
    """Make a damaged tree render the layered shader again, touching none of the artist's nodes:
    a Material Output when there is none, fed by the end of the shader's chain; the shader's
    BSDF linked to the output's Surface when it feeds nothing and the Surface is free."""
    tree = mat.node_tree
    bsdf = find_socket(node.outputs, "BSDF")
    out = active_output(tree)
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
