"""The best one film against each structural preset's stack: what a stack adds.

For every structural preset, the stack's mirror reflectance spectrum at 0, 30 and 60 degrees (its disorder
averaged over the model's draws) is written as a reflectance table and fitted by ``layered-brdf fit
--reflectance`` with no start (the fit chooses among its films' structures: every film preset's, with each
lower medium and boundary); the table prints the closest single film's mean CIEDE2000 from the stack and
what that film is.  ``--sheets DIR`` keeps each fit's figure (target, fit, curves).  Tilted lamellae
(labradorite) reflect inside their crystal, away from its top's mirror direction: their closest one film is
the crystal's with one lamella, its index (1.3-2.5) and thickness (20-600 nm) the scan's nearest to the
lamellae's colours at those angles inside the crystal (:func:`closest_lamella`).
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
from layered_brdf_addon.model.stack_optics import StackResponse, disorder_draws, lower_index, stack_spectra
from layered_brdf_reference.spectral import delta_e_2000 as rgb_delta_e

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


LAMELLA_IORS = np.arange(1.30, 2.501, 0.02)
LAMELLA_NM = np.arange(20.0, 601.0, 2.0)


def closest_lamella(name: str):
    """``(params, record)``: tilted lamellae's preset with its stack replaced by the one lamella whose colours at
    ANGLES inside the crystal are nearest the stack's (mean CIEDE2000, ``record["mean_delta_e_2000"]``); its
    thickness range the preset's relative spread about the lamella's thickness."""
    p = preset(name)
    cos = np.cos(np.radians(ANGLES))[:, None]
    target = StackResponse.of(p).colour(cos, p.stack.total_nm)[0][:, 0]  # (angles, 3)
    best = (np.inf, None, None)
    for ior in LAMELLA_IORS:
        one = p.replace(stack={"kind": "list", "films": [{"ior": round(float(ior), 3), "thickness_nm": 100.0}]})
        R = StackResponse.of(one).colour(cos, LAMELLA_NM[None, :])[0]  # (angles, thicknesses, 3)
        errors = np.mean([rgb_delta_e(R[a], np.broadcast_to(target[a], R[a].shape)) for a in range(len(ANGLES))],
                         axis=0)
        k = int(np.argmin(errors))
        if errors[k] < best[0]:
            best = (float(errors[k]), round(float(ior), 3), float(LAMELLA_NM[k]))
    error, ior, nm = best
    middle = 0.5 * (p.d_min + p.d_max)
    film = p.replace(stack={"kind": "list", "films": [{"ior": ior, "thickness_nm": nm}]},
                     d_min=round(nm * p.d_min / middle, 1), d_max=round(nm * p.d_max / middle, 1))
    return film, {"mean_delta_e_2000": error, "lamella_ior": ior, "lamella_nm": nm}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sheets", type=Path, help="a folder for each fit's figure")
    args = ap.parse_args(argv)
    print("| stack | closest one film | mean CIEDE2000 |")
    print("|---|---|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in STACK_PRESETS:
            if preset(name).normal_mode == "tilted":
                _, fit = closest_lamella(name)
                print(f"| {name} | one lamella in the crystal, n {fit['lamella_ior']:.2f}, {fit['lamella_nm']:.0f} nm | "
                      f"{fit['mean_delta_e_2000']:.2f} |")
                continue
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
