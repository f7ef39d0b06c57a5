"""Directional albedo of the exact model per preset: where and by how much it exceeds 1.

The white-furnace value of a surface point seen from ``v`` is the integral of
``f(l, v) <n0, l>`` over the hemisphere (Monte Carlo, see layered_brdf_reference/lighting.py).  The
interference term adds up to ``2 sqrt(R T)`` and the paper's model does not conserve
energy: this prints the largest albedo over thickness and view angle.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from layered_brdf_addon.model import PRESETS, preset
from layered_brdf_reference.lighting import environment_shading


def albedo_table(names, samples=4096, thicknesses=24, angles=(0.0, 30.0, 60.0)):
    rows = []
    n = np.array([[0.0, 0.0, 1.0]])
    for name in names:
        p = preset(name)
        best = (-1.0, None)
        for d in np.linspace(p.d_min, p.d_max, thicknesses if p.d_max > p.d_min else 1):
            for a in angles:
                v = np.array([np.sin(np.radians(a)), 0.0, np.cos(np.radians(a))])
                alb = environment_shading(p, n, n, np.array([d]), v, samples=samples, seed=1)[0]
                if alb.max() > best[0]:
                    best = (alb.max(), dict(d=float(d), view_deg=a, albedo=alb.round(4).tolist()))
        rows.append(dict(preset=name, max_albedo=round(float(best[0]), 4), **best[1]))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--samples", type=int, default=4096)
    args = ap.parse_args(argv)
    rows = albedo_table(sorted(PRESETS), args.samples)
    out = Path(__file__).resolve().parent / "results" / "energy.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(rows, indent=1))
    print("| preset | largest albedo | channel albedos (R, G, B) | at d (nm) | view angle |")
    print("|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['preset']} | {r['max_albedo']:.3f} | {r['albedo']} | {r['d']:.0f} | {r['view_deg']:.0f} |")


if __name__ == "__main__":
    main()
