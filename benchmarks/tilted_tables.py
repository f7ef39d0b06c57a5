"""Tables for a tilted lower boundary, sliced by the lower normal's azimuth from the view's plane
(model/shading/tables.py): the closures read from them against those the program computes (numpy,
20,000 of the tables' check's random probes, model/table_check.py: L1 of the light about the mirror
direction, highlights off by more than 2%), for several numbers of slices, past the tables' budget too
(docs/tables.md#a-tilted-boundary).

    python benchmarks/tilted_tables.py [PRESET ...]
"""
from __future__ import annotations

import sys
import time
from dataclasses import replace

import layered_brdf_addon.model.table_bake as table_bake
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.table_check import check_tables


def measure(name, p, seed=1):
    plan = replace(plan_effects(p), tables=True)
    t0 = time.perf_counter()
    layout, texels = table_bake.bake(p, plan)
    baked = time.perf_counter() - t0
    check = check_tables(p, plan, layout, texels, points=20000, seed=seed)
    print(f"| {name} | {layout.azimuths} | {100 * check.l1:.2f}% | {100 * check.failing:.1f}% | {1000 * baked:.0f} | "
          f"{texels.nbytes / 1024:.0f} |")


def main():
    table_bake.MAX_TABLE_BYTES = 1 << 28  # measure past the budget (the planner holds to 1 MB)
    print("| preset | azimuth slices | L1 | highlights off by > 2% | bake (ms) | tables (kB) |\n"
          "|---|---|---|---|---|---|")
    for name in sys.argv[1:] or ["fig4_tilted", "fig6_thin", "fig6_medium"]:
        for slices in (9, 17, 25, 33):
            table_bake.AZIMUTH_SAMPLES = slices
            measure(name, preset(name))


if __name__ == "__main__":
    main()
