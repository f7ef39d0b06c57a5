"""What a fit finds and what it costs: held-out materials on the reference sphere and
thin-film optics tables (tmm), each fitted from a preset by ``layered_brdf_addon.fit``.

Prints, per case: the start, the free parameters, the mean CIEDE2000 over the sampled
pixels (or table rows) and over every pixel of the sphere, the model evaluations, the
seconds (process CPU time and wall time, one thread) and the key parameters found against
the truth.  ``--markdown`` for docs/fitting.md.
"""
from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from layered_brdf_addon.fit.solve import fit  # noqa: E402
from layered_brdf_addon.fit.targets import ReflectanceTarget, SphereTarget  # noqa: E402
from layered_brdf_addon.model.presets import preset  # noqa: E402
from layered_brdf_reference.fit_cases import FILMS, SUNS, held_out, image_delta_e, tmm_rows, views_of  # noqa: E402
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
    args = ap.parse_args(argv)
    print(table(HEADER, sphere_rows() + table_rows(), args.markdown))


if __name__ == "__main__":
    main()
