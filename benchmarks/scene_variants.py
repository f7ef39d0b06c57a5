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
