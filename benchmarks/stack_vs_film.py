"""The best one film against each structural preset's stack: what a stack adds.

For every structural preset, the stack's mirror reflectance spectrum at 0, 30 and 60 degrees (its disorder
averaged over the model's draws) is written as a reflectance table and fitted by ``layered-brdf fit
--reflectance`` with no start (the fit chooses among its films' structures: every film preset's, with each
lower medium and boundary); the table prints the closest single film's mean CIEDE2000 from the stack and
what that film is.  ``--sheets DIR`` keeps each fit's figure (target, fit, curves).
"""
from __future__ import annotations

import argparse
import csv
import json
import tempfile
from pathlib import Path

import numpy as np

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.model.presets import STACK_PRESETS, preset
from layered_brdf_addon.model.stack_optics import disorder_draws, lower_index, stack_spectra

ANGLES = (0.0, 30.0, 60.0)
WAVES = np.arange(380.0, 781.0, 5.0)


def write_table(name: str, path: Path) -> None:
    """The preset's stack at scale 1: its reflectance per angle and wavelength (disorder averaged)."""
    p = preset(name)
    lower = lower_index(p.r2, p.k2, WAVES, p.lower_medium)
    draws = list(disorder_draws(p.stack)) if p.stack.disorder else [None]
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["angle_deg", "wavelength_nm", "reflectance"])
        for angle in ANGLES:
            cos = np.array([np.cos(np.radians(angle))])
            R = np.mean([stack_spectra(p.stack, float(p.r0), lower, cos, np.array([1.0]), WAVES, draw)[0][0]
                         for draw in draws], axis=0)
            out.writerows([angle, lam, f"{r:.6f}"] for lam, r in zip(WAVES, R))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sheets", type=Path, help="a folder for each fit's figure")
    args = ap.parse_args(argv)
    print("| stack | closest one film | mean CIEDE2000 |")
    print("|---|---|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in STACK_PRESETS:
            table = Path(tmp) / f"{name}.csv"
            write_table(name, table)
            stem = (args.sheets or Path(tmp)) / f"stack-vs-film-{name.replace('_', '-')}"
            cli.main(["fit", "--reflectance", str(table), "--layer", "film", "--output", str(stem), "--no-progress"])
            record = json.loads(stem.with_suffix(".json").read_text())
            p, fit = record["params"], record["fit"]
            film = (f"{p['optics']} optics, n {p['r1_r']:.2f}/{p['r1_g']:.2f}/{p['r1_b']:.2f}, {p['d_min']:.0f} nm over "
                    f"{p['lower_medium'] if p['lower_medium'] != 'custom' else 'a custom medium'}")
            print(f"| {name} | {film} | {fit['mean_delta_e_2000']:.2f} |")


if __name__ == "__main__":
    main()
