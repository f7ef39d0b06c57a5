"""What fitting the baked tables to the exact model buys: the closure form vs its exact model
under Blender's bundled HDRIs (layered_brdf_reference.hdri_accuracy: Monte Carlo over the
environment, the same light directions for both, thickness by height), for the closures as the
program computes them, as the tables hold them (moment matched), and with each texel's weights
fitted to the exact model (layered_brdf_reference.fitted_tables).  The artist presets and a sharp
film of high index on a metal (titanium-like: parallel, 60 nm, exponents 800).

    python benchmarks/fitted_tables.py [--markdown] [HDRI ...]
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace

from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.presets import ARTIST_PRESETS, preset
from layered_brdf_reference.fitted_tables import fit_tables, table_shading
from layered_brdf_reference.hdri_accuracy import closure_error
from report import table  # benchmarks/ is on sys.path when the script runs

HDRIS = ("forest", "courtyard", "interior")


def cases() -> dict:
    out = {name: preset(name) for name in ARTIST_PRESETS}
    out["sharp titanium film"] = preset("anodised_titanium").replace(d_min=60.0, d_max=60.0, e0=800.0, e1=800.0)
    out["sharp titanium film, paper optics"] = out["sharp titanium film"].replace(optics="paper", accuracy="rgb")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("hdris", nargs="*", default=list(HDRIS))
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    head = ["case", "optics", "fit (s): weights / with widths"] + \
        [f"L1 {h}: computed / tables / fitted weights / with widths" for h in args.hdris]
    rows = []
    for name, p in cases().items():
        p = p.replace(thickness_mode="height")  # what the HDRI measurement renders
        plan = replace(plan_effects(p), tables=True)
        seconds, fits = [], []
        for widths in (False, True):
            t = time.perf_counter()
            layout, texels, fitted = fit_tables(p, plan, fit_widths=widths)
            seconds.append(time.perf_counter() - t)
            fits.append(fitted)
        cells = []
        for h in args.hdris:
            shadings = [None, texels, *fits]
            errors = [closure_error(p, h, **({} if x is None else {"shading": table_shading(plan, layout, x)}))["l1"]
                      for x in shadings]
            cells.append(" / ".join(f"{100 * e:.1f}%" for e in errors))
        rows.append([name, p.optics, " / ".join(f"{x:.1f}" for x in seconds)] + cells)
        print(rows[-1], flush=True)
    print(table(head, rows, args.markdown))


if __name__ == "__main__":
    main()
