"""CIEDE2000 of the physical optics' smooth-film colour against tmm, per case, angle and mode.

For every film of :data:`~layered_brdf_reference.film_colours.CASES` and view angle of
``ANGLES_DEG``: the mean and max over thickness of the CIEDE2000 difference between the
model's mirror reflection (physical optics, accuracy modes "analytic" and "rgb") and tmm's
reflectance spectrum seen under D65, with the paper optics' mean beside it.  Prints an
aligned table, or a markdown one with ``--markdown``.
"""
from __future__ import annotations

import argparse

from layered_brdf_reference.film_colours import ACCURACIES, ANGLES_DEG, CASES, film_errors, reference_film_lab

HEADER = ("case", "angle") + tuple(f"physical {a} {s}" for a in ACCURACIES for s in ("mean", "max")) \
    + tuple(f"paper {a} mean" for a in ACCURACIES)


def measure(step_nm: float) -> list[tuple]:
    """One row per case and angle: the columns of :data:`HEADER`."""
    rows = []
    for case in CASES:
        d = case.thicknesses(step_nm=step_nm)
        for theta in ANGLES_DEG:
            ref = reference_film_lab(case.film, case.below, d, theta)
            physical = [film_errors(case.film, case.below, d, theta, "physical", a, ref) for a in ACCURACIES]
            paper = [film_errors(case.film, case.below, d, theta, "paper", a, ref) for a in ACCURACIES]
            rows.append((case.name, f"{theta:g}°") + tuple(f"{v:.2f}" for e in physical for v in (e.mean(), e.max()))
                        + tuple(f"{e.mean():.1f}" for e in paper))
    return rows


def markdown(rows: list[tuple]) -> str:
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "|".join(["---"] * 2 + ["---:"] * (len(HEADER) - 2)) + "|"]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def plain(rows: list[tuple]) -> str:
    widths = [max(len(str(r[i])) for r in rows + [HEADER]) for i in range(len(HEADER))]
    return "\n".join("  ".join(str(c).ljust(w) if i < 2 else str(c).rjust(w) for i, (c, w) in
                               enumerate(zip(r, widths))) for r in [HEADER] + rows)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true", help="print a markdown table")
    ap.add_argument("--step", type=float, default=2.0, help="thickness step in nm (default 2)")
    args = ap.parse_args(argv)
    rows = measure(args.step)
    print(f"Thickness every {args.step:g} nm; CIEDE2000 against tmm (380-780 nm every 5 nm, D65, CIE 1931).")
    print(markdown(rows) if args.markdown else plain(rows))


if __name__ == "__main__":
    main()
