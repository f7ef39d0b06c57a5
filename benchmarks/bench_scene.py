"""What the layered material costs on a realistic scene, against Blender's own BSDFs.

Scene: Suzanne with a level-2 Subdivision Surface, smooth shaded, at 256 x 256, lit by
one of Blender's bundled studio HDRIs and a sun; Cycles on the CPU with its default
bounces, a fixed seed, no denoising, no adaptive sampling, one render thread.

Cycles: for every variant (Principled BSDF + Thin Film, Principled, Glossy, Diffuse, the
closures alone (and, when OSL is measured, the same closures as an OSL shader and Principled
BSDF + Thin Film under Cycles' OSL shading system: OSL's own floor), and the layered material
for each preset x backend, RGB, plus every accuracy mode for one preset) the cost per sample is (t_hi - t_lo) / (n_hi - n_lo), t the process CPU time of
a render at n samples.  Each variant gets a warm-up render first (kernels, shader
compilation); repetitions are interleaved (rep 1: every variant, rep 2: every variant,
...), so slow drifts of a shared machine spread over all variants.  Ratios are of
medians, within this one run.

EEVEE (when it starts): the node group (tables and computed) for two presets, and spectral 16
for one, against Principled BSDF with and without Thin Film: wall time of the first frame
(shader compilation) and of the frames after it, and whether the render succeeded (a
material that fails to compile renders magenta).

Node counts: the nodes each node-group variant's group interprets: those an output depends
on, nested groups expanded (group input/output, reroute and frame nodes excluded).

Tables: for each variant reading baked tables, the time of a bake (the shading program on
numpy over the tables' texels, median of several) and the tables' size in memory; for the OSL
shader reading them, also what a change of a value costs it ("change": a bake, its text written
and compiled).

Writes benchmarks/results/scene_cost.json (every raw measurement) and prints a table.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from scene_variants import (REFERENCE, THIN_FILM_IOR, THIN_FILM_NM, Variant, floor_variants, layered_variant,
                            layered_variants, stock_variants, table_floor_variants)
from timing import DIFFUSE, cost_per_sample, machine_info, spread, stock_material, timed_render

RESULTS = Path(__file__).resolve().parent / "results"
OUT_JSON = RESULTS / "scene_cost.json"

SIZE = 256
SUBDIV_LEVELS = 2
HDRI_STRENGTH = 1.0
SUN_STRENGTH = 3.0
SUN_ROTATION_DEG = (50.0, 0.0, 30.0)
CAMERA_LOCATION = (1.6, -4.6, 1.0)
SEED = 0

# "tables": the node group reading the material's baked tables; "nodes": the node group computing its
# closures (Evaluation 'arithmetic'); "osl-tables": the OSL shader reading them; "osl": the OSL shader
# computing.
BACKENDS = ("tables", "nodes", "osl-tables", "osl")
SPECTRAL_PRESET = "fig4_parallel"  # parallel boundaries: every accuracy mode also reads baked tables

DEFAULTS = dict(samples=(1, 6), reps=3, eevee_samples=4, eevee_frames=2)
QUICK = dict(samples=(1, 3), reps=1, eevee_samples=1, eevee_frames=1, presets=(SPECTRAL_PRESET,),
             spectral_modes=("rgb",), eevee_presets=())
EEVEE_PRESETS = ("oil_slick", "glazed_clay")
EEVEE_FAILING = ("fig6_medium", "spectral16")  # computed closures known not to link in EEVEE: the check must see it
MAGENTA_TOL = 0.1  # a pixel within this of (1, 0, 1) is Blender's "shader failed" colour
MAGENTA_FAILED = 0.5  # the render failed when this fraction of the object's pixels is magenta


# --- scene -------------------------------------------------------------------------------------
def hdri_path() -> Path:
    """The first of forest, courtyard and studio among Blender's bundled studio lights."""
    from layered_brdf_addon.blender.lookdev import hdri_path as bundled_hdri

    return bundled_hdri()


def build_scene():
    """Suzanne, camera, HDRI world and sun in a factory-fresh file; returns Suzanne."""
    import bpy
    from mathutils import Vector
    from math import radians

    from layered_brdf_addon.blender.scene import deterministic_cycles

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    obj = bpy.context.active_object
    obj.modifiers.new("Subdivision", "SUBSURF").levels = SUBDIV_LEVELS
    obj.modifiers["Subdivision"].render_levels = SUBDIV_LEVELS
    obj.data.shade_smooth()
    obj.data.materials.append(None)

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = CAMERA_LOCATION
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (-Vector(CAMERA_LOCATION)).to_track_quat("-Z", "Y")
    scene.collection.objects.link(cam)
    scene.camera = cam

    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = SUN_STRENGTH
    sun.rotation_euler = tuple(radians(a) for a in SUN_ROTATION_DEG)
    scene.collection.objects.link(sun)

    world = bpy.data.worlds.new("HDRI")
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(hdri_path()))
    bg = nt.nodes.get("Background") or nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = HDRI_STRENGTH
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    scene.world = world

    deterministic_cycles(scene, (SIZE, SIZE), None, 1, SEED)  # samples: set per render
    return obj


def use_variant(obj, v: Variant, engine: str = "CYCLES") -> None:
    """Put the variant's material on Suzanne and set the engine (and OSL) it needs."""
    import bpy

    scene = bpy.context.scene
    obj.material_slots[0].material = v.material
    scene.render.engine = engine
    scene.cycles.shading_system = v.osl


# --- failed-render check -----------------------------------------------------------------------
def magenta_fraction(scene=None) -> float:
    """Fraction of the object's pixels (alpha > 0.5, or all pixels without a transparent film)
    in the last render that are Blender's "shader failed" magenta."""
    import bpy
    import numpy as np

    scene = scene or bpy.context.scene
    s = scene.render.image_settings
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGBA"
    s.color_depth = "32"
    with tempfile.TemporaryDirectory(prefix="bench_scene_") as tmp:
        path = Path(tmp) / "r.exr"
        bpy.data.images["Render Result"].save_render(filepath=str(path), scene=scene)
        img = bpy.data.images.load(str(path))
        try:
            px = np.empty(img.size[0] * img.size[1] * 4, dtype=np.float32)
            img.pixels.foreach_get(px)
        finally:
            bpy.data.images.remove(img)
    px = px.reshape(-1, 4)
    mask = px[:, 3] > 0.5 if scene.render.film_transparent else np.ones(len(px), bool)
    if not mask.any():
        return 0.0
    from layered_brdf_addon.blender.scene import shader_failed

    return float(shader_failed(px[mask], MAGENTA_TOL).mean())


# --- Cycles ------------------------------------------------------------------------------------
def render_cycles(n: int) -> tuple[float, float]:
    import bpy

    bpy.context.scene.cycles.samples = n
    return timed_render()


def measure_cycles(obj, variants, samples, reps, log=print) -> list[dict]:
    """Warm-up render per variant, then ``reps`` interleaved rounds of renders at both sample
    counts; one record per variant with the raw times."""
    lo, hi = samples
    records = []
    for v in variants:
        use_variant(obj, v)
        cpu, wall = render_cycles(lo)
        records.append(dict(v.record(), warmup=dict(cpu=cpu, wall=wall), magenta=magenta_fraction(), reps=[]))
        log(f"  warm-up {v.label}: {cpu:.1f} s CPU")
    for rep in range(reps):
        for v, rec in zip(variants, records):
            use_variant(obj, v)
            t_lo, w_lo = render_cycles(lo)
            t_hi, w_hi = render_cycles(hi)
            rec["reps"].append(dict(cpu_lo=t_lo, cpu_hi=t_hi, wall_lo=w_lo, wall_hi=w_hi,
                                    per_sample=cost_per_sample(t_lo, t_hi, lo, hi)))
        log(f"  rep {rep + 1}/{reps} done")
    ref = None
    for rec in records:
        rec["per_sample"] = spread(r["per_sample"] for r in rec["reps"])
        if rec["label"] == REFERENCE:
            ref = rec["per_sample"]["median"]
    for rec in records:
        rec["vs_reference"] = rec["per_sample"]["median"] / ref if ref else None
    return records


# --- EEVEE -------------------------------------------------------------------------------------
def eevee_engine() -> str | None:
    """EEVEE's engine id in this Blender (BLENDER_EEVEE_NEXT in 4.2-4.x, BLENDER_EEVEE again since)."""
    from layered_brdf_addon.blender.lookdev import eevee_engine as engine

    return engine()


def measure_eevee(obj, variants, samples, frames, log=print) -> dict:
    """First-frame and later-frame wall times per variant, and whether each render succeeded.
    A first render with the Diffuse BSDF takes EEVEE's own start-up cost out of the others."""
    import bpy

    engine = eevee_engine()
    if engine is None:
        return dict(skipped="no EEVEE engine in this Blender")
    scene = bpy.context.scene
    scene.eevee.taa_render_samples = samples
    scene.render.film_transparent = True  # the object's pixels, for the magenta check
    out = dict(engine=engine, samples=samples, frames=frames, rows=[])
    try:
        use_variant(obj, Variant("Diffuse BSDF", material=stock_material("EEVEE start-up", DIFFUSE)), engine)
        out["startup_wall"] = timed_render()[1]
    except Exception as exc:  # EGL / software GL not available: no EEVEE on this machine
        out["skipped"] = f"EEVEE did not start: {exc}"
        return out
    finally:
        scene.render.engine = "CYCLES"
    log(f"  EEVEE start-up: {out['startup_wall']:.1f} s")
    for v in variants:
        use_variant(obj, v, engine)
        row = dict(v.record())
        try:
            row["first_wall"] = timed_render()[1]
            row["magenta"] = magenta_fraction()
            row["frames_wall"] = [timed_render()[1] for _ in range(frames)]
            row["frame"] = spread(row["frames_wall"])
            row["ok"] = row["magenta"] < MAGENTA_FAILED
        except Exception as exc:
            row["ok"], row["error"] = False, str(exc)
        out["rows"].append(row)
        log(f"  EEVEE {v.label}: first frame {row.get('first_wall', float('nan')):.1f} s, ok={row['ok']}")
    scene.render.engine = "CYCLES"
    scene.render.film_transparent = False
    return out


def eevee_variants(obj, measured, presets, failing) -> list[Variant]:
    """Plain Principled, the node group of ``presets`` (each in its own accuracy mode) and the
    known-failing group: the Cycles variants (``measured``) where there are, new ones where not."""
    from layered_brdf_addon.model import preset

    by_key = {(v.preset, v.backend, v.accuracy): v for v in measured}
    vs = [v for v in measured if v.label in (REFERENCE, "Principled BSDF")]
    for key in [(p, preset(p).accuracy) for p in presets] + ([failing] if failing else []):
        for backend in ("tables", "nodes"):
            vs.append(by_key.get((key[0], backend, key[1])) or layered_variant(obj, key[0], backend, key[1]))
    return vs


# --- report ------------------------------------------------------------------------------------
def table(d: dict) -> str:
    """Markdown tables of a scene_cost.json."""
    s = d["settings"]
    lo, hi = s["samples"]
    lines = [f"Suzanne (subdivision {s['subdiv']}), {s['size']} x {s['size']}, {s['hdri']} + sun, Cycles CPU, "
             f"1 thread, default bounces; cost per sample from {lo} and {hi} samples (process CPU time), "
             f"{s['reps']} interleaved repetitions; Blender {d['machine']['bpy']}, "
             f"{d['machine']['cpu_count']} CPUs; run took {d['seconds'] / 60:.0f} min.", "",
             "| material | backend | accuracy | optics | nodes interpreted | ms / sample min / median / max "
             "| x Principled + Thin Film | bake (ms) | tables (kB) | change (ms) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in d["cycles"]:
        p = r["per_sample"]
        flag = "" if r["magenta"] < MAGENTA_FAILED else " (magenta)"
        lines.append(f"| {r['preset'] or r['label']}{flag} | {r['backend']} | {r['accuracy'] or ''} | "
                     f"{r.get('optics') or ''} | {_nodes_cell(r)} | "
                     f"{1e3 * p['min']:.0f} / {1e3 * p['median']:.0f} / {1e3 * p['max']:.0f} | "
                     f"{r['vs_reference']:.2f} | {_cell(r.get('bake_ms'), '{:.1f}')} | "
                     f"{_cell(r.get('table_bytes') and r['table_bytes'] / 1024, '{:.0f}')} | "
                     f"{_cell(r.get('rebuild_ms'), '{:.0f}')} |")
    e = d.get("eevee", {})
    lines.append("")
    if e.get("skipped"):
        lines.append(f"EEVEE skipped: {e['skipped']}")
        return "\n".join(lines)
    lines += [f"EEVEE ({e['engine']}, software GL, wall time): {e['samples']} samples per frame, "
              f"engine start-up {e['startup_wall']:.0f} s before these.", "",
              "| material | backend | accuracy | nodes | first frame (s) | later frames (s) | renders correctly |",
              "|---|---|---|---|---|---|---|"]
    for r in e["rows"]:
        fr = r.get("frame")
        later = f"{fr['median']:.1f}" if fr else ""
        first = f"{r['first_wall']:.1f}" if "first_wall" in r else ""
        ok = "yes" if r["ok"] else ("no: " + r.get("error", "magenta"))[:80]
        lines.append(f"| {r['preset'] or r['label']} | {r['backend']} | {r['accuracy'] or ''} | "
                     f"{r['nodes'] if r['nodes'] is not None else ''} | {first} | {later} | {ok} |")
    return "\n".join(lines)


def _cell(value, fmt: str) -> str:
    return "" if value is None else fmt.format(value)


def _nodes_cell(r: dict) -> str:
    """Nodes interpreted, and of those the nodes Cycles cannot fold (records of older runs have no such count)."""
    if r["nodes"] is None:
        return ""
    per_point = r.get("per_point_nodes")
    return f"{r['nodes']}" + ("" if per_point is None else f" ({per_point} per point)")


def write_json(d: dict, path: Path = OUT_JSON) -> None:
    path.parent.mkdir(exist_ok=True)
    tmp = path.with_suffix(".partial")
    tmp.write_text(json.dumps(d, indent=1))
    os.replace(tmp, path)


def parse_args(argv=None):
    from layered_brdf_addon.model.params import ACCURACY_MODES
    from layered_brdf_addon.model.presets import PRESETS

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="a ~1 minute smoke run (2 presets, 1 rep, tiny samples)")
    ap.add_argument("--presets", nargs="*", help="presets to measure (default: all)")
    ap.add_argument("--backends", nargs="*", choices=BACKENDS, help="default: " + " ".join(BACKENDS))
    ap.add_argument("--reps", type=int, help=f"interleaved repetitions (default {DEFAULTS['reps']})")
    ap.add_argument("--samples", type=int, nargs=2, metavar=("LO", "HI"),
                    help=f"the two sample counts (default {DEFAULTS['samples']})")
    ap.add_argument("--no-eevee", action="store_true", help="skip the EEVEE part")
    ap.add_argument("--spectral-modes", nargs="*", choices=ACCURACY_MODES,
                    help=f"accuracy modes measured for {SPECTRAL_PRESET} (default: all)")
    ap.add_argument("--paper-optics", action="store_true",
                    help="also measure each physical-optics preset with the paper's optics")
    ap.add_argument("--reads-floor", action="store_true",
                    help="after each variant reading tables, its thickness pattern, tables' reads and closures "
                         "alone (no other arithmetic: what a tabulated group cannot do without), and Principled "
                         "BSDF + Thin Film with the same thickness pattern")
    ap.add_argument("--out", type=Path, default=OUT_JSON, help="the JSON to write")
    args = ap.parse_args(argv)
    base = {**DEFAULTS, "presets": tuple(PRESETS), "spectral_modes": ACCURACY_MODES,
            "eevee_presets": EEVEE_PRESETS, **(QUICK if args.quick else {})}
    args.presets = tuple(args.presets or base["presets"])
    args.backends = tuple(args.backends or BACKENDS)
    args.reps = args.reps or base["reps"]
    args.samples = tuple(args.samples or base["samples"])
    if args.samples[1] <= args.samples[0]:
        ap.error("--samples LO HI needs HI > LO")
    for key in ("eevee_presets", "eevee_samples", "eevee_frames"):
        setattr(args, key, base[key])
    args.spectral_modes = tuple(args.spectral_modes if args.spectral_modes is not None else base["spectral_modes"])
    return args


def main(argv=None):
    args = parse_args(argv)
    t0 = time.perf_counter()
    obj = build_scene()
    stock = stock_variants()
    osl_measured = any(b.startswith("osl") for b in args.backends)
    layered = layered_variants(obj, args.presets, args.backends, SPECTRAL_PRESET, args.spectral_modes,
                               args.paper_optics)
    if args.reads_floor:
        layered = [f for v in layered for f in ([v, *table_floor_variants(v)] if v.backend == "tables" else [v])]
    variants = stock + floor_variants(stock[0] if osl_measured else None) + layered
    d = dict(machine=machine_info(), seconds=0.0,
             settings=dict(size=SIZE, subdiv=SUBDIV_LEVELS, hdri=hdri_path().name, sun=SUN_STRENGTH,
                           samples=args.samples, reps=args.reps, threads=1, seed=SEED, quick=args.quick,
                           presets=args.presets, backends=args.backends, spectral_preset=SPECTRAL_PRESET,
                           spectral_modes=args.spectral_modes, reads_floor=args.reads_floor,
                           thin_film=[THIN_FILM_NM, THIN_FILM_IOR],
                           clock="process CPU time (Cycles), wall time (EEVEE)"))
    print(f"{len(variants)} Cycles variants, samples {args.samples}, {args.reps} reps")
    d["cycles"] = measure_cycles(obj, variants, args.samples, args.reps)
    d["seconds"] = time.perf_counter() - t0
    write_json(d, args.out)  # kept if EEVEE brings the process down
    if args.no_eevee:
        d["eevee"] = dict(skipped="--no-eevee")
    else:
        failing = EEVEE_FAILING if not args.quick else None
        d["eevee"] = measure_eevee(obj, eevee_variants(obj, variants, args.eevee_presets, failing),
                                   args.eevee_samples, args.eevee_frames)
        if d["eevee"].get("skipped"):
            print(d["eevee"]["skipped"])
    d["seconds"] = time.perf_counter() - t0
    write_json(d, args.out)
    print(table(d))
    print(f"{d['seconds']:.0f} s in all; wrote {args.out}")


if __name__ == "__main__":
    main()
