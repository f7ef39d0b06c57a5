"""What accuracy and effects cost in render time (Cycles CPU, the reference scene).

For each configuration the cost per sample is the difference between renders at two
sample counts divided by the difference of the counts, so scene set-up, shader
compilation and BVH building do not count.  All ratios are taken within one run.

Configurations: the layered material with the effect plan of its parameters
("planned") and with the always-full shader ("full"), each with the node group and
the OSL shader (Beckmann, and Phong lobes for OSL), against Blender's Principled
BSDF with Thin Film and a plain Diffuse BSDF on the same scene and samples.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from report import cost_table  # benchmarks/ is on sys.path when the script runs
from timing import DIFFUSE, PRINCIPLED, cost_per_sample, stock_material, thin_film_inputs

RESULTS = Path(__file__).resolve().parent / "results"


def _scene(backend_osl: bool, size: int):
    from layered_brdf_addon.blender import scene
    from layered_brdf_addon.model.sphere import Sun

    scene.reset_blender()
    cam = scene.camera_for(1, size)
    sun = Sun(direction=(0.0, -np.cos(np.radians(40.0)), np.sin(np.radians(40.0))), strength=3.0)
    spheres = scene.build_scene(scene.SceneSpec(camera=cam, sun=sun, osl=backend_osl, threads=1))
    return scene, spheres[0]


def _time_render(scene, samples: int) -> float:
    import bpy

    bpy.context.scene.cycles.samples = samples
    with __import__("tempfile").TemporaryDirectory() as tmp:
        return scene.render_to_exr(Path(tmp) / "r.exr")


def per_sample(scene, s1: int, s2: int, repeats: int) -> float:
    _time_render(scene, 1)  # warm: kernels, shader compilation
    best1 = min(_time_render(scene, s1) for _ in range(repeats))
    best2 = min(_time_render(scene, s2) for _ in range(repeats))
    return max(cost_per_sample(best1, best2, s1, s2), 1e-9)


def principled_thin_film(obj):
    obj.data.materials.append(stock_material("PrincipledThinFilm", PRINCIPLED, thin_film_inputs(300.0, 1.33, 0.2)))


def plain_diffuse(obj):
    obj.data.materials.append(stock_material("Diffuse", DIFFUSE))


def run(presets, size, s1, s2, repeats, spectral_preset="fig6_medium",
        spectral_modes=("rgb", "spectral4", "spectral8", "spectral16", "spectral32")):
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.model import preset
    from layered_brdf_addon.model.plan import EffectPlan
    from layered_brdf_addon.model.policy import plan_effects

    rows = []
    scene, obj = _scene(False, size)
    principled_thin_film(obj)
    ref = per_sample(scene, s1, s2, repeats)
    rows.append(dict(config="Principled BSDF + Thin Film", backend="nodes", per_sample=ref))
    scene, obj = _scene(False, size)
    plain_diffuse(obj)
    rows.append(dict(config="Diffuse BSDF", backend="nodes", per_sample=per_sample(scene, s1, s2, repeats)))
    for name in presets:
        p = preset(name)
        planned = plan_effects(p)
        for backend, lobe in (("nodes", "beckmann"), ("osl", "beckmann"), ("osl", "phong")):
            q = p.replace(lobe=lobe)
            for which, plan in (("planned", planned), ("full", EffectPlan.full(lobe=lobe))):
                plan = EffectPlan(**{**plan.to_dict(), "lobe": lobe})
                scene, obj = _scene(backend == "osl", size)
                apply_layered_material(obj, q, backend, plan=plan)
                t = per_sample(scene, s1, s2, repeats)
                rows.append(dict(config=f"{name} {which} [{plan.key}]", preset=name, which=which, backend=backend,
                                 lobe=lobe, plan=plan.key, per_sample=t))
    # Accuracy modes: RGB and N wavelengths, both backends, the planned shader of one preset.
    rgb_nodes = None
    for mode in spectral_modes:
        for backend in ("nodes", "osl"):
            p = preset(spectral_preset).replace(accuracy=mode)
            scene, obj = _scene(backend == "osl", size)
            apply_layered_material(obj, p, backend)
            t = per_sample(scene, s1, s2, repeats)
            if mode == "rgb" and backend == "nodes":
                rgb_nodes = t
            rows.append(dict(config=f"{spectral_preset} {mode}", preset=spectral_preset, which="mode", mode=mode,
                             backend=backend, lobe="beckmann", plan=plan_effects(p).key, per_sample=t))
    for r in rows:
        r["vs_principled"] = r["per_sample"] / ref
        if rgb_nodes:
            r["vs_rgb_nodes"] = r["per_sample"] / rgb_nodes
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--presets", nargs="*", default=["fig3_clay", "fig4_parallel", "fig6_medium", "soap_bubble",
                                                      "glazed_clay", "beetle_shell"])
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--samples", type=int, nargs=2, default=(4, 36))
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)
    t0 = time.time()
    rows = run(args.presets, args.size, args.samples[0], args.samples[1], args.repeats)
    RESULTS.mkdir(exist_ok=True)
    out = RESULTS / "render_cost.json"
    tmp = out.with_suffix(".partial")
    tmp.write_text(json.dumps(dict(size=args.size, samples=args.samples, threads=1, rows=rows), indent=1))
    os.replace(tmp, out)
    print(f"best of {args.repeats}; {time.time() - t0:.0f} s in all")
    print(cost_table())

if __name__ == "__main__":
    main()
