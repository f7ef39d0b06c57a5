"""Tables for a tilted lower boundary, sliced by the lower normal's azimuth from the view's plane
(model/shading/tables.py): the closures read from them against those the program computes (numpy,
20,000 random points, lights about the mirror direction, the lower normal at random azimuths), for
several numbers of slices, past the tables' budget too (docs/tables.md#a-tilted-boundary).

    python benchmarks/tilted_tables.py [PRESET ...]
"""
from __future__ import annotations

import sys
import time
from dataclasses import replace

import numpy as np

import layered_brdf_addon.model.table_bake as table_bake
from layered_brdf_addon.fit.cycles_closures import evaluate_closures
from layered_brdf_addon.model import preset, program
from layered_brdf_addon.model.ops_numpy import vec
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.sphere import shading_point

sys.path.insert(0, "tests")
from test_tables import _lower_normals, _points  # noqa: E402


def measure(name, p, seed=1):
    rng = np.random.default_rng(seed)
    plan = replace(plan_effects(p), tables=True)
    t0 = time.perf_counter()
    layout, texels = table_bake.bake(p, plan)
    baked = time.perf_counter() - t0
    n0, v, l, d = _points(p, rng)
    axes, n1 = _lower_normals(p, rng, len(d))
    pt = shading_point(p, n0, np.zeros_like(n0), view=v)
    computed = program.layered_surface(pt, replace(plan, tables=False), thickness=d, lower=vec(n1), axis=vec(axes))
    tabulated = table_bake.tabulated_result(p, plan, layout, texels, n0, v, d, axes)
    a, b = evaluate_closures(computed, n0, v, l), evaluate_closures(tabulated, n0, v, l)
    l1 = np.abs(a - b).sum() / np.abs(a).sum()
    failing = np.mean(np.abs(a - b).max(axis=-1) > 0.02 * np.maximum(a.max(axis=-1), 1e-3 * a.max()))
    print(f"| {name} | {layout.azimuths} | {100 * l1:.2f}% | {100 * failing:.1f}% | {1000 * baked:.0f} | "
          f"{texels.nbytes / 1024:.0f} |")


def main():
    table_bake.MAX_TABLE_BYTES = 1 << 28  # measure past the budget (the planner holds to 1 MB)
    print("| preset | azimuth slices | L1 | points off by > 2% | bake (ms) | tables (kB) |\n|---|---|---|---|---|---|")
    for name in sys.argv[1:] or ["fig4_tilted", "fig6_thin", "fig6_medium"]:
        for slices in (9, 17, 25, 33):
            table_bake.AZIMUTH_SAMPLES = slices
            measure(name, preset(name))


if __name__ == "__main__":
    main()
