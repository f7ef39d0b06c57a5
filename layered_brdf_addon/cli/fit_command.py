"""``layered-brdf fit``: the layered material that reproduces a target.

A target is one of:

* a reference-sphere render of ``layered-brdf render`` (``TARGET``: its sidecar ``STEM.json``,
  or ``STEM``, ``STEM.exr`` or ``STEM.png`` with the sidecar beside it): the EXR's Combined
  pass, seen by the sidecar's camera under its sun; one sphere of a gallery with ``--tile``;
* a table of a smooth film's mirror reflectance (``--reflectance FILE.csv``): rows of angle,
  wavelength or channel, and reflectance;
* a Principled BSDF material of a .blend (``--principled FILE.blend --material NAME``),
  rendered by Cycles on the reference sphere under a few suns.

The options are validated into a :class:`~.fit_request.FitRequest` first; the fit
(:func:`layered_brdf_addon.fit.solve.fit`) runs in numpy from its start (a preset, a
params file, their modes overridden by options) and writes, together and only once it is
done:

* ``OUT.json``: the fitted parameters in the format of the panel's user presets (``format``,
  ``version``, ``name``, ``params``), which ``render --params OUT.json`` reads too, with a
  ``fit`` record: the target, the start, the free parameters, the mean CIEDE2000, the model
  evaluations, the seconds and the starts tried;
* ``OUT.png``: target | fit | CIEDE2000 per pixel (a sphere target, one row per view), or a
  swatch per angle, target above fit, and the reflectance curves (a reflectance table).

Everything the command is given is checked before the fit: invalid input is exit code 2
with nothing written; an interrupt leaves nothing behind (exit code 130).  Nothing here
imports bpy except the ``--principled`` path.
"""
from __future__ import annotations

import sys
from dataclasses import replace
from typing import Callable, Sequence

from ..fit import solve, structures
from ..fit.free import vary_for
from ..fit.solve import FitCancelled
from ..io.staging import InterruptGuard
from ..model.params import LayeredParams
from .fit_outputs import fit_record, output_document, reflectance_figure, sphere_figure, write_outputs
from .fit_request import FitRequest
from .fit_targets import load_principled_target, load_reflectance_target, load_render_target
from .fit_verify import check_camera, verify
from .options import EXIT_OK

STEPS_PER_START = 40  # the optimiser's steps from each start


def fit_with_progress(target, start: LayeredParams, vary, starts: int, enabled: bool,
                      should_stop: Callable[[], bool]):
    """:func:`~layered_brdf_addon.fit.solve.fit` with a tqdm bar of model evaluations on the
    standard error (its total the most the fit can take)."""
    from tqdm import tqdm

    names = vary_for(target, start, vary)
    scan = solve.THICKNESS_SCAN_STEPS * (1 + len(solve.SCAN_HALF_WIDTHS))
    most = scan + (starts + 1) * STEPS_PER_START * (len(names) + 1)
    bar = tqdm(total=most, desc="fit", unit="eval", file=sys.stderr, disable=not enabled, dynamic_ncols=True)

    def progress(evaluations: int) -> None:
        bar.update(evaluations - bar.n)

    try:
        result = solve.fit(target, start, vary, starts=starts, steps_per_start=STEPS_PER_START,
                           progress=progress, should_stop=should_stop)
        bar.total = bar.n
        bar.refresh()
    finally:
        bar.close()
    return result


def select_with_progress(target, req: FitRequest, should_stop: Callable[[], bool]):
    """:func:`~layered_brdf_addon.fit.structures.select_and_fit` over the request's structures with a
    tqdm bar of model evaluations, its label the stage (``screen K/N``, ``fit K/N``,
    ``refine K/N``, ``noise 1/1``)."""
    from tqdm import tqdm

    bar = tqdm(total=None, desc="fit", unit="eval", file=sys.stderr, disable=not req.progress, dynamic_ncols=True)

    shown_stage = [""]

    def progress(stage: str, evaluations: int) -> None:
        if shown_stage[0] != stage:
            shown_stage[0] = stage
            bar.set_description_str(stage, refresh=False)
        bar.update(evaluations - bar.n)

    try:
        return structures.select_and_fit(target, req.pool, req.vary, starts=req.starts,
                                         steps_per_start=STEPS_PER_START, progress=progress, should_stop=should_stop,
                                         try_noise=req.try_noise)
    finally:
        bar.close()


def run_fit(req: FitRequest, argv: Sequence[str] | None = None) -> int:
    """``fit``: read (or render) the validated request's target, fit, write OUT.json and OUT.png."""
    source, paths = req.source, req.paths
    with InterruptGuard() as guard:
        if source.kind == "render":
            loaded = load_render_target(source, req.tile)
        elif source.kind == "reflectance":
            loaded = load_reflectance_target(source)
        else:
            loaded = load_principled_target(source, req.principled, guard, verbose=req.verbose)
        if req.verify:
            check_camera(loaded.record)
        guard.check()
        stop = lambda: guard.received is not None  # noqa: E731
        selection = None
        try:
            if req.pool:
                if source.kind == "principled":  # the material says what its surface is
                    req = replace(req, pool=tuple(structures.for_material(req.pool, loaded.record["surface"],
                                                                           loaded.record["uniform_film"])))
                selection = select_with_progress(loaded.target, req, stop)
                result = selection.result
            else:
                result = fit_with_progress(loaded.target, req.start, req.vary, req.starts, req.progress, stop)
        except FitCancelled:
            raise KeyboardInterrupt("the fit was interrupted") from None
        guard.check()
        record_extra = {}
        if req.verify:
            record_extra["verify"] = verify(loaded.target, loaded.record, result.params, guard, req.principled,
                                            req.verbose)
        record = {**fit_record(result, loaded, dict(req.start_record), argv, selection), **record_extra}
        note = structures.far_fit_note(record["mean_delta_e_2000"], selection is not None)
        if note is not None:
            record["note"] = note
        draw = reflectance_figure if source.kind == "reflectance" else sphere_figure
        figure = draw(loaded.target, result.params, record["mean_delta_e_2000"],
                      structure=selection.chosen.label if selection is not None else None)
        document = output_document(paths.stem.name, result.params, record)
        write_outputs(paths, document, figure, guard)
    if selection is not None:
        print(structures_table(selection))
    print(f"fit: mean CIEDE2000 {record['mean_delta_e_2000']:.3f}, {result.seconds:.1f} s, {result.evaluations} "
          f"evaluations; wrote {paths.json}, {paths.png}")
    if note is not None:
        print(f"fit: warning: {note}", file=sys.stderr)
    if "verify" in record_extra:
        v = record_extra["verify"]
        views = f" (per view {' / '.join(f'{d:.2f}' for d in v['per_view'])})" if len(v["per_view"]) > 1 else ""
        print(f"re-rendered: mean CIEDE2000 {v['mean_delta_e_2000']:.3f} over the sphere's {v['pixels']} pixels{views} "
              f"(the fit's figure {record['mean_delta_e_2000']:.3f} over the same pixels computed in numpy)")
    return EXIT_OK


def structures_table(selection) -> str:
    """The structures tried, best first (``*`` the one chosen): the full fit's mean CIEDE2000 (the
    finalists) and the screening's."""
    width = max(len(c.label) for c in selection.candidates)
    lines = [f"  {'structure tried':<{width}}  screened  fitted"]
    for c in selection.candidates:
        fitted = f"{c.delta_e:6.2f}" if c.delta_e is not None else "     -"
        lines.append(f"{'*' if c is selection.chosen else ' '} {c.label:<{width}}  {c.screen_delta_e:8.2f}  {fitted}")
    return "\n".join(lines)
