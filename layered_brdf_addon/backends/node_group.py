"""The node-group backend: the shading program built as a "Layered BRDF" shader node group.

The group's inputs are ``Normal``, the shader parameters of ``LayeredParams`` (sockets
named for people, in panels; the base colour one colour socket) and ``Base Shader``; its outputs are ``BSDF``,
``Thickness`` (nm), ``Lower Normal`` and ``Upper Normal`` (world space), the last three
for AOV passes.  Groups are stamped with :data:`NODE_GROUP_VERSION`, a digest of what
they compute (:func:`_output_digest`), and their plan; a stale group is rebuilt in place.
"""
from __future__ import annotations

import ast
import hashlib
import inspect
import re

import bpy

from ..model import params as P_
from ..model import program
from ..model.plan import EffectPlan
from ..model.policy import check_backend
from ..model.shading import tables as tables_module
from ..model.shading.surface_prelude import UNLINKED_THICKNESS
from .node_ops import Expr, NodeOps
from .osl_shader import shader_source

NODE_GROUP_VERSION = 7  # 7: baked tables; 6: Roughness sockets, Tilt as an angle; 5: sockets named for people, in panels
GROUP_PREFIX = "Layered BRDF"
STAMP_KEY = "layered_brdf_version"
OPEN_PANELS = ("Layer", "Specular", "Diffuse")  # open on a new node; the others start closed
PLAN_KEY = "layered_brdf_plan"
TABLE_SLOT_KEY = "layered_brdf_table_slot"  # on a group's Image Texture node: which image of the tables it reads
TABLE_SHAPE_KEY = "layered_brdf_table_shape"  # on a group built for tables: its layout
TABLE_READERS_KEY = "layered_brdf_table_readers"  # on a group built for tables: how many Image Texture nodes read them


def stamp_plans() -> list[EffectPlan]:
    """Plans that together take every branch of the shading program: the full plan, and each
    of its settings changed one at a time (with thin-film optics for the physical-only ones)."""
    base = EffectPlan.full().to_dict()
    variants = {"specular": [False], "diffuse": [False], "thickness": ["height", "constant", "input"],
                "normals": ["parallel", "tilted"], "dispersion": [False], "interference": [False],
                "analytic": [True], "spectral": [4, 8, 16, 32], "optics": ["physical"], "index": ["ior"]}
    plans = [EffectPlan(**base)]
    plans += [EffectPlan(**{**base, key: value}) for key, values in variants.items() for value in values]
    physical = {**base, "optics": "physical"}
    plans += [EffectPlan(**{**physical, "multibeam": True}), EffectPlan(**{**physical, "passes": False}),
              EffectPlan(**{**base, "analytic": True, "footprint": False})]
    return plans


_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)


def code_without_docs(source: str) -> str:
    """The syntax tree of Python ``source`` without its docstrings (comments are not in it)."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            node.body = body[1:] or [ast.Pass()]
    return ast.dump(tree)


def _output_digest() -> str:
    """Digest of what the groups are made of, not of the text that makes them: the shading
    program's computation for plans that take its every branch (the OSL backend's source of
    them, comments removed: the same operations the nodes are built from), and the node
    backend's own code (syntax trees, without docstrings).  Editing a docstring or a comment
    leaves saved groups current; a change to what is computed, or to how nodes are built
    from it, makes them stale."""
    h = hashlib.sha1()
    for plan in stamp_plans():
        h.update(_COMMENT.sub("", shader_source(plan)).encode())
    for module in (inspect.getmodule(NodeOps), inspect.getmodule(_output_digest), tables_module):
        h.update(code_without_docs(inspect.getsource(module)).encode())
    return h.hexdigest()[:12]


_STAMP = None


def build_stamp() -> str:
    global _STAMP
    if _STAMP is None:
        _STAMP = f"{NODE_GROUP_VERSION}:{_output_digest()}"
    return _STAMP


def group_name(plan: EffectPlan) -> str:
    """The group's name for people, and unique per plan: "Layered BRDF — Physical film, analytic
    colour, noise thickness [SDNPxBAT]" (the bracket: the plan's key, :attr:`EffectPlan.key`)."""
    return f"{GROUP_PREFIX} \u2014 {plan.title} [{plan.key}]"


def group_description(plan: EffectPlan) -> str:
    """The group's tooltip in the Add menu and the node editor: what it simulates, and where its modes are set."""
    return (f"Granier & Heidrich's layered RGB BRDF: a thin film over a surface. {plan.title}: "
            + "; ".join(plan.describe())
            + ". The modes (thickness pattern, lower boundary, optics, accuracy) are set in Properties "
              "> Material > Layered BRDF, which rebuilds this group")


def is_current(group, plan: EffectPlan) -> bool:
    return group.get(STAMP_KEY) == build_stamp() and group.get(PLAN_KEY) == plan.key


def ensure_group(plan: EffectPlan, layout=None):
    """The node group for ``plan`` (for tables of ``layout`` where the plan has tables): reused when
    current, rebuilt in place when stale."""
    check_backend("nodes", plan.lobe)
    name = group_name(plan)
    group = bpy.data.node_groups.get(name)
    if group is not None and group.library is None and is_current(group, plan):
        return group
    if group is not None and group.library is None and group.users == 0:
        build_into(group, plan, layout)  # nothing uses it: rebuilt in place
        return group
    if group is not None and group.library is None:
        # Other materials still use the stale group: it stays, under another name, until each is
        # rebuilt from its own sockets (their values, links and keyframes are kept), then goes.
        group.name = f"{name} (outdated)"
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    build_into(group, plan, layout)
    return group


def _interface(group):
    """The group's sockets: Normal, then one panel per parameter group (the add-on's sub-panels)
    of sockets named for people, with units as subtypes and the parameters' descriptions as
    tooltips; the base colour is one colour socket; the Base Shader closes the Diffuse panel."""
    iface = group.interface
    iface.clear()
    s = iface.new_socket("Normal", in_out="INPUT", socket_type="NodeSocketVector")
    s.hide_value = True
    s.description = "Upper-boundary normal; the shading normal when not connected"
    s = iface.new_socket(P_.THICKNESS_SOCKET, in_out="INPUT", socket_type="NodeSocketFloat")
    s.subtype = "WAVELENGTH"
    s.default_value = UNLINKED_THICKNESS  # not linked: the pattern (a group built for a link reads Thickness Min)
    s.hide_value = True
    s.description = P_.THICKNESS_DESCRIPTION
    panels = {}
    for sock in P_.iter_group_sockets():
        panel = panels.get(sock.group)
        if panel is None:
            panel = panels[sock.group] = iface.new_panel(sock.group, default_closed=sock.group not in OPEN_PANELS)
        if sock.is_color:
            s = iface.new_socket(sock.name, in_out="INPUT", socket_type="NodeSocketColor", parent=panel)
            s.default_value = (*(spec.default for spec in sock.specs), 1.0)
            s.description = P_.BASE_COLOR_DESCRIPTION
            continue
        (spec,) = sock.specs
        s = iface.new_socket(sock.name, in_out="INPUT", socket_type="NodeSocketFloat", parent=panel)
        s.subtype = spec.subtype
        lo, hi = P_.socket_limits(spec, "nodes")
        s.default_value = P_.socket_default(spec, "nodes")
        s.min_value = max(lo, -3.0e38)
        s.max_value = min(hi, 3.0e38)
        s.description = P_.socket_tooltip(spec)
    s = iface.new_socket("Base Shader", in_out="INPUT", socket_type="NodeSocketShader", parent=panels["Diffuse"])
    s.description = ("Your own material under the layer; it receives what the layer passes on (thin-film optics: "
                     "in the channel where it passes least; the paper's: 1 - F)")
    iface.new_socket("BSDF", in_out="OUTPUT", socket_type="NodeSocketShader")
    s = iface.new_socket("Thickness", in_out="OUTPUT", socket_type="NodeSocketFloat")
    s.description = "Layer thickness d in nm"
    s = iface.new_socket("Lower Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    s.description = "Normal n1 of the lower boundary, world space"
    s = iface.new_socket("Upper Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
    s.description = "Normal n0 of the upper boundary (the shading normal used), world space"
    s = iface.new_socket("Transmittance", in_out="OUTPUT", socket_type="NodeSocketColor")
    s.description = ("What passes through the layer to the base, per channel: the colour of a clear base's "
                     "Transparent BSDF")


class GroupOps(NodeOps):
    """Node ops at the top of the group: the material's inputs and the shading point."""

    SOCKETS = "nodes"  # whose sockets the inputs are (params.socket_units)

    def __init__(self, group, gin, **kw):
        super().__init__(group, **kw)
        self.gin = gin
        self._geometry = None

    def input(self, name):
        if name == "Normal":
            return Expr(self, self.gin.outputs[name], "vector", 0)
        if name == P_.THICKNESS_SOCKET:
            return Expr(self, self.gin.outputs[name], "float", 0)
        spec = P_.LayeredParams.spec(name)
        socket = self.gin.outputs[P_.group_socket_name(spec)]
        if spec.component is None:
            return Expr(self, socket, "float", 0)
        sep, dd = self.node("ShaderNodeSeparateColor", {"Color": Expr(self, socket, "vector", 0)})
        return self.out(sep, dd, spec.component, "float")

    def _geo(self, socket):
        node, _ = self.node("ShaderNodeNewGeometry", depth=0) if self._geometry is None else (self._geometry, 0)
        self._geometry = node
        return self.out(node, 0, socket, "vector")

    def shading_normal(self):
        return self._geo("Normal")

    def incoming(self):
        return self._geo("Incoming")

    def object_position(self):
        node, _ = self.node("ShaderNodeTexCoord", depth=0)
        return self.out(node, 0, "Object", "vector")

    def _transform(self, vec, src, dst):
        n, dd = self.node("ShaderNodeVectorTransform", {"Vector": vec}, vector_type="VECTOR",
                          convert_from=src, convert_to=dst)
        return self.out(n, dd, 0, "vector")

    def object_to_world(self, vec):
        return self._transform(vec, "OBJECT", "WORLD")

    def world_to_object(self, vec):
        return self._transform(vec, "WORLD", "OBJECT")

    def bump_normal(self, n, height, distance):
        """Blender's Bump node, inverted: ``n`` tilted by ``distance`` times the height's surface
        gradient (Cycles differentiates the height's nodes; EEVEE takes screen-space derivatives)."""
        node, dd = self.node("ShaderNodeBump", {"Strength": 1.0, "Distance": distance, "Height": height,
                                                "Normal": n}, invert=True)
        return self.out(node, dd, "Normal", "vector")

    def table(self, k, xy):
        """Image ``k`` of the material's baked tables at ``xy`` (an Image Texture, Cubic over the tables' spline
        coefficients, extended at the edges; the image is the material's, assigned by the Blender layer): its
        colour and alpha."""
        node, dd = self.node("ShaderNodeTexImage", {"Vector": xy}, interpolation="Cubic", extension="EXTEND",
                             label=f"Baked table {k}")
        node[TABLE_SLOT_KEY] = k
        return self.out(node, dd, "Color", "vector"), self.out(node, dd, "Alpha", "float")

    def noise_fbm(self, p, w, scale, detail, roughness):
        n, dd = self.node("ShaderNodeTexNoise", {"Vector": p, "W": w, "Scale": scale, "Detail": detail,
                                                 "Roughness": roughness, "Lacunarity": 2.0, "Distortion": 0.0},
                          noise_dimensions="4D", noise_type="FBM", normalize=True)
        return self.out(n, dd, "Fac", "float")


def _colour(ops, value):
    """A colour socket's value: a colour of the program, or its three channels combined."""
    if not isinstance(value, tuple):
        return value
    col, dd = ops.node("ShaderNodeCombineColor", {"Red": value[0], "Green": value[1], "Blue": value[2]})
    return ops.out(col, dd, 0, "vector")


def table_nodes(group) -> dict:
    """The Image Texture nodes of a group built for tables, by the image of the tables each reads (a list:
    a tilted boundary's group reads an image at two azimuth slices)."""
    out = {}
    for n in group.nodes:
        if n.bl_idname == "ShaderNodeTexImage" and TABLE_SLOT_KEY in n:
            out.setdefault(n[TABLE_SLOT_KEY], []).append(n)
    return out


def table_readers_intact(group, layout) -> bool:
    """Whether ``group`` has every Image Texture node it was built with for tables of ``layout``."""
    nodes = table_nodes(group)
    return set(nodes) == set(range(layout.images)) and \
        sum(len(n) for n in nodes.values()) == group.get(TABLE_READERS_KEY)


def layout_record(layout) -> str:
    record = f"format {tables_module.TABLE_FORMAT}:{layout.closures}:{layout.width}x{layout.height}:{layout.images}"
    return record + f":{layout.azimuths} azimuths {layout.oriented}" if layout.sliced else record


def build_into(group, plan: EffectPlan, layout=None) -> None:
    """(Re)build ``group``'s nodes for ``plan`` (with a plan for tables, for the tables of ``layout``,
    :class:`~..model.shading.tables.TableLayout`): idempotent, stamps version and plan."""
    if plan.tables and layout is None:
        raise ValueError(f"plan {plan.key} reads baked tables: its group needs their layout (table_layout)")
    group.nodes.clear()
    _interface(group)
    group.description = group_description(plan)
    if hasattr(group, "color_tag"):
        group.color_tag = "SHADER"
    gin = group.nodes.new("NodeGroupInput")
    gin.location = (-200.0, 0.0)
    gout = group.nodes.new("NodeGroupOutput")
    # A leading "." keeps the helper groups out of the Add menu and the group selector (Blender's
    # convention for hidden data); the material's own group stays visible.
    ops = GroupOps(group, gin, x0=200.0, stamp=build_stamp(),
                   subgroup_name=lambda key: f".{GROUP_PREFIX} part: {key}")
    res = program.layered_surface(ops, plan, layout)
    extras = res.extras
    n0 = extras["upper_normal"]

    with ops.stage("Closures: diffuse, glossy lobes and your Base Shader, added"):
        shaders = []
        if res.diffuse is not None:
            bsdf, dd = ops.node("ShaderNodeBsdfDiffuse", {"Color": _colour(ops, res.diffuse), "Roughness": 0.0,
                                                          "Normal": n0})
            shaders.append(ops.out(bsdf, dd, 0, "shader"))
        for cl in res.glossy:
            colour = _colour(ops, cl.weight)
            # The Glossy node's Roughness is sqrt(alpha).
            rough = cl.roughness if cl.roughness is not None else ops.sqrt(ops.clamp(cl.alpha, 0.0, 1.0))
            inputs = {"Color": colour, "Roughness": rough, "Normal": cl.normal}
            if cl.tangent is not None:
                inputs.update({"Anisotropy": cl.anisotropy, "Tangent": cl.tangent})
            bsdf, dd = ops.node("ShaderNodeBsdfGlossy", inputs, distribution="BECKMANN")
            bsdf.label = cl.name
            shaders.append(ops.out(bsdf, dd, 0, "shader"))
        mix, dd = ops.node("ShaderNodeMixShader", {"Fac": extras["base_weight"]})
        group.links.new(gin.outputs["Base Shader"], mix.inputs[2])
        shaders.append(ops.out(mix, dd, 0, "shader"))
        total = None
        for s in shaders:
            if total is None:
                total = s
                continue
            n, dd = ops.node("ShaderNodeAddShader", {0: total, 1: s})
            total = ops.out(n, dd, 0, "shader")
    ops.stack_stages()
    gout.location = (ops.x0 + (max(ops._rows) + 2) * ops.COLUMN, 0.0)
    group.links.new(total.socket, gout.inputs["BSDF"])
    for name, value in (("Thickness", extras["thickness"]), ("Lower Normal", extras["lower_normal"]),
                        ("Upper Normal", n0), ("Transmittance", extras["transmittance"])):
        if hasattr(value, "socket"):  # else a constant: nothing passes to the base, the output's black
            group.links.new(value.socket, gout.inputs[name])
    group[STAMP_KEY] = build_stamp()
    group[PLAN_KEY] = plan.key
    if layout is not None:
        group[TABLE_SHAPE_KEY] = layout_record(layout)
        group[TABLE_READERS_KEY] = sum(len(nodes) for nodes in table_nodes(group).values())
    else:
        for key in (TABLE_SHAPE_KEY, TABLE_READERS_KEY):
            if key in group:
                del group[key]
    group["layered_brdf_node_count"] = ops.count
