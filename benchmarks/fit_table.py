"""What a fit finds and what it costs: held-out materials on the reference sphere and
thin-film optics tables (tmm), each fitted from a preset by ``layered_brdf_addon.fit``, and
generated materials of every structure fitted with no start (the fit chooses the structure:
``fit/structures.py``).

Prints, per case: the start (or the structure chosen), the free parameters, the mean CIEDE2000
over the sampled pixels (or table rows) and over every pixel of the sphere, the model
evaluations, the seconds (process CPU time and wall time, one thread) and the key parameters
found against the truth (or the truth's structure).  ``--markdown`` for docs/fitting.md;
``--selection`` for the generated targets alone.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from layered_brdf_addon.fit.solve import fit  # noqa: E402
from layered_brdf_addon.fit.structures import select_and_fit, structure_pool  # noqa: E402
from layered_brdf_addon.fit.targets import ReflectanceTarget, SphereTarget  # noqa: E402
from layered_brdf_addon.model.presets import preset  # noqa: E402
from layered_brdf_reference.fit_cases import (FILMS, SUNS, generated_targets, held_out, image_delta_e,  # noqa: E402
                                              tmm_rows, views_of)
from report import table  # noqa: E402  (benchmarks/ is on sys.path when the script runs)

HEADER = ("case", "start", "free", "ΔE00 fitted", "ΔE00 image", "evaluations", "CPU s", "wall s", "found (truth)")


def _timed(target, start):
    c0, w0 = time.process_time(), time.perf_counter()
    result = fit(target, start)
    return result, time.process_time() - c0, time.perf_counter() - w0


def sphere_rows() -> list[tuple]:
    rows = []
    cases = [(name, truth, start, 1) for name, (truth, start) in held_out().items()]
    truth, start = held_out()["oil_milky"]
    cases.append(("oil_milky, two suns", truth, start, 2))
    for name, truth, start, suns in cases:
        target = SphereTarget(views_of(truth, SUNS[:suns]))
        r, cpu, wall = _timed(target, preset(start).replace(thickness_mode=truth.thickness_mode))
        found = f"d {r.params.d_min:.0f}-{r.params.d_max:.0f} ({truth.d_min:.0f}-{truth.d_max:.0f}), " \
                f"e0 {r.params.e0:.0f} ({truth.e0:.0f})"
        rows.append((name, start, len(r.vary), f"{r.mean_delta_e:.2f}", f"{image_delta_e(target, r.params):.2f}",
                     r.evaluations, f"{cpu:.1f}", f"{wall:.1f}", found))
    return rows


def _modes(p) -> str:
    medium = f" {p.lower_medium}" if p.optics == "physical" else ""
    return f"{p.optics}{medium} {p.normal_mode} {p.base_layer}" + (" kd" if p.kd > 0 else "")


def selection_rows() -> list[tuple]:
    """Generated targets (no preset's values) fitted with no start: the structure chosen among every
    candidate, and the image's CIEDE2000 (every pixel of the sphere) against the fit's own figure."""
    rows, pool = [], structure_pool()
    for name, truth in generated_targets().items():
        target = SphereTarget(views_of(truth))
        c0, w0 = time.process_time(), time.perf_counter()
        s = select_and_fit(target, pool)
        cpu, wall = time.process_time() - c0, time.perf_counter() - w0
        rows.append((name, f"chosen: {_modes(s.result.params)}", len(s.result.vary), f"{s.result.mean_delta_e:.2f}",
                     f"{image_delta_e(target, s.result.params):.2f}", s.result.evaluations, f"{cpu:.1f}", f"{wall:.1f}",
                     f"truth: {_modes(truth)}"))
        print(*rows[-1], sep=" | ", flush=True)
    return rows


def table_rows() -> list[tuple]:
    rows = []
    for film, below, thickness, start in FILMS:
        r, cpu, wall = _timed(ReflectanceTarget.from_rows(tmm_rows(film, below, thickness)), preset(start))
        n = sum(r.params.r1) / 3
        rows.append((f"tmm {film} on {below}, {thickness:g} nm", start, len(r.vary), f"{r.mean_delta_e:.2f}", "",
                     r.evaluations, f"{cpu:.1f}", f"{wall:.1f}", f"n d {n * r.params.d_min:.0f} nm, n {n:.2f}"))
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--selection", action="store_true", help="the generated targets fitted with no start only")
    args = ap.parse_args(argv)
    rows = selection_rows() if args.selection else sphere_rows() + table_rows() + selection_rows()
    print(table(HEADER, rows, args.markdown))


if __name__ == "__main__":
    main()
