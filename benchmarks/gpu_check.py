"""The layered material on a GPU: renders, per pixel against the CPU, and what it costs there.

For each GPU device type Cycles finds on this machine (OptiX and CUDA; HIP, Metal and oneAPI
where present), and with ``--devices CPU`` for a check of the check itself:

* the reference spheres (a row of the artist presets and two tilted boundaries, each with the node
  group reading its baked tables, the node group computing its closures and, on OptiX, the OSL
  shader; 64 px, fixed seed, no denoiser, no adaptive sampling) rendered on the device and on the
  CPU, compared pixel by pixel (a pixel fails when a channel is off by more than 5%: the two devices
  round differently);
* the realistic scene (benchmarks/bench_scene.py: Suzanne, HDRI + sun) with Principled BSDF + Thin
  Film, the oil slick and a tilted boundary (fig6_medium) in each form: wall time per sample on the
  device, from two sample counts (median of three pairs).

Writes benchmarks/results/gpu_check.json (or --out) after each step, so that a run cut short keeps
what it compared, and prints a table.  Without a GPU it says so and writes that, and exits 0:
everything else in the project runs without one.  A GPU whose CUDA kernels Blender does not ship
compiles them on the first render (docs/tables.md, GPU: more than five minutes on a Hopper card).

    make gpu-check            # every GPU device type found
    python benchmarks/gpu_check.py --devices CPU   # the comparison machinery, CPU against CPU
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
OUT_JSON = RESULTS / "gpu_check.json"
GPU_TYPES = ("OPTIX", "CUDA", "HIP", "METAL", "ONEAPI")
PRESETS = ("soap_bubble", "oil_slick", "beetle_shell", "anodised_titanium", "old_metal", "glazed_clay",
           "fig4_tilted", "fig6_medium")  # the last two: a tilted lower boundary
FORMS = {"tables": ("nodes", "tables"), "nodes": ("nodes", "arithmetic"), "osl": ("osl", "tables")}
HEIGHT = 64
SAMPLES = 16
REL_TOL = 0.05
MAX_FAILING = 0.02
SCENE_SAMPLES = {"CPU": (4, 16), "GPU": (64, 1024)}  # a GPU's fixed costs hide small sample counts
SCENE_REPS = 3
SCENE_PRESETS = ("oil_slick", "fig6_medium")  # equal indices; a tilted, dispersive boundary
SCENE_BACKENDS = {"tables": "tables", "nodes": "nodes", "osl": "osl-tables"}  # bench_scene's names


def device_types() -> dict[str, list[str]]:
    """GPU device types Cycles finds, with their devices' names."""
    import bpy

    prefs = bpy.context.preferences.addons["cycles"].preferences
    found = {}
    for kind in GPU_TYPES:
        try:
            devices = prefs.get_devices_for_type(kind)
        except (TypeError, ValueError, AttributeError):
            continue
        names = [d.name for d in devices if d.type == kind]
        if names:
            found[kind] = names
    return found


def use_device(scene, kind: str) -> None:
    """Render ``scene`` on the devices of ``kind`` ("CPU" for the CPU)."""
    import bpy

    if kind == "CPU":
        scene.cycles.device = "CPU"
        return
    prefs = bpy.context.preferences.addons["cycles"].preferences
    prefs.compute_device_type = kind
    for d in prefs.get_devices_for_type(kind):
        d.use = d.type == kind
    scene.cycles.device = "GPU"


def render_spheres_on(kind: str, form: str):
    """The artist presets in a row, in ``form`` (tables, nodes or osl), rendered on ``kind``: beauty."""
    import bpy

    from layered_brdf_addon.blender.material import apply_layered_material
    import math

    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                                  row_of_spheres)
    from layered_brdf_addon.model import preset
    from layered_brdf_addon.model.sphere import Sun

    backend, evaluation = FORMS[form]
    reset_blender()
    sun = Sun(direction=(0.0, -math.cos(math.radians(40.0)), math.sin(math.radians(40.0))), strength=1.0)
    spheres = build_scene(SceneSpec(camera=camera_for(len(PRESETS), HEIGHT), sun=sun,
                                    centers=row_of_spheres(len(PRESETS)), samples=SAMPLES, osl=backend == "osl"))
    for obj, name in zip(spheres, PRESETS):
        apply_layered_material(obj, preset(name).replace(evaluation=evaluation), backend, name=name)
    scene = bpy.context.scene
    scene.render.threads_mode = "AUTO"
    use_device(scene, kind)
    return render_passes().beauty[..., :3]


def compare_spheres(kind: str, forms) -> list[dict]:
    from layered_brdf_addon.blender.scene import camera_for, row_of_spheres
    from layered_brdf_addon.model.sphere import sphere_geometry
    from layered_brdf_reference.compare import agreement

    geo = sphere_geometry(camera_for(len(PRESETS), HEIGHT), row_of_spheres(len(PRESETS)))
    rows = []
    for form in forms:
        t0 = time.perf_counter()
        device = render_spheres_on(kind, form)
        t_device = time.perf_counter() - t0
        t0 = time.perf_counter()
        cpu = render_spheres_on("CPU", form)
        t_cpu = time.perf_counter() - t0
        for k, name in enumerate(PRESETS):
            ag = agreement(device, cpu, geo.sphere == k, rel_tol=REL_TOL)
            rows.append(dict(device=kind, form=form, preset=name, failing=ag.failing_fraction,
                             ok=ag.failing_fraction <= MAX_FAILING, summary=str(ag), render_s=t_device,
                             cpu_render_s=t_cpu))
        worst = max(rows[-len(PRESETS):], key=lambda r: r["failing"])
        print(f"spheres, {form}: {kind} {t_device:.1f} s, CPU {t_cpu:.1f} s (scene built and rendered); "
              f"most pixels off: {worst['preset']}, {worst['summary']}", flush=True)
    return rows


def scene_costs(kind: str, forms) -> list[dict]:
    """Wall time per sample on ``kind`` of Principled BSDF + Thin Film and of SCENE_PRESETS in each form."""
    import bpy

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_scene import build_scene
    from scene_variants import REFERENCE, THIN_FILM_IOR, THIN_FILM_NM, layered_variant
    from timing import PRINCIPLED, stock_material, thin_film_inputs, timed_render

    from layered_brdf_addon.blender.scene import reset_blender
    from layered_brdf_addon.model import preset

    reset_blender()
    obj = build_scene()
    scene = bpy.context.scene
    scene.render.threads_mode = "AUTO"
    materials = [(REFERENCE, stock_material(REFERENCE, PRINCIPLED, thin_film_inputs(THIN_FILM_NM, THIN_FILM_IOR)))]
    for name in SCENE_PRESETS:
        for form in forms:
            v = layered_variant(obj, name, SCENE_BACKENDS[form], preset(name).accuracy)
            materials.append((v.label, v.material))
    out = []
    lo, hi = SCENE_SAMPLES["CPU" if kind == "CPU" else "GPU"]
    for label, mat in materials:
        obj.material_slots[0].material = mat
        scene.cycles.shading_system = "osl" in label.split()
        use_device(scene, kind)
        scene.cycles.samples = lo
        first = timed_render()[1]  # kernels, shaders
        per_sample = []
        for _ in range(SCENE_REPS):
            times = {}
            for n in (lo, hi):
                scene.cycles.samples = n
                times[n] = timed_render()[1]
            per_sample.append((times[hi] - times[lo]) / (hi - lo))
        print(f"scene, {label}: first render {first:.1f} s, {1e3 * statistics.median(per_sample):.3f} ms / sample",
              flush=True)
        out.append(dict(device=kind, material=label, samples=(lo, hi), first_render_s=first,
                        wall_per_sample=statistics.median(per_sample), runs=per_sample))
    ref = out[0]["wall_per_sample"]
    for row in out:
        row["vs_reference"] = row["wall_per_sample"] / ref if ref > 0 else None
    return out


def report(d: dict) -> str:
    if not d["devices"]:
        return f"No GPU device found ({d['machine']['bpy']}): nothing to check."
    lines = ["| device | form | preset | pixels off by > 5% | agrees | render (s), device / CPU |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r['device']} | {r['form']} | {r['preset']} | {100 * r['failing']:.2f}% | "
              f"{'yes' if r['ok'] else 'NO'} | {r['render_s']:.1f} / {r['cpu_render_s']:.1f} |" for r in d["spheres"]]
    lines += ["", "| device | material | ms / sample (wall) | x Principled + Thin Film | first render (s) |",
              "|---|---|---|---|---|"]
    lines += [f"| {r['device']} | {r['material']} | {1e3 * r['wall_per_sample']:.3f} | "
              f"{r['vs_reference']:.2f} | {r['first_render_s']:.1f} |" for r in d["scene"]]
    return "\n".join(lines)


def save(d: dict, out: Path) -> None:
    """Write the results so far, whole (a temporary file renamed over the last)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".partial")
    tmp.write_text(json.dumps(d, indent=1))
    os.replace(tmp, out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--devices", nargs="*", help="device types to check (default: every GPU type found; "
                                                 "CPU checks the machinery against itself)")
    ap.add_argument("--forms", nargs="+", choices=list(FORMS), default=list(FORMS),
                    help="the material's forms to check (default: all; OSL only on OptiX and the CPU)")
    ap.add_argument("--out", type=Path, default=OUT_JSON)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from timing import machine_info

    found = device_types()
    kinds = args.devices if args.devices is not None else list(found)
    d = dict(machine=machine_info(), found=found, devices=kinds, spheres=[], scene=[])
    missing = [k for k in kinds if k != "CPU" and k not in found]
    if missing:  # Cycles would render on the CPU and the check would compare the CPU with itself
        ap.error(f"--devices: no {', '.join(missing)} device found (found: {', '.join(found) or 'none'})")
    save(d, args.out)
    for kind in kinds:
        forms = [f for f in args.forms if f != "osl" or kind in ("OPTIX", "CPU")]  # OSL: CPU and OptiX only
        for form in forms:  # each form's rows saved as they come: what is done stays, should a later step hang
            d["spheres"] += compare_spheres(kind, [form])
            save(d, args.out)
        d["scene"] += scene_costs(kind, forms)
        save(d, args.out)
    print(report(d))
    return 0 if all(r["ok"] for r in d["spheres"]) else 1


if __name__ == "__main__":
    sys.exit(main())
