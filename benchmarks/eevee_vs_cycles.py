"""The look-dev shader ball in Cycles and in EEVEE, side by side, with their CIEDE2000.

Principled BSDF's Thin Film renders in Cycles only; the layered node group renders in
EEVEE too.  For each preset: the look-dev scene (layered_brdf_addon/blender/lookdev.py)
rendered by Cycles and by EEVEE (tests/eevee_lookdev.py, in a subprocess: EEVEE needs
EGL), both encoded by Blender with AgX; the mean and 95th percentile CIEDE2000 over the
ball's pixels; and, for scale, the same numbers between two Cycles renders that differ
only in their seed (Cycles' own noise at these samples).  The presets read their baked
tables where they can (the default Evaluation); each is also rendered computing its closures
(Evaluation 'arithmetic'): the CIEDE2000 between the two per engine (EEVEE reads the tables'
Image Textures with mipmaps and filtering, Cycles point by point), and that of EEVEE computing
against Cycles.

Writes docs/images/eevee-vs-cycles.png and a .json next to it (numbers and timings).
A few minutes on two cores: ``.venv-5.2/bin/python benchmarks/eevee_vs_cycles.py``.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

OUT = ROOT / "docs" / "images" / "eevee-vs-cycles.png"
PRESETS = ("oil_slick", "beetle_shell", "anodised_titanium", "old_metal", "glazed_clay", "soap_bubble",
           "fig4_tilted", "fig6_medium")
SIZE = 128
CYCLES_SAMPLES = 64
EEVEE_SAMPLES = 32
PAIRS_PER_ROW = 4


def main(argv=None) -> int:
    import eevee_lookdev

    from layered_brdf_addon.cli.gallery import compose_sheet, layout_for
    from layered_brdf_addon.io.codecs import save_png
    from layered_brdf_addon.cli.lookdev import check_sheet_output
    from layered_brdf_addon.io.sidecar import write_json
    from layered_brdf_addon.io.staging import StagedOutputs
    from layered_brdf_addon.model.presets import preset_label

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--output", default=str(OUT))
    ap.add_argument("--size", type=int, default=SIZE)
    ap.add_argument("--cycles-samples", type=int, default=CYCLES_SAMPLES)
    ap.add_argument("--eevee-samples", type=int, default=EEVEE_SAMPLES)
    ap.add_argument("--presets", nargs="+", default=list(PRESETS))
    args = ap.parse_args(argv)
    output = check_sheet_output(args.output)

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        r = eevee_lookdev.run(Path(tmp) / "r.npz", args.size, args.cycles_samples, args.eevee_samples, args.presets,
                              3600)
        # Cycles' own noise: the same renders with another seed
        noise = eevee_lookdev.run(Path(tmp) / "n.npz", args.size, args.cycles_samples, 0, args.presets, 3600, seed=1)
        computed = eevee_lookdev.run(Path(tmp) / "a.npz", args.size, args.cycles_samples, args.eevee_samples,
                                     args.presets, 3600, evaluation="arithmetic")
    rows, tiles, labels = [], [], []
    for name in args.presets:
        c, e, m = r[f"{name}/cycles"], r[f"{name}/eevee"], r[f"{name}/mask"]
        de = eevee_lookdev.delta_e2000(c, e, m)
        dn = eevee_lookdev.delta_e2000(c, noise[f"{name}/cycles"], m)
        rows.append({"name": name, "mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
                     "cycles_noise_mean": float(dn.mean()), "cycles_noise_p95": float(np.percentile(dn, 95)),
                     "pixels": int(m.sum()), "cycles_seconds": float(r[f"{name}/cycles_seconds"]),
                     "eevee_seconds": float(r[f"{name}/eevee_seconds"]),
                     "eevee_failed_pixels": int(r[f"{name}/eevee_failed"][m].sum())})
        for engine in ("cycles", "eevee"):  # tables against computed closures, in the same engine
            dt = eevee_lookdev.delta_e2000(r[f"{name}/{engine}"], computed[f"{name}/{engine}"], m)
            rows[-1][f"{engine}_tables_vs_computed_mean"] = float(dt.mean())
            rows[-1][f"{engine}_tables_vs_computed_p95"] = float(np.percentile(dt, 95))
        dc = eevee_lookdev.delta_e2000(c, computed[f"{name}/eevee"], m)  # EEVEE computing, against Cycles
        rows[-1]["computed_mean"], rows[-1]["computed_p95"] = float(dc.mean()), float(np.percentile(dc, 95))
        tiles += [c, e]
        labels += [[preset_label(name), f"Cycles {args.cycles_samples} spp",
                    f"{rows[-1]['cycles_seconds']:.1f} s"],
                   ["EEVEE", f"\u0394E00 mean {rows[-1]['mean']:.1f}, p95 {rows[-1]['p95']:.1f}",
                    f"{rows[-1]['eevee_seconds']:.1f} s"]]
    title = (f"look-dev ball: Cycles | EEVEE ({r['eevee_engine']}, {args.eevee_samples} samples, software GL) "
             f"\u00b7 {r['view_transform']}")
    layout = layout_for(labels, args.size, 2 * PAIRS_PER_ROW, title)
    grid = np.zeros((layout.rows * args.size, layout.columns * args.size, 3), np.uint8)
    for k, t in enumerate(tiles):
        x0, y0, x1, y1 = layout.render_box(k)
        grid[y0:y1, x0:x1] = t[..., :3]
    pixels = np.asarray(compose_sheet(grid, layout, labels, title))
    data = {"title": title, "size": args.size, "cycles_samples": args.cycles_samples,
            "eevee_samples": args.eevee_samples, "eevee_engine": str(r["eevee_engine"]),
            "view_transform": str(r["view_transform"]), "presets": rows, "seconds": time.perf_counter() - t0}
    sidecar = output.with_suffix(".json")
    with StagedOutputs([output, sidecar]) as staged:
        save_png(staged.temp(output), pixels)
        write_json(staged.temp(sidecar), data)
    print(f"{'preset':18s} {'mean':>6s} {'p95':>6s} {'noise mean':>10s} {'noise p95':>9s} {'Cycles s':>9s} "
          f"{'EEVEE s':>8s}  EEVEE computing: mean / p95; tables vs computed, mean / p95: Cycles, EEVEE")
    for row in rows:
        print(f"{row['name']:18s} {row['mean']:6.2f} {row['p95']:6.2f} {row['cycles_noise_mean']:10.2f} "
              f"{row['cycles_noise_p95']:9.2f} {row['cycles_seconds']:9.1f} {row['eevee_seconds']:8.1f}  "
              f"{row['computed_mean']:.2f} / {row['computed_p95']:.2f}; "
              f"{row['cycles_tables_vs_computed_mean']:.2f} / {row['cycles_tables_vs_computed_p95']:.2f}, "
              f"{row['eevee_tables_vs_computed_mean']:.2f} / {row['eevee_tables_vs_computed_p95']:.2f}")
    print(f"wrote {output}, {sidecar}; {data['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
