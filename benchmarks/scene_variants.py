"""The materials the scene benchmark measures (benchmarks/bench_scene.py): Blender's BSDFs, the
closures of a layered material alone, and the layered material of each preset as the node group
reading its baked tables, the node group computing its closures, or the OSL shader.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from node_count import interpreted_nodes, per_point_nodes
from timing import DIFFUSE, GLOSSY, PRINCIPLED, stock_material, thin_film_inputs

REFERENCE = "Principled BSDF + Thin Film"
THIN_FILM_NM, THIN_FILM_IOR = 500.0, 1.33
BAKE_REPS = 7  # bakes timed per tabulated variant (the median is reported)


# --- variants ---------------------------------------------------------------------------------
@dataclass
class Variant:
    """One material to measure: a stock BSDF or the layered material of a preset."""

    label: str
    backend: str = "stock"  # "stock" (Blender's BSDFs), "osl-stock" (under Cycles' OSL), or bench_scene.BACKENDS
    preset: str | None = None
    accuracy: str | None = None
    material: object = field(default=None, repr=False)
    optics: str | None = None
    nodes: int | None = None  # nodes the layered node group interprets
    per_point: int | None = None  # of those, the nodes Cycles cannot fold (they depend on the shading point)
    bake_ms: float | None = None  # a bake of the material's tables (tables variants)
    table_bytes: int | None = None  # the tables' texels in memory
    rebuild_ms: float | None = None  # OSL reading tables: a bake, the text written and compiled

    @property
    def osl(self) -> bool:
        return self.backend.startswith("osl")

    def record(self) -> dict:
        return dict(label=self.label, backend=self.backend, preset=self.preset, accuracy=self.accuracy,
                    nodes=self.nodes, per_point_nodes=self.per_point, optics=self.optics, bake_ms=self.bake_ms,
                    table_bytes=self.table_bytes, rebuild_ms=self.rebuild_ms)


def stock_variants() -> list[Variant]:
    """Blender's BSDFs, the reference first."""
    specs = ((REFERENCE, PRINCIPLED, thin_film_inputs(THIN_FILM_NM, THIN_FILM_IOR)),
             ("Principled BSDF", PRINCIPLED, {}), ("Glossy BSDF", GLOSSY, {}), ("Diffuse BSDF", DIFFUSE, {}))
    return [kept_variant(label, stock_material(label, bsdf, inputs)) for label, bsdf, inputs in specs]


def kept_variant(label: str, mat) -> Variant:
    """A stock variant of the material ``mat``, kept in the file while other materials are in use."""
    mat.use_fake_user = True
    return Variant(label, material=mat)


def closure_floor_material(label: str, glossy: int):
    """The closures of a layered material and no arithmetic: a Diffuse BSDF and ``glossy``
    Beckmann Glossy BSDFs (anisotropic, tangent from the Tangent node, constant colours and
    roughness), added.  What Cycles spends on the closures alone, the floor of any node
    group that builds them."""
    import bpy

    mat = bpy.data.materials.new(label)
    nt = mat.node_tree
    nt.nodes.clear()
    tangent = nt.nodes.new("ShaderNodeTangent")
    total = nt.nodes.new(DIFFUSE).outputs[0]
    for k in range(glossy):
        g = nt.nodes.new(GLOSSY)
        g.distribution = "BECKMANN"
        g.inputs["Color"].default_value = (0.3 + 0.2 * (k % 3), 0.5, 0.8 - 0.2 * (k % 3), 1.0)
        g.inputs["Roughness"].default_value = 0.15 + 0.05 * k
        g.inputs["Anisotropy"].default_value = 0.5
        nt.links.new(tangent.outputs["Tangent"], g.inputs["Tangent"])
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(total, add.inputs[0])
        nt.links.new(g.outputs[0], add.inputs[1])
        total = add.outputs[0]
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(total, out.inputs["Surface"])
    return mat


#: The closure sets of the layered material: with dispersion (a reflected and three
#: transmitted lobes) and with equal indices (one of each), each with the diffuse part.
CLOSURE_FLOORS = (("closures alone: diffuse + 4 glossy (dispersion)", 4),
                  ("closures alone: diffuse + 2 glossy (equal indices)", 2))


OSL_FLOOR = """\
#include "stdcycles.h"
shader closures_alone(output closure color BSDF = 0)
{{
  vector T = normalize(cross(N, I));
  BSDF = color(0.2, 0.3, 0.1) * diffuse(N);
{lobes}}}
"""


def osl_closure_floor_material(label: str, glossy: int):
    """What the OSL shading system spends on the closures alone: an OSL shader adding a diffuse closure
    and ``glossy`` anisotropic Beckmann closures of constant weights (the OSL shader's own closures)."""
    import bpy

    from layered_brdf_addon.blender.osl import compile_script_node

    lobes = "".join(f"  BSDF += color({0.3 + 0.2 * (k % 3):.1f}, 0.5, {0.8 - 0.2 * (k % 3):.1f}) * "
                    f"microfacet(\"beckmann\", N, T, {(0.15 + 0.05 * k) ** 2 * 1.5:.4f}, "
                    f"{(0.15 + 0.05 * k) ** 2 / 1.5:.4f}, 0.0, 0);\n" for k in range(glossy))
    mat = bpy.data.materials.new(label)
    nt = mat.node_tree
    nt.nodes.clear()
    text = bpy.data.texts.new(f"{label}.osl")
    text.from_string(OSL_FLOOR.format(lobes=lobes))
    script = nt.nodes.new("ShaderNodeScript")
    script.mode = "INTERNAL"
    compile_script_node(script, text)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(script.outputs["BSDF"], out.inputs["Surface"])
    return mat


def _table_images(mat) -> dict:
    """The baked tables a layered material's group reads: {image index: bpy image}."""
    group = next(n.node_tree for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree)
    return {int(n.label.rsplit(" ", 1)[1]): n.image for n in group.nodes
            if n.bl_idname == "ShaderNodeTexImage" and n.label.startswith("Baked table ")}


def node_builder(nt):
    """``node(kind, inputs, **props)``: a new node of ``nt``, its inputs (key, socket or value) linked or set."""
    import bpy

    def node(kind, inputs=(), **props):
        n = nt.nodes.new(kind)
        for key, value in props.items():
            setattr(n, key, value)
        for key, value in inputs:
            if isinstance(value, bpy.types.NodeSocket):
                nt.links.new(value, n.inputs[key])
            else:
                n.inputs[key].default_value = value
        return n
    return node


def thickness_pattern(node, params, plan):
    """The thickness pattern of ``params`` as the group makes it, with stock nodes (``node``:
    :func:`node_builder`): Blender's Noise Texture (4D fBm, normalised) on object coordinates, its factor
    in [0, 1]; None for any other pattern."""
    if plan.thickness != "noise":
        return None
    position = node("ShaderNodeTexCoord").outputs["Object"]
    return node("ShaderNodeTexNoise", (("Vector", position), ("W", params.noise_phase), ("Scale", params.noise_scale),
                                       ("Detail", params.noise_detail), ("Roughness", params.noise_roughness)),
                noise_dimensions="4D", noise_type="FBM", normalize=True).outputs["Fac"]


def table_reads_floor_material(label: str, source, params):
    """What a tabulated node group cannot do without: its thickness pattern, the reads of its tables and its
    closures, and no other arithmetic.  ``source`` is the layered material of ``params`` reading its tables;
    its images are read here as the group reads them (Cubic, extended edges; a sliced layout twice, between
    two slices, with the group's slice arithmetic, and mixed), along x at the shading point's Generated
    coordinate and along y at the thickness pattern's factor, and the closures take their weights, roughness
    and anisotropy from the reads, about the shading normal and the Tangent node's tangent (no lower normal,
    view frame, Normal input's checks or closure normals)."""
    import bpy

    from layered_brdf_addon.model.policy import plan_effects
    from layered_brdf_addon.model.table_bake import table_layout

    plan = plan_effects(params)
    layout = table_layout(params, plan)
    images = _table_images(source)
    mat = bpy.data.materials.new(label)
    nt = mat.node_tree
    nt.nodes.clear()
    node = node_builder(nt)

    def math_node(op, a, b):
        return node("ShaderNodeMath", ((0, a), (1, b)), operation=op).outputs[0]

    def vector_node(op, a, b):
        return node("ShaderNodeVectorMath", ((0, a), (1, b)), operation=op).outputs[0]

    generated = node("ShaderNodeTexCoord").outputs["Generated"]
    tangent = node("ShaderNodeTangent").outputs["Tangent"]
    xy = vector_node("MULTIPLY", generated, (1.0 / layout.azimuths, 1.0, 0.0))
    factor = thickness_pattern(node, params, plan)
    if factor is not None:
        x = node("ShaderNodeSeparateXYZ", (("Vector", xy),)).outputs["X"]
        xy = node("ShaderNodeCombineXYZ", (("X", x), ("Y", factor))).outputs[0]

    def table(k, at):
        n = node("ShaderNodeTexImage", (("Vector", at),), interpolation="Cubic", extension="EXTEND")
        n.image = images[k]
        return n.outputs["Color"], n.outputs["Alpha"]

    if layout.sliced:  # the group's slice arithmetic (tables._slice_reader), on a per-point angle
        phi = node("ShaderNodeSeparateXYZ", (("Vector", generated),)).outputs["Z"]
        u = node("ShaderNodeClamp", (("Value", math_node("MULTIPLY", phi, layout.azimuths - 1.0)),
                                     ("Min", 0.0), ("Max", layout.azimuths - 1.0))).outputs[0]
        i0 = math_node("MINIMUM", math_node("FLOOR", u, 0.0), layout.azimuths - 2.0)
        f = math_node("SUBTRACT", u, i0)
        step = 1.0 / layout.azimuths
        offset = node("ShaderNodeCombineXYZ", (("X", math_node("MULTIPLY", i0, step)),)).outputs[0]
        xy0 = vector_node("ADD", xy, offset)
        xy1 = vector_node("ADD", xy0, (step, 0.0, 0.0))

        def read(k):
            (c0, a0), (c1, a1) = table(k, xy0), table(k, xy1)
            colour = node("ShaderNodeMix", (("Factor", f), (6, c0), (7, c1)), data_type="RGBA").outputs[2]
            alpha = node("ShaderNodeMix", (("Factor", f), (2, a0), (3, a1)), data_type="FLOAT").outputs[0]
            return colour, alpha
    else:
        def read(k):
            return table(k, xy)

    packed = {}

    def value(k, what):
        image, channel = layout.slot(k, what)
        if image not in packed:
            colour, alpha = read(image)
            packed[image] = [*node("ShaderNodeSeparateXYZ", (("Vector", colour),)).outputs, alpha]
        return packed[image][channel]

    for k in layout.oriented:  # read, as the group reads them, though the normal is the shading normal here
        value(k, "normal_x"), value(k, "normal_y")
    diffuse_colour, _ = table(layout.diffuse_image, xy)
    total = node(DIFFUSE, (("Color", diffuse_colour),)).outputs[0]
    for k, (_, channels) in enumerate(layout.closures):
        if layout.has_image(k):
            colour, roughness = read(layout.closure_image(k))
        else:
            w, roughness = value(k, "weight"), value(k, "roughness")
            colour = node("ShaderNodeCombineXYZ", [("XYZ"[c], w) for c in channels]).outputs[0]
        g = node(GLOSSY, (("Color", colour), ("Roughness", roughness), ("Anisotropy", value(k, "anisotropy")),
                          ("Tangent", tangent)), distribution="BECKMANN")
        total = node("ShaderNodeAddShader", ((0, total), (1, g.outputs[0]))).outputs[0]
    out = node("ShaderNodeOutputMaterial")
    nt.links.new(total, out.inputs["Surface"])
    return mat


def thin_film_with_pattern_material(label: str, params):
    """Principled BSDF + Thin Film with the thickness pattern of ``params`` (:func:`thickness_pattern`),
    ``d_min + (d_max - d_min) factor`` nm: what an artist builds for a film that varies like this preset's."""
    from layered_brdf_addon.model.policy import plan_effects

    mat = stock_material(label, PRINCIPLED, thin_film_inputs(THIN_FILM_NM, THIN_FILM_IOR))
    nt = mat.node_tree
    node = node_builder(nt)
    factor = thickness_pattern(node, params, plan_effects(params))
    if factor is not None:
        d = node("ShaderNodeMapRange", (("Value", factor), ("To Min", params.d_min), ("To Max", params.d_max)))
        principled = next(n for n in nt.nodes if n.bl_idname == PRINCIPLED)
        nt.links.new(d.outputs["Result"], principled.inputs["Thin Film Thickness"])
    return mat


def table_floor_variants(v: Variant) -> list[Variant]:
    """For the tabulated variant ``v``: its floor (:func:`table_reads_floor_material`) and, where its thickness
    follows a pattern, Principled BSDF + Thin Film with that pattern (:func:`thin_film_with_pattern_material`)."""
    from layered_brdf_addon.model import preset
    from layered_brdf_addon.model.policy import plan_effects

    params = preset(v.preset).replace(accuracy=v.accuracy, evaluation="tables", optics=v.optics)
    label = f"{v.preset} {v.accuracy}: pattern, table reads and closures alone"
    f = kept_variant(label, table_reads_floor_material(label, v.material, params))
    f.backend, f.accuracy, f.optics = "reads-floor", v.accuracy, v.optics
    f.per_point = per_point_nodes(f.material.node_tree)
    f.nodes = interpreted_nodes(f.material.node_tree)
    out = [f]
    if plan_effects(params).thickness == "noise":
        label = f"{REFERENCE}, thickness from {v.preset}'s noise"
        out.append(kept_variant(label, thin_film_with_pattern_material(label, params)))
    return out


def floor_variants(reference: Variant | None = None) -> list[Variant]:
    """The closures alone, as stock nodes; with the ``reference`` variant (when OSL is measured), also as an
    OSL shader, and the reference rendered by Cycles' OSL shading system: what OSL itself costs."""
    vs = [kept_variant(label, closure_floor_material(label, glossy)) for label, glossy in CLOSURE_FLOORS]
    if reference is not None:
        for label, glossy in CLOSURE_FLOORS:
            v = kept_variant(f"{label}, OSL", osl_closure_floor_material(f"{label}, OSL", glossy))
            v.backend = "osl-stock"
            vs.append(v)
        vs.append(Variant(f"{reference.label}, OSL shading system", "osl-stock", material=reference.material))
    return vs


def layered_variant(obj, preset_name: str, backend: str, accuracy: str, optics: str | None = None) -> Variant:
    """The layered material of a preset (in ``optics``, default its own), built by the add-on on
    ``obj`` and then kept aside."""
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.model import preset

    evaluation = "tables" if backend in ("tables", "osl-tables") else "arithmetic"
    params = preset(preset_name).replace(accuracy=accuracy, evaluation=evaluation,
                                         **({"optics": optics} if optics else {}))
    label = f"{preset_name} {accuracy} {params.optics} {backend}"
    obj.material_slots[0].material = None  # so that the add-on makes a new material
    shader = "osl" if backend.startswith("osl") else "nodes"
    mat = apply_layered_material(obj, params, shader, name=label)
    mat.use_fake_user = True
    v = Variant(label, backend, preset_name, accuracy, mat, optics=params.optics)
    if shader == "nodes":
        v.nodes = interpreted_nodes(mat.node_tree)
        v.per_point = per_point_nodes(mat.node_tree)
    if evaluation == "tables":
        v.bake_ms, v.table_bytes = bake_cost(params)
    if backend == "osl-tables" and v.bake_ms is not None:
        v.rebuild_ms = osl_rebuild_cost(mat, params)
    return v


def osl_rebuild_cost(mat, params) -> float:
    """Median wall time (ms) of what a change of a value costs the OSL shader reading tables: a bake, its
    text written and compiled (each time for values not seen before, so nothing is reused)."""
    import numpy as np

    from layered_brdf_addon.blender.material import apply_layered_material

    times = []
    for k in range(1, BAKE_REPS + 1):
        changed = params.replace(e0=params.e0 * (1.0 + 1e-3 * k))
        t = time.perf_counter()
        apply_layered_material(mat, changed, "osl")
        times.append(time.perf_counter() - t)
    apply_layered_material(mat, params, "osl")
    return 1e3 * float(np.median(times))


def bake_cost(params) -> tuple[float | None, int | None]:
    """Median wall time (ms) of a bake of ``params``'s tables, and their size in bytes; None where the
    plan computes its closures (a boundary that follows the thickness, a tilted one beyond its budget)."""
    import numpy as np

    from layered_brdf_addon.model.policy import plan_effects
    from layered_brdf_addon.model.table_bake import bake

    plan = plan_effects(params)
    if not plan.tables:
        return None, None
    times = []
    for _ in range(BAKE_REPS):
        t = time.perf_counter()
        _, texels = bake(params, plan)
        times.append(time.perf_counter() - t)
    return 1e3 * float(np.median(times)), int(texels.nbytes)


def layered_variants(obj, presets, backends, spectral_preset, spectral_modes, paper_optics=False) -> list[Variant]:
    """Every preset x backend in its own accuracy mode (the paper's figures RGB, the artist
    presets analytic), then the other accuracy modes of one preset; with ``paper_optics``, each
    preset of physical optics also with the paper's (what thin-film optics cost)."""
    from layered_brdf_addon.model import preset

    combos = [(p, b, preset(p).accuracy) for p in presets for b in backends]
    if paper_optics:
        combos += [(p, b, preset(p).accuracy, "paper") for p in presets for b in backends
                   if preset(p).optics == "physical"]
    own = preset(spectral_preset).accuracy
    combos += [(spectral_preset, b, m) for m in spectral_modes if m != own for b in backends]
    if spectral_preset not in presets:
        combos += [(spectral_preset, b, own) for b in backends if own in spectral_modes]
    return [layered_variant(obj, *c) for c in combos]
