"""The layered material on a GPU: renders, per pixel against the CPU, and what it costs there.

For each GPU device type Cycles finds on this machine (OptiX and CUDA; HIP, Metal and oneAPI
where present), and with ``--devices CPU`` for a check of the check itself:

* the reference spheres (a row of the artist presets, each with the node group reading its baked
  tables, the node group computing its closures and, on OptiX, the OSL shader; 64 px, fixed seed,
  no denoiser, no adaptive sampling) rendered on the device and on the CPU, compared pixel by pixel
  (a pixel fails when a channel is off by more than 5%: the two devices round differently);
* the realistic scene (benchmarks/bench_scene.py: Suzanne, HDRI + sun) with Principled BSDF + Thin
  Film and the oil slick in each form: wall time per sample on the device, from two sample counts.

Writes benchmarks/results/gpu_check.json (or --out) and prints a table.  Without a GPU it says so
and writes that, and exits 0: everything else in the project runs without one.

    make gpu-check            # every GPU device type found
    python benchmarks/gpu_check.py --devices CPU   # the comparison machinery, CPU against CPU
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
OUT_JSON = RESULTS / "gpu_check.json"
GPU_TYPES = ("OPTIX", "CUDA", "HIP", "METAL", "ONEAPI")
PRESETS = ("soap_bubble", "oil_slick", "beetle_shell", "anodised_titanium", "old_metal", "glazed_clay")
FORMS = {"tables": ("nodes", "tables"), "nodes": ("nodes", "arithmetic"), "osl": ("osl", "tables")}
HEIGHT = 64
SAMPLES = 16
REL_TOL = 0.05
MAX_FAILING = 0.02
SCENE_SAMPLES = (4, 16)


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
    return rows


def scene_costs(kind: str, forms) -> list[dict]:
    """Wall time per sample on ``kind`` of Principled BSDF + Thin Film and the oil slick in each form."""
    import bpy

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_scene import build_scene
    from scene_variants import REFERENCE, THIN_FILM_IOR, THIN_FILM_NM, layered_variant
    from timing import PRINCIPLED, stock_material, thin_film_inputs, timed_render

    from layered_brdf_addon.blender.scene import reset_blender

    reset_blender()
    obj = build_scene()
    scene = bpy.context.scene
    scene.render.threads_mode = "AUTO"
    materials = [(REFERENCE, stock_material(REFERENCE, PRINCIPLED, thin_film_inputs(THIN_FILM_NM, THIN_FILM_IOR)))]
    for form in forms:
        v = layered_variant(obj, "oil_slick", form, "analytic")
        materials.append((v.label, v.material))
    out = []
    lo, hi = SCENE_SAMPLES
    for label, mat in materials:
        obj.material_slots[0].material = mat
        scene.cycles.shading_system = "osl" in label.split()
        use_device(scene, kind)
        scene.cycles.samples = lo
        timed_render()  # kernels, shaders
        times = {}
        for n in (lo, hi):
            scene.cycles.samples = n
            times[n] = timed_render()[1]
        out.append(dict(device=kind, material=label, wall_per_sample=(times[hi] - times[lo]) / (hi - lo)))
    ref = out[0]["wall_per_sample"]
    for row in out:
        row["vs_reference"] = row["wall_per_sample"] / ref if ref > 0 else None
    return out


def report(d: dict) -> str:
    if not d["devices"]:
        return f"No GPU device found ({d['machine']['bpy']}): nothing to check."
    lines = ["| device | form | preset | pixels off by > 5% | agrees |", "|---|---|---|---|---|"]
    lines += [f"| {r['device']} | {r['form']} | {r['preset']} | {100 * r['failing']:.2f}% | "
              f"{'yes' if r['ok'] else 'NO'} |" for r in d["spheres"]]
    lines += ["", "| device | material | ms / sample (wall) | x Principled + Thin Film |", "|---|---|---|---|"]
    lines += [f"| {r['device']} | {r['material']} | {1e3 * r['wall_per_sample']:.1f} | "
              f"{r['vs_reference']:.2f} |" for r in d["scene"]]
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--devices", nargs="*", help="device types to check (default: every GPU type found; "
                                                 "CPU checks the machinery against itself)")
    ap.add_argument("--out", type=Path, default=OUT_JSON)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from timing import machine_info

    found = device_types()
    kinds = args.devices if args.devices is not None else list(found)
    d = dict(machine=machine_info(), found=found, devices=kinds, spheres=[], scene=[])
    for kind in kinds:
        forms = [f for f in FORMS if f != "osl" or kind in ("OPTIX", "CPU")]  # OSL: CPU and OptiX only
        d["spheres"] += compare_spheres(kind, forms)
        d["scene"] += scene_costs(kind, forms)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".partial")
    tmp.write_text(json.dumps(d, indent=1))
    os.replace(tmp, args.out)
    print(report(d))
    return 0 if all(r["ok"] for r in d["spheres"]) else 1


if __name__ == "__main__":
    sys.exit(main())
