"""Film stacks: their colour against tmm, what their tables cost to bake and how well they hold.

For every structural preset and for random stacks (2-64 films, dielectric and absorbing), at 0, 30 and 60
degrees: the CIEDE2000 between the add-on's colour of the stack's mirror reflection (analytic mode and the
paper's RGB) and tmm's spectrum at 1 nm seen under D65 (layered_brdf_reference/stack_colours.py); then per
preset and per stack size, the bake's CPU time (the process's, every thread's: a bake's points are split
over the cores) and wall time (medians of ``--repeats``), its rows and bytes, and the tables' check against the stack computed per point (model/table_check.py: the light's L1, the share of
highlights off by more than 2%, what passes to the base); then, per disordered stack, how far the model's
8 draws (stratified), 8 independent ones and the partially coherent sums are from the average of 1024.
Prints aligned tables, markdown with ``--markdown``.
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model import stack_optics as so
from layered_brdf_addon.model.partial_coherence import DEEP_MODES, deep_start, stack_colour_partial
from layered_brdf_addon.model.presets import STACK_PRESETS, preset
from layered_brdf_addon.model.table_bake import bake
from layered_brdf_addon.model.table_check import check_tables
from layered_brdf_reference.spectral import delta_e_2000 as rgb_delta_e
from layered_brdf_reference.stack_colours import stack_error

ANGLES = (0.0, 30.0, 60.0)


def random_stack(seed: int, absorbing: bool) -> LayeredParams:
    """A random stack of 2-64 films (IOR 1.3-2.5; absorbing: k up to 2 in a third of them), 20-250 nm each."""
    rng = np.random.default_rng(seed)
    films = [{"ior": round(float(rng.uniform(1.3, 2.5)), 3), "thickness_nm": round(float(rng.uniform(20, 250)), 1),
              **({"k": round(float(rng.uniform(0, 2)), 3)} if absorbing and rng.random() < 1 / 3 else {})}
             for _ in range(int(rng.integers(2, 65)))]
    total = sum(f["thickness_nm"] for f in films)
    return LayeredParams.from_dict(dict(optics="physical", stack={"kind": "list", "films": films},
                                        lower_medium="glass", d_min=total * 0.95, d_max=total * 1.05))


def colour_rows(randoms: int) -> list[tuple]:
    cases = [(name, preset(name)) for name in STACK_PRESETS]
    cases += [(f"random {k} ({'absorbing' if k % 2 else 'dielectric'}, {p.stack.count} films)", p)
              for k, p in ((k, random_stack(k, bool(k % 2))) for k in range(randoms))]
    rows = []
    for name, p in cases:
        rows.append((name, *(f"{stack_error(p, a):.2f}" for a in ANGLES),
                     *(f"{stack_error(p, a, accuracy='rgb'):.1f}" for a in ANGLES)))
    return rows


COLOUR_HEADER = ("stack", *(f"analytic {a:g}°" for a in ANGLES), *(f"rgb {a:g}°" for a in ANGLES))


def _sized(films: int, disorder: float) -> LayeredParams:
    stack = {"films": [{"ior": 1.56, "thickness_nm": 90.0}, {"medium": "air", "thickness_nm": 97.5}],
             "periods": films // 2, "disorder": disorder}
    total = 187.5 * films / 2
    return LayeredParams.from_dict(dict(optics="physical", stack=stack, lower_medium="chitin", kd=0.0,
                                        d_min=total * 0.95, d_max=total * 1.05))


def bake_rows(repeats: int) -> list[tuple]:
    cases = [(name, preset(name)) for name in STACK_PRESETS]
    cases += [(f"Bragg {n} films{', disorder 5%' if dis else ''}", _sized(n, dis)) for n in (16, 64)
              for dis in (0.0, 0.05)]
    rows = []
    for name, p in cases:
        plan = plan_effects(p)
        times, walls = [], []
        for _ in range(repeats):
            t0, w0 = time.process_time(), time.perf_counter()
            layout, texels = bake(p, plan)
            times.append(time.process_time() - t0)
            walls.append(time.perf_counter() - w0)
        c = check_tables(p, plan, layout, texels)
        rows.append((name, str(p.stack.count), f"{statistics.median(times):.2f}", f"{statistics.median(walls):.2f}",
                     str(layout.height),
                     f"{texels.nbytes / 1024:.0f}", f"{100 * c.l1:.2f}%", f"{100 * c.failing:.1f}%", f"{c.base:.3f}"))
    return rows


DRAWS_REFERENCE = 1024


def _independent_draws(stack):
    """Independent normal draws (what the stratified ones replaced), for the table's comparison."""
    g = np.random.default_rng(so.DISORDER_SEED).standard_normal((so.DISORDER_DRAWS, stack.count))
    return np.maximum(1.0 + stack.disorder * g, 0.05)


def _mirror_colour(p, draws_fn, draws: int, partial: str = ""):
    """The stack's mirror colour at ANGLES, scale 1, as the optics give it, averaged over ``draws``
    (``partial``: the deeper films' light added as power, :mod:`layered_brdf_addon.model.partial_coherence`)."""
    kept = so.disorder_draws, so.DISORDER_DRAWS
    so.disorder_draws, so.DISORDER_DRAWS = draws_fn, draws
    try:
        r = so.StackResponse.of(p)
        cosines, scales = np.cos(np.radians(ANGLES)), np.ones(len(ANGLES))
        if partial:
            return stack_colour_partial(p.stack, r.n0, r.lower_rgb, cosines, scales, partial,
                                        lower_medium=p.lower_medium)[0]
        return so.stack_colour(p.stack, r.n0, r.lower_rgb, cosines, scales, "analytic", p.lower_medium, gamut=False)[0]
    finally:
        so.disorder_draws, so.DISORDER_DRAWS = kept


def _errors(colour, reference) -> str:
    e = rgb_delta_e(colour, reference)
    return " / ".join(f"{x:.2f}" for x in e) + f" ({np.mean(e):.2f})"


DRAWS_CASES = ((16, 0.05), (64, 0.05), (16, 0.2), (16, 0.4), (64, 0.2), (64, 0.4))


def draws_rows() -> list[tuple]:
    """Per disordered stack, CIEDE2000 at ANGLES (and their mean) from the average of DRAWS_REFERENCE stratified
    draws of the whole stack summed coherently: the model's 8 draws (stratified), 8 independent ones, and the
    partially coherent sums of 8 draws (each of partial_coherence.DEEP_MODES; '-': the spread stays within
    coherence, every film coherent)."""
    cases = [("nacre (5%)", preset("nacre"))] + [(f"Bragg {n} films, disorder {round(100 * d)}%", _sized(n, d))
                                                 for n, d in DRAWS_CASES]
    rows = []
    for name, p in cases:
        reference = _mirror_colour(p, so.disorder_draws, DRAWS_REFERENCE)
        row = [name, _errors(_mirror_colour(p, so.disorder_draws, 8), reference),
               _errors(_mirror_colour(p, _independent_draws, 8), reference)]
        for mode in DEEP_MODES:
            deep = deep_start(p.stack, mode) < p.stack.count
            row.append(_errors(_mirror_colour(p, so.disorder_draws, 8, mode), reference) if deep else "-")
        rows.append(tuple(row))
    return rows


DRAWS_HEADER = ("stack", "8 stratified draws (0 / 30 / 60°, mean)", "8 independent draws",
                *(f"partially coherent, {mode}" for mode in DEEP_MODES))

BAKE_HEADER = ("stack", "films", "bake (s, CPU)", "bake (s, wall)", "rows", "KiB", "L1", "highlights off", "base")


def _table(header, rows, md: bool) -> str:
    if md:
        lines = ["| " + " | ".join(header) + " |", "|" + "|".join(["---"] + ["---:"] * (len(header) - 1)) + "|"]
        return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])
    widths = [max(len(str(r[i])) for r in rows + [header]) for i in range(len(header))]
    return "\n".join("  ".join(str(c).ljust(w) if i == 0 else str(c).rjust(w) for i, (c, w) in
                               enumerate(zip(r, widths))) for r in [header] + rows)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", action="store_true", help="print markdown tables")
    ap.add_argument("--randoms", type=int, default=6, help="random stacks in the colour table")
    ap.add_argument("--repeats", type=int, default=3, help="bakes per stack (the median's)")
    ap.add_argument("--tables", nargs="+", choices=("colour", "bake", "draws"), default=("colour", "bake", "draws"),
                    help="which tables to measure (default all)")
    args = ap.parse_args(argv)
    if "colour" in args.tables:
        print(_table(COLOUR_HEADER, colour_rows(args.randoms), args.markdown))
        print()
    if "bake" in args.tables:
        print(_table(BAKE_HEADER, bake_rows(args.repeats), args.markdown))
        print()
    if "draws" in args.tables:
        print(f"disorder: CIEDE2000 of the mirror colour from the average of {DRAWS_REFERENCE} draws")
        print(_table(DRAWS_HEADER, draws_rows(), args.markdown))


if __name__ == "__main__":
    main()
