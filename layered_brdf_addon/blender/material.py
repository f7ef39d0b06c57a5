"""apply_layered_material: the one function the UI, the CLI and the tests call."""
from __future__ import annotations

import re

import bpy

from ..model.params import ParameterError, LayeredParams, iter_sockets
from ..model.plan import EffectPlan
from ..model import policy
from ..model.policy import plan_effects
from . import osl as osl_backend
from ..backends import node_group as node_group_builder

MATERIAL_KEY = "layered_brdf"  # custom property marking materials made by the add-on
AOV_THICKNESS = "layer_thickness"
AOV_LOWER_NORMAL = "lower_normal"
AOV_UPPER_NORMAL = "upper_normal"  # Cycles' Normal pass averages closure normals: not n0 here
SHADER_NODE = "Layered BRDF"


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
        if obj.data.materials:
            obj.data.materials[obj.active_material_index] = mat
        else:
            obj.data.materials.append(mat)
    return mat


def shader_node(mat):
    """The add-on's shader node in ``mat`` (group or script), or None."""
    if mat.node_tree is None:
        return None
    return mat.node_tree.nodes.get(SHADER_NODE)


def set_inputs(node, params: LayeredParams) -> None:
    """Write parameter values into the shader node's input sockets (the source of truth)."""
    for spec in iter_sockets():
        sock = node.inputs.get(spec.name)
        if sock is None:
            raise RuntimeError(f"shader node lacks the input '{spec.name}'")
        sock.default_value = float(getattr(params, spec.name))


def read_inputs(node, base: LayeredParams | None = None) -> LayeredParams:
    """Parameters from the shader node's sockets (enums from the material's stored settings)."""
    values = {spec.name: float(node.inputs[spec.name].default_value) for spec in iter_sockets()}
    return LayeredParams.from_dict(values, base=base or LayeredParams())


OWN_PREFIX = "Layered BRDF"  # nodes the add-on creates (and may delete); the artist's are kept
_SOCKET_ALIASES = {"Base Color": "BaseColor", "Base Shader": "Base", "Lower Normal": "LowerNormal",
                   "Upper Normal": "UpperNormal"}
_SOCKET_ALIASES.update({v: k for k, v in list(_SOCKET_ALIASES.items())})


def _socket(sockets, name):
    return sockets.get(name) or sockets.get(_SOCKET_ALIASES.get(name, ""))


def _build_tree(mat, params: LayeredParams, backend: str, plan: EffectPlan):
    """(Re)build the add-on's nodes in ``mat``; the artist's own nodes and their links to the
    shader node's inputs and outputs are kept."""
    tree = mat.node_tree
    old = tree.nodes.get(SHADER_NODE)
    keep_in, keep_out = [], []
    if old is not None:
        for sock in old.inputs:
            for link in sock.links:
                if not link.from_node.name.startswith(OWN_PREFIX):
                    keep_in.append((link.from_socket, sock.name))
        for sock in old.outputs:
            for link in sock.links:
                if not link.to_node.name.startswith(OWN_PREFIX) and link.to_node.bl_idname != "ShaderNodeOutputMaterial":
                    keep_out.append((sock.name, link.to_socket))
    for n in [n for n in tree.nodes if n.name.startswith(OWN_PREFIX)]:
        tree.nodes.remove(n)
    out = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output), None)
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
        osl_backend.compile_script_node(node, script=osl_backend.text_for(plan))
    node.name = node.label = SHADER_NODE
    node.width = 220
    node.location = (out.location[0] - 300, out.location[1])
    shader_out = _socket(node.outputs, "BSDF")
    tree.links.new(shader_out, out.inputs["Surface"])
    for from_socket, name in keep_in:
        target = _socket(node.inputs, name)
        if target is not None:
            tree.links.new(from_socket, target)
    for name, to_socket in keep_out:
        source = _socket(node.outputs, name)
        if source is not None:
            tree.links.new(source, to_socket)
    base_in = _socket(node.inputs, "Base Shader")
    if params.base_layer == "transparent" and base_in is not None and not base_in.is_linked:
        tr = tree.nodes.new("ShaderNodeBsdfTransparent")
        tr.name = tr.label = f"{OWN_PREFIX} base"
        tr.location = (node.location[0] - 250, node.location[1] - 300)
        tree.links.new(tr.outputs[0], base_in)
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
        tree.links.new(src, aov.inputs[kind])
    return node


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
    names = {s.name for s in iter_sockets() if node.inputs[s.name].is_linked}
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
                    names.add(node.inputs[i].name)
            else:
                key = index[1:-1]
                sock = node.inputs.get(key)
                names.add(sock.name if sock is not None else key)
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
    node = shader_node(mat)
    key = f"{backend}:{plan.key}:{params.base_layer}"
    if node is None or mat.get("layered_brdf_build") != key or not _node_current(node, backend, plan):
        node = _build_tree(mat, params, backend, plan)
        mat["layered_brdf_build"] = key
    set_inputs(node, params)
    mat["layered_brdf_backend"] = backend
    mat["layered_brdf_enums"] = {"thickness_mode": params.thickness_mode, "normal_mode": params.normal_mode,
                                 "lobe": params.lobe, "base_layer": params.base_layer}
    return mat


def _node_current(node, backend, plan) -> bool:
    if backend == "nodes":
        return node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and \
            node_group_builder.is_current(node.node_tree, plan)
    return node.bl_idname == "ShaderNodeScript" and node.script is not None and \
        node.script.as_string() == osl_backend.source(plan)


def remove_layered_material(obj) -> bool:
    """Remove the add-on's material from ``obj``'s slots; True when one was removed."""
    removed = False
    for i, slot in enumerate(obj.material_slots):
        if slot.material is not None and slot.material.get(MATERIAL_KEY):
            obj.data.materials.pop(index=i)
            removed = True
            break
    return removed
