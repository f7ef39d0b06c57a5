"""Where EEVEE spends its time on a tilted boundary's tables: the bench scene (benchmarks/bench_scene.py)
rendered by EEVEE with, for one preset,

* Principled BSDF + Thin Film (the reference);
* the node group reading its tables, as the add-on builds it;
* its floor (benchmarks/scene_variants.py: the thickness pattern, the same reads and closures, no other
  arithmetic);
* the group with its slice offset taken out of the reads' coordinates (every value read from the first
  two slices, still mixed by the view's azimuth): the reads then no longer depend on the azimuth;
* the group with its slice chosen by the object's height instead of the view's azimuth (the same reads,
  the slices changing smoothly over the surface);
* the group with its images read with Linear, then Closest, interpolation instead of Cubic.

and, from a Cycles render of the slice index, how often two neighbouring pixels read slices more than one
apart (the view's azimuth about the lower normal turns fast where the view is near the normal).

The last three change what the group renders; they are there to find the cost, not as designs.  Each is
rendered at two numbers of samples per pixel, so that the wall time per sample (what the shader costs
per pixel, without scene sync and shader compilation) is the slope.  Software GL (Mesa's llvmpipe) on a
machine without a GPU.

    python benchmarks/eevee_table_reads.py [--preset fig6_medium] [--samples 1 16] [--reps 2]

Writes benchmarks/results/eevee_table_reads.json and prints a table.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from bench_scene import MAGENTA_FAILED, build_scene, eevee_engine, magenta_fraction, use_variant, write_json
from scene_variants import kept_variant, layered_variant, node_builder, stock_variants, table_floor_variants
from timing import machine_info, spread, timed_render

OUT_JSON = Path(__file__).resolve().parent / "results" / "eevee_table_reads.json"


def _group_copy(mat, label: str):
    """A copy of the layered material ``mat`` with a copy of its group: (material, group)."""
    copy = mat.copy()
    copy.name = label
    node = next(n for n in copy.node_tree.nodes if n.bl_idname == "ShaderNodeGroup")
    node.node_tree = node.node_tree.copy()
    node.node_tree.name = label
    return copy, node.node_tree


def _reads(group) -> list:
    return [n for n in group.nodes if n.bl_idname == "ShaderNodeTexImage"]


def without_slice_offset(mat, label: str):
    """The group with the slice's offset (``i0 / A`` along x, tables._slice_reader) unlinked: its reads'
    coordinates are those of the first slice and the next, whatever the view's azimuth."""
    copy, group = _group_copy(mat, label)
    for combine in _slice_offsets(group):
        for link in list(combine.inputs["X"].links):
            group.links.remove(link)
        combine.inputs["X"].default_value = 0.0
    return copy


def _slice_offsets(group) -> set:
    """The Combine XYZ nodes that make the slice's offset of the group's sliced reads."""
    offsets = set()
    for read in _reads(group):
        node = read.inputs["Vector"].links[0].from_node  # xy0, xy1 = xy0 + one slice, or xy (not sliced)
        while node.bl_idname == "ShaderNodeVectorMath" and not node.inputs[1].is_linked:
            node = node.inputs[0].links[0].from_node  # xy1 -> xy0
        if node.bl_idname == "ShaderNodeVectorMath":  # xy0 = xy + combine(i0 step, 0, 0)
            offsets.add(node.inputs[1].links[0].from_node)
    if not offsets:
        raise ValueError(f"{group.name}: no sliced reads")
    return offsets


def slices_by_position(mat, label: str, azimuths: int):
    """The group with its slice chosen by the object's height (Generated z) instead of the view's azimuth:
    the same reads of the same images, the slices changing smoothly over the surface."""
    copy, group = _group_copy(mat, label)
    node = node_builder(group)
    z = node("ShaderNodeSeparateXYZ", ((0, node("ShaderNodeTexCoord").outputs["Generated"]),)).outputs["Z"]
    index = node("ShaderNodeMath", ((0, z), (1, azimuths - 2.0)), operation="MULTIPLY").outputs[0]
    index = node("ShaderNodeMath", ((0, index),), operation="FLOOR").outputs[0]
    offset = node("ShaderNodeMath", ((0, index), (1, 1.0 / azimuths)), operation="MULTIPLY").outputs[0]
    for combine in _slice_offsets(group):
        group.links.new(offset, combine.inputs["X"])
    return copy


def read_with(mat, label: str, interpolation: str):
    """The group with its Image Texture nodes set to ``interpolation``."""
    copy, group = _group_copy(mat, label)
    for read in _reads(group):
        read.interpolation = interpolation
    return copy


def variants(obj, preset_name: str) -> list:
    from layered_brdf_addon.model import preset
    from layered_brdf_addon.model.policy import plan_effects
    from layered_brdf_addon.model.table_bake import table_layout

    params = preset(preset_name).replace(evaluation="tables")
    reference = stock_variants()[0]
    tables = layered_variant(obj, preset_name, "tables", preset(preset_name).accuracy)
    floor = table_floor_variants(tables)[0]
    out = [reference, tables, floor]
    label = f"{preset_name}: tables, no slice offset"
    out.append(kept_variant(label, without_slice_offset(tables.material, label)))
    label = f"{preset_name}: tables, slices by position"
    azimuths = table_layout(params, plan_effects(params)).azimuths
    out.append(kept_variant(label, slices_by_position(tables.material, label, azimuths)))
    for interpolation in ("Linear", "Closest"):
        label = f"{preset_name}: tables read {interpolation}"
        out.append(kept_variant(label, read_with(tables.material, label, interpolation)))
    return out


def slice_jumps(obj, tables) -> float:
    """Of the pairs of horizontally neighbouring pixels on the object, the fraction whose slice positions
    (``u`` in tables._slice_reader, in slices) differ by more than one: the group's slice position sent to
    an Emission shader, rendered by Cycles at one sample into a temporary OpenEXR."""
    import tempfile

    import bpy
    import numpy as np

    copy, group = _group_copy(tables.material, f"{tables.label}: slice position")
    floor = next(n for n in group.nodes if n.bl_idname == "ShaderNodeMath" and n.operation == "FLOOR")
    emission = node_builder(group)("ShaderNodeEmission", (("Color", floor.inputs[0].links[0].from_socket),))
    output = next(n for n in group.nodes if n.bl_idname == "NodeGroupOutput")
    group.links.new(emission.outputs[0], next(s for s in output.inputs if s.type == "SHADER"))
    use_variant(obj, kept_variant(copy.name, copy))
    scene = bpy.context.scene
    saved = (scene.cycles.samples, scene.render.film_transparent, scene.render.filepath,
             scene.render.image_settings.file_format)
    with tempfile.TemporaryDirectory() as tmp:
        scene.cycles.samples, scene.render.film_transparent = 1, True
        scene.render.image_settings.file_format = "OPEN_EXR"
        scene.render.filepath = str(Path(tmp) / "slices.exr")
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(scene.render.filepath)
        px = np.array(image.pixels[:], dtype=np.float32).reshape(image.size[1], image.size[0], 4)
        bpy.data.images.remove(image)
    (scene.cycles.samples, scene.render.film_transparent, scene.render.filepath,
     scene.render.image_settings.file_format) = saved
    on = px[..., 3] > 0.99
    pairs = on[:, 1:] & on[:, :-1]
    return float((np.abs(np.diff(px[..., 0], axis=1))[pairs] > 1.0).mean())


def measure(obj, vs, samples, reps, log=print) -> list[dict]:
    """Wall time of EEVEE renders of each variant at each number of samples (after a first render, which
    compiles), repetitions interleaved; the slope per sample of the medians."""
    import bpy

    engine = eevee_engine()
    scene = bpy.context.scene
    scene.render.film_transparent = True
    rows = [dict(label=v.label, per_point_nodes=v.per_point, walls={str(n): [] for n in samples}) for v in vs]
    for v, row in zip(vs, rows):
        use_variant(obj, v, engine)
        scene.eevee.taa_render_samples = samples[0]
        row["first_wall"] = timed_render()[1]
        row["magenta"] = magenta_fraction()
    for rep in range(reps):
        for v, row in zip(vs, rows):
            use_variant(obj, v, engine)
            for n in samples:
                scene.eevee.taa_render_samples = n
                row["walls"][str(n)].append(timed_render()[1])
        log(f"  rep {rep + 1}/{reps} done")
    lo, hi = samples
    for row in rows:
        med = {n: spread(row["walls"][str(n)])["median"] for n in samples}
        row["per_sample"] = (med[hi] - med[lo]) / (hi - lo)
        row["ok"] = row["magenta"] < MAGENTA_FAILED
    for row in rows:
        row["vs_reference"] = row["per_sample"] / rows[0]["per_sample"]
    scene.render.engine = "CYCLES"
    scene.render.film_transparent = False
    return rows


def table(d: dict) -> str:
    lo, hi = d["samples"]
    lines = [f"EEVEE ({d['engine']}, software GL), bench scene, wall time per sample from {lo} and {hi} samples "
             f"(medians of {d['reps']}); Blender {d['machine']['bpy']}, {d['machine']['cpu_count']} CPUs.", "",
             "| material | nodes per point | first frame (s) | s / sample | x Principled + Thin Film |",
             "|---|---|---|---|---|"]
    for r in d["rows"]:
        nodes = "" if r["per_point_nodes"] is None else r["per_point_nodes"]
        flag = "" if r["ok"] else " (magenta)"
        lines.append(f"| {r['label']}{flag} | {nodes} | {r['first_wall']:.1f} | {r['per_sample']:.3f} | "
                     f"{r['vs_reference']:.2f} |")
    lines += ["", f"Neighbouring pixels whose slices are more than one apart: {100 * d['slice_jumps']:.1f}%."]
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", default="fig6_medium", help="a preset with a tilted boundary (default fig6_medium)")
    ap.add_argument("--samples", type=int, nargs=2, default=(1, 16), metavar=("LO", "HI"))
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--out", type=Path, default=OUT_JSON)
    args = ap.parse_args(argv)
    if args.samples[1] <= args.samples[0]:
        ap.error("--samples LO HI needs HI > LO")
    obj = build_scene()
    if eevee_engine() is None:
        print("no EEVEE engine in this Blender")
        return
    vs = variants(obj, args.preset)
    jumps = slice_jumps(obj, vs[1])
    d = dict(machine=machine_info(), engine=eevee_engine(), preset=args.preset, samples=list(args.samples),
             reps=args.reps, slice_jumps=jumps, rows=measure(obj, vs, tuple(args.samples), args.reps))
    write_json(d, args.out)
    print(table(d))


if __name__ == "__main__":
    main()
