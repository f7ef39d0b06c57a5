"""Closure form vs its exact model under Blender's bundled HDRIs: the relative L1 per preset
(Monte Carlo over the environment, the same light directions for both; thickness by height).

    python benchmarks/closure_vs_exact_hdri.py [--markdown] [HDRI ...]
"""
from __future__ import annotations

import argparse

from layered_brdf_addon.model.presets import PRESETS, preset
from layered_brdf_reference.hdri_accuracy import closure_error
from report import table  # benchmarks/ is on sys.path when the script runs

HDRIS = ("forest", "courtyard", "interior")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("hdris", nargs="*", default=list(HDRIS))
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    head = ["preset", "optics"] + [f"L1 {h}" for h in args.hdris]
    rows = []
    for name in PRESETS:
        p = preset(name)
        rows.append([name, p.optics] + [f"{100 * closure_error(p, h)['l1']:.1f}%" for h in args.hdris])
    print(table(head, rows, args.markdown))


if __name__ == "__main__":
    main()
