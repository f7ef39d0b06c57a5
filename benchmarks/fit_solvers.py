"""The fit's own solver and colour maths (numpy alone, ``fit/least_squares.py`` and
``fit/colour_space.py``) against SciPy's ``least_squares`` (trust region reflective, soft-L1)
with colour-science's CIEDE2000, on the same fits: what carrying no SciPy and no colour-science
in the extension costs in accuracy and time.

Per case and solver: the fitted mean CIEDE2000 (the fit's sample), the image's (every pixel of
the sphere; the tmm tables have none), the model evaluations and the process CPU seconds (one
thread).  Cases: the held-out sphere materials fitted from a preset, the thin-film optics tables
(tmm), and with ``--selection`` the generated targets fitted with no start (each screens every
structure, minutes per target).  ``--markdown`` for docs/fitting.md.
"""
from __future__ import annotations

import argparse
import os
import time
from contextlib import contextmanager
from unittest import mock

os.environ.setdefault("OMP_NUM_THREADS", "1")

import colour  # noqa: E402
from scipy.optimize import least_squares as scipy_least_squares  # noqa: E402

from layered_brdf_addon.fit import colour_space, solve  # noqa: E402
from layered_brdf_addon.fit.structures import select_and_fit, structure_pool  # noqa: E402
from layered_brdf_addon.fit.targets import ReflectanceTarget, SphereTarget  # noqa: E402
from layered_brdf_addon.model.presets import preset  # noqa: E402
from layered_brdf_reference.fit_cases import FILMS, generated_targets, held_out, image_delta_e, tmm_rows, views_of  # noqa: E402
from report import table  # noqa: E402  (benchmarks/ is on sys.path when the script runs)

HEADER = ("case", "solver", "ΔE00 fitted", "ΔE00 image", "evaluations", "CPU s")


def _scipy_solver(fun, x0, jac, bounds, *, f_scale, max_nfev):
    return scipy_least_squares(fun, x0, jac=jac, bounds=bounds, loss="soft_l1", f_scale=f_scale, x_scale=1.0,
                               max_nfev=max_nfev)


def _colour_science_delta_e(lab1, lab2):
    return colour.delta_E(lab1, lab2, method="CIE 2000")


@contextmanager
def _solver(name: str):
    if name == "numpy":
        yield
        return
    with mock.patch.object(solve, "least_squares", _scipy_solver), \
            mock.patch.object(colour_space, "delta_e_2000", _colour_science_delta_e):
        yield


SOLVERS = ("numpy", "scipy + colour-science")


def _cases(selection: bool):
    if selection:
        pool = structure_pool()
        for name, truth in generated_targets().items():
            target = SphereTarget(views_of(truth))
            yield f"{name} (no start)", target, lambda t=target: select_and_fit(t, pool).result, True
        return
    for name, (truth, start) in held_out().items():
        target = SphereTarget(views_of(truth))
        p = preset(start).replace(thickness_mode=truth.thickness_mode)
        yield f"{name} from {start}", target, lambda t=target, p=p: solve.fit(t, p), True
    for film, below, thickness, start in FILMS:
        target = ReflectanceTarget.from_rows(tmm_rows(film, below, thickness))
        yield f"tmm {film} on {below}, {thickness:g} nm", target, lambda t=target, s=start: solve.fit(t, preset(s)), \
            False


def rows(selection: bool = False) -> list[tuple]:
    out = []
    for name, target, run, sphere in _cases(selection):
        for solver in SOLVERS:
            with _solver(solver):
                c0 = time.process_time()
                result = run()
                cpu = time.process_time() - c0
                image = f"{image_delta_e(target, result.params):.2f}" if sphere else ""
            out.append((name, solver, f"{result.mean_delta_e:.2f}", image, result.evaluations, f"{cpu:.1f}"))
            print(*out[-1], sep=" | ", flush=True)
    return out


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--selection", action="store_true", help="the generated targets fitted with no start")
    args = ap.parse_args(argv)
    print(table(HEADER, rows(args.selection), args.markdown))


if __name__ == "__main__":
    main()
