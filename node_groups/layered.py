"""Builds the "Layered BRDF" shader node group for one effect plan.

The group's inputs are the shader parameters of ``LayeredParams`` (same names as the
OSL shader's), plus ``Normal``; its outputs are ``BSDF``, ``Thickness`` (nm) and
``Lower Normal`` (world space), the last two for AOV passes.  Groups are stamped
with :data:`NODE_GROUP_VERSION` and their plan; a stale group is rebuilt in place.
"""
from __future__ import annotations

import math

import bpy

from ._core import params as P_
from ._core import plan as plan_
from ._core import program
from ._core import sphere as sphere_
from .ops_nodes import Expr, NodeOps

NODE_GROUP_VERSION = 3


def _source_digest() -> str:
    """Digest of the code that shapes the groups: any change makes saved groups stale."""
    import hashlib
    import inspect

    h = hashlib.sha1()
    for mod in (program, inspect.getmodule(NodeOps), inspect.getmodule(_source_digest)):
        h.update(inspect.getsource(mod).encode())
    return h.hexdigest()[:12]
GROUP_PREFIX = "Layered BRDF"
STAMP_KEY = "layered_brdf_version"
PLAN_KEY = "layered_brdf_plan"


def group_name(plan: "plan_.EffectPlan") -> str:
    return f"{GROUP_PREFIX} [{plan.key}]"


def build_stamp() -> str:
    global _STAMP
    if _STAMP is None:
        _STAMP = f"{NODE_GROUP_VERSION}:{_source_digest()}"
    return _STAMP


_STAMP = None


def is_current(group, plan) -> bool:
    return group.get(STAMP_KEY) == build_stamp() and group.get(PLAN_KEY) == plan.key


def ensure_group(plan: "plan_.EffectPlan"):
    """The node group for ``plan``: reused when current, rebuilt in place when stale."""
    if plan.lobe != "beckmann":
        raise P_.ParameterError("lobe", plan.lobe, "'beckmann' with the node backend (phong_ramp exists only in OSL)")
    name = group_name(plan)
    group = bpy.data.node_groups.get(name)
    if group is not None and group.library is None and is_current(group, plan):
        return group
    if group is None or group.library is not None:
        group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    build_into(group, plan)
    return group


def _interface(group):
    iface = group.interface
    iface.clear()
    for spec in P_.iter_sockets():
        s = iface.new_socket(spec.name, in_out="INPUT", socket_type="NodeSocketFloat")
        s.default_value = spec.default
        s.min_value = max(spec.min, -3.0e38)
        s.max_value = min(spec.max, 3.0e38)
        unit = f" ({spec.unit})" if spec.unit else ""
        s.description = f"{spec.label}{unit}: {spec.description}"
    s = iface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    s.hide_value = True
    s.description = "Upper-boundary normal; the shading normal when not connected"
    s = iface.new_socket("Base Color", in_out="INPUT", socket_type="NodeSocketColor")
    s.default_value = (1.0, 1.0, 1.0, 1.0)
    s.description = "Multiplies the diffuse base colour (plug a texture here)"
    s = iface.new_socket("Base Shader", in_out="INPUT", socket_type="NodeSocketShader")
    s.description = "The artist's own material under the layer; it receives the transmitted 1 - F"
    iface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    s = iface.new_socket("Thickness", in_out="OUTPUT", socket_type="NodeSocketFloat")
    s.description = "Layer thickness d in nm"
    s = iface.new_socket("Lower Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    s.description = "Normal n1 of the lower boundary, world space"
    s = iface.new_socket("Upper Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    s.description = "Normal n0 of the upper boundary (the shading normal used), world space"


def rotate_about(ops, v, axis, angle):
    """Rodrigues' rotation of ``v`` about the unit ``axis`` (``angle`` in radians)."""
    c, s = ops.cos(angle), ops.sin(angle)
    return v * c + ops.cross(axis, v) * s + axis * (ops.dot(axis, v) * (1.0 - c))


def build_into(group, plan) -> None:
    """(Re)build ``group``'s nodes for ``plan``: idempotent, stamps version and plan."""
    group.nodes.clear()
    _interface(group)
    ops = NodeOps(group, x0=200.0, stamp=build_stamp(),
                  subgroup_name=lambda key: f"{GROUP_PREFIX} part: {key}")
    gin = group.nodes.new("NodeGroupInput")
    gin.location = (-200.0, 0.0)
    gout = group.nodes.new("NodeGroupOutput")

    def inp(name):
        return Expr(ops, gin.outputs[name], "vector" if name == "Normal" else "float", 0)

    # Every input is clamped to its allowed range: a texture may feed any value.
    P = {}
    for spec in P_.iter_sockets():
        P[spec.name] = ops.clamp(inp(spec.name), spec.min, spec.max)
    geo_node, _ = ops.node("ShaderNodeNewGeometry", depth=0)
    tc_node, _ = ops.node("ShaderNodeTexCoord", depth=0)
    shading_normal = ops.out(geo_node, 0, "Normal", "vector")
    v = ops.out(geo_node, 0, "Incoming", "vector")
    p_obj = ops.out(tc_node, 0, "Object", "vector")
    n0 = ops.normalize(inp("Normal"), shading_normal)  # unconnected (zero) or NaN: shading normal

    d_min, d_max = P["d_min"], ops.maximum(P["d_max"], P["d_min"])

    def factor_at(p):
        if plan.thickness == "noise":
            n, dd = ops.node("ShaderNodeTexNoise", {"Vector": p, "W": P["noise_phase"], "Scale": P["noise_scale"],
                                                    "Detail": P["noise_detail"], "Roughness": P["noise_roughness"],
                                                    "Lacunarity": 2.0, "Distortion": 0.0},
                             noise_dimensions="4D", noise_type="FBM", normalize=True)
            return ops.out(n, dd, "Fac", "float")
        return ops.clamp(0.5 - 0.5 * ops.dot(p, (0.0, 0.0, 1.0)), 0.0, 1.0)

    def thickness_at(p):
        return ops.clamp(d_min + (d_max - d_min) * ops.clamp(factor_at(p), 0.0, 1.0), 0.0, 1.0e6)

    d = d_min if plan.thickness == "constant" else thickness_at(p_obj)

    if plan.normals == "tilted":
        z_obj = ops.normalize(object_to_world(ops, (0.0, 0.0, 1.0)), (0.0, 0.0, 1.0))
        x_obj = ops.normalize(object_to_world(ops, (1.0, 0.0, 0.0)), (1.0, 0.0, 0.0))
        c = ops.cross(z_obj, n0)
        t = ops.select_vec(ops.lt(ops.length(c), 1e-4), x_obj, ops.vmath("NORMALIZE", c))
        t = rotate_about(ops, t, n0, P["tilt_azimuth"] * (math.pi / 180.0))
        n1 = ops.normalize(rotate_about(ops, n0, t, P["tilt"] * (math.pi / 180.0)), n0)
    elif plan.normals == "correlated" and plan.thickness != "constant":
        h = sphere_.GRADIENT_STEP
        parts = [(thickness_at(p_obj + tuple(h if j == k else 0.0 for j in range(3))) - d) * (1.0 / h)
                 for k in range(3)]
        comb, dd = ops.node("ShaderNodeCombineXYZ", {"X": parts[0], "Y": parts[1], "Z": parts[2]})
        g_obj = ops.out(comb, dd, 0, "vector")
        # A gradient is a covector: for rotation and uniform scale s, M^-T g = M g / s^2.
        g_vec = object_to_world(ops, g_obj)
        sx = object_to_world(ops, (1.0, 0.0, 0.0))
        g = g_vec / ops.maximum(ops.dot(sx, sx), 1e-12)
        g_t = g - n0 * ops.dot(g, n0)
        n1 = ops.normalize(n0 + g_t * P["bump_strength"], n0)
    else:
        n1 = n0

    sep, dd = ops.node("ShaderNodeSeparateColor", {"Color": Expr(ops, gin.outputs["Base Color"], "vector", 0)})
    tint = [ops.maximum(ops.out(sep, dd, k, "float"), 0.0) for k in range(3)]
    inputs = dict(r1=(P["r1_r"], P["r1_g"], P["r1_b"]), r0=P["r0"], e0=P["e0"], e1=P["e1"], ks=P["ks"],
                  kd=P["kd"], base=tuple(P[f"base_{c}"] * t for c, t in zip("rgb", tint)))
    res = program.shade(ops, inputs, n0, n1, d, v, plan)

    shaders = []
    if res.diffuse is not None:
        col, dd = ops.node("ShaderNodeCombineColor", {"Red": res.diffuse[0], "Green": res.diffuse[1],
                                                      "Blue": res.diffuse[2]})
        bsdf, dd = ops.node("ShaderNodeBsdfDiffuse", {"Color": ops.out(col, dd, 0, "vector"), "Roughness": 0.0,
                                                      "Normal": n0})
        shaders.append(ops.out(bsdf, dd, 0, "shader"))
    for cl in res.glossy:
        col, dd = ops.node("ShaderNodeCombineColor", {"Red": cl.weight[0], "Green": cl.weight[1],
                                                      "Blue": cl.weight[2]})
        rough = ops.sqrt(ops.clamp(cl.alpha, 0.0, 1.0))
        bsdf, dd = ops.node("ShaderNodeBsdfGlossy", {"Color": ops.out(col, dd, 0, "vector"), "Roughness": rough,
                                                     "Normal": cl.normal}, distribution="BECKMANN")
        bsdf.label = cl.name
        shaders.append(ops.out(bsdf, dd, 0, "shader"))
    # The artist's base shader gets the transmitted 1 - F(v) (mean over the channels:
    # a Mix Shader takes one factor).
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    f_mean = sum(program.schlick(ops, cos_v, program.fresnel_f0(r1, P["r0"])) for r1 in inputs["r1"]) * (1.0 / 3.0)
    mix, dd = ops.node("ShaderNodeMixShader", {"Fac": 1.0 - f_mean})
    group.links.new(gin.outputs["Base Shader"], mix.inputs[2])
    shaders.append(ops.out(mix, dd, 0, "shader"))
    total = None
    for s in shaders:
        if total is None:
            total = s
            continue
        n, dd = ops.node("ShaderNodeAddShader", {0: total, 1: s})
        total = ops.out(n, dd, 0, "shader")
    gout.location = (ops.x0 + (max(ops._rows) + 2) * ops.COLUMN, 0.0)
    if total is not None:
        group.links.new(total.socket, gout.inputs["BSDF"])
    if isinstance(d, Expr):
        group.links.new(d.socket, gout.inputs["Thickness"])
    else:
        group.links.new(gin.outputs["d_min"], gout.inputs["Thickness"])
    group.links.new(n1.socket, gout.inputs["Lower Normal"])
    group.links.new(n0.socket, gout.inputs["Upper Normal"])
    group[STAMP_KEY] = build_stamp()
    group[PLAN_KEY] = plan.key
    group["layered_brdf_node_count"] = ops.count


def object_to_world(ops, vec):
    """A direction (constant or computed) from object to world space (Vector Transform)."""
    n, dd = ops.node("ShaderNodeVectorTransform", {"Vector": vec}, vector_type="VECTOR",
                     convert_from="OBJECT", convert_to="WORLD")
    return ops.out(n, dd, 0, "vector")
