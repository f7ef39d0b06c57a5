"""Thickness aliasing: a far-away noise-thickness sphere at a few samples per pixel.

Where the layer's thickness varies within a pixel (a noise pattern seen from far away),
each camera sample sees a different interference colour and a few samples per pixel
turn the film into coloured noise; the converged pixel is their average.  The analytic
mode integrates the interference over each colour channel's band, and in OSL also over
the pixel's footprint (``filterwidth`` of the path difference, docs/spectral.md; reading baked
tables, ``filterwidth`` of the thickness: a box along the tables' thickness axis).  Every
variant reads the material's baked tables except the one marked "computed closures".

One sphere 24 pixels across with Fig. 3's diffuse thin film (eq. 18) on a fine noise
thickness (0-1,000 nm, several noise features per pixel), a sun at 40 degrees, Cycles'
default 1.5 px pixel filter, OSL on the CPU.  Per
variant: a 1,024-spp reference and four 4-spp renders with different seeds; over the
sphere's pixels, the per-pixel variance across the four (the noise), their RMS difference
from the variant's own reference and from the band-only variant's reference (the
converged image of the unfiltered analytic mode).  Prints a table and writes
``benchmarks/results/aliasing.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results" / "aliasing.json"
HEIGHT = 24  # pixels across the sphere's frame
FILTER_WIDTH = 1.5  # Cycles' default pixel filter (px)
LOW_SPP = 4
REFERENCE_SPP = 1024
SEEDS = (1, 2, 3, 4)
# Fig. 3's thin film (the diffuse part, eq. 18) with a fine noise thickness: what is left of the
# noise at 4 spp once the film averages out is the silhouette's, which the constant-thickness
# control row measures.
PRESET = "fig3_thin_film"
MATERIAL = dict(thickness_mode="noise", d_min=0.0, d_max=1000.0, noise_scale=40.0, noise_detail=2.0)
BAND_ONLY = "analytic, band only"


def variants():
    """(label, params, plan) of each measured variant."""
    from layered_brdf_addon.model import preset
    from layered_brdf_addon.model.policy import plan_effects

    p = preset(PRESET).replace(accuracy="analytic", **MATERIAL)
    plan = plan_effects(p)  # baked tables (the default Evaluation)
    computed = p.replace(evaluation="arithmetic")
    rgb = p.replace(accuracy="rgb")
    flat = p.replace(d_min=500.0, d_max=500.0)
    return [("analytic, band and pixel footprint", p, plan),
            ("analytic, band and pixel footprint, computed closures", computed, plan_effects(computed)),
            (BAND_ONLY, p, replace(plan, footprint=False)),
            ("RGB (the paper's three wavelengths)", rgb, plan_effects(rgb)),
            ("control: constant 500 nm (the silhouette's noise)", flat, plan_effects(flat))]


def render(scene, samples: int, seed: int) -> np.ndarray:
    import bpy

    c = bpy.context.scene.cycles
    c.samples, c.seed = samples, seed
    with tempfile.TemporaryDirectory(prefix="layered_brdf_alias_") as tmp:
        path = Path(tmp) / "r.exr"
        scene.render_to_exr(path)
        return scene.passes_from_exr(path).beauty[..., :3].astype(float)


def measure(label, params, plan, threads: int) -> dict:
    from layered_brdf_addon.blender import scene
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.model.sphere import Sun

    scene.reset_blender()
    sun = Sun(direction=(0.0, -np.cos(np.radians(40.0)), np.sin(np.radians(40.0))), strength=3.0)
    spheres = scene.build_scene(scene.SceneSpec(camera=scene.camera_for(1, HEIGHT), sun=sun, osl=True, threads=threads))
    import bpy

    bpy.context.scene.cycles.filter_width = FILTER_WIDTH
    apply_layered_material(spheres[0], params, "osl", plan=plan, name="Aliasing")
    t0 = time.process_time()
    reference = render(scene, REFERENCE_SPP, 0)
    low = np.stack([render(scene, LOW_SPP, s) for s in SEEDS])
    return dict(label=label, plan=plan.key, reference=reference, low=low, cpu_seconds=time.process_time() - t0)


def summarise(runs: list[dict]) -> list[dict]:
    truth = next(r["reference"] for r in runs if r["label"] == BAND_ONLY)
    mask = truth.sum(axis=-1) > 1e-4
    rows = []
    for r in runs:
        low, ref = r["low"][:, mask], r["reference"][mask]
        rows.append(dict(label=r["label"], plan=r["plan"], pixels=int(mask.sum()),
                         noise_variance=float(low.var(axis=0, ddof=1).sum(axis=-1).mean()),
                         rms_to_own_reference=float(np.sqrt(((low - ref) ** 2).sum(axis=-1).mean())),
                         rms_to_band_only_reference=float(np.sqrt(((low - truth[mask]) ** 2).sum(axis=-1).mean())),
                         reference_shift=float(np.sqrt(((ref - truth[mask]) ** 2).sum(axis=-1).mean())),
                         mean_level=float(ref.sum(axis=-1).mean()), cpu_seconds=r["cpu_seconds"]))
    return rows


def markdown(rows: list[dict]) -> str:
    out = ["| variant | noise (variance per pixel, 4 spp) | RMS to its 1,024-spp image | RMS to the band-only "
           "1,024-spp image | its 1,024-spp image vs band-only | mean pixel (sum of RGB) |",
           "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        out.append(f"| {r['label']} | {r['noise_variance']:.3g} | {r['rms_to_own_reference']:.3g} | "
                   f"{r['rms_to_band_only_reference']:.3g} | {r['reference_shift']:.3g} | {r['mean_level']:.3g} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    runs = [measure(label, p, plan, args.threads) for label, p, plan in variants()]
    rows = summarise(runs)
    table = markdown(rows)
    print(table)
    data = dict(settings=dict(height=HEIGHT, filter_width=FILTER_WIDTH, low_spp=LOW_SPP,
                              reference_spp=REFERENCE_SPP, seeds=list(SEEDS), material=MATERIAL),
                rows=rows, seconds=time.perf_counter() - t0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".partial")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, args.out)
    print(f"wrote {args.out} in {data['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
