"""Model selection: the film's structure a target calls for, chosen by the fit.

A fit from one start keeps that start's modes (the optics, the lower boundary, the base, the
lower medium) and moves only continuous parameters, so a target of another kind of film is out
of its reach: its colour bands cannot appear.  Here the fit tries the structures that could
explain the target and keeps the best:

1. **Candidates** (:func:`candidates`): every preset's structure (its modes, with its
   continuous values as the start: a beetle's chitin over air, an oxide on titanium, the
   paper's tilted dispersive layer...) with each of the three lower boundaries, and physical
   optics over each named medium of the preset's kind (the metals under an oxide, the
   dielectrics under a film); the modes the user pins (``--optics``, ``--normal-mode``...) are kept
   and the candidates that would change them merged away.  A Principled BSDF target keeps only
   the candidates whose base is what the material says it is (:func:`for_surface`: Metallic, or
   Transmission Weight, from 0.5).  :func:`structure_pool` is the pool every caller asks for.
2. **Screening** (in :func:`select_and_fit`): each candidate on a small sample of the target's pixels
   (:data:`SCREEN_PIXELS`): the thickness scan of the full fit (its best order), then a few
   optimiser steps (:data:`SCREEN_STEPS`) from there; its mean CIEDE2000 there is the evidence.
   A structure that cannot show the target's colour bands, its highlight's tint or its diffuse
   colour scores badly whatever its thickness, at the cost of a few hundred evaluations of a
   small sample.
3. **The full fit** (:func:`select_and_fit`) of the best :data:`FINALISTS` (and any other within
   :data:`FINALIST_MARGIN` of the best's screening figure), on every sampled pixel, in two rounds:
   each from its screened start (the scan's best order on the sample), then, only where none came
   within the fit's :data:`~.solve.GOOD_ENOUGH`, each through the full scan's other orders (layer
   indices scanned too) and, where the screening carried it out of its preset's own order, from the
   preset's own values, fitted on a larger sample (:data:`REFINE_PIXELS`, :data:`REFINE_STEPS`
   steps from each), and on every sampled pixel again only where the best of them lies in another
   interference order (:func:`other_order`) and beats the finalist's own fit on that sample: a
   finalist that finds its first order again costs a sample's scan, not a full fit.  A target with
   nothing to sample (a reflectance table: a few colours) fits every order in full.  The lowest mean
   CIEDE2000 over every pixel of the sphere wins.  Every candidate's figures are returned for the
   report.
4. **The thickness pattern**: the candidates' thickness follows the surface's height (numpy
   reproduces it pixel by pixel).  Where the best of them stays over :data:`NOISE_TRIAL_DELTA_E`
   and the pattern is free (``try_noise``), its structure (unless its lower boundary follows the
   thickness's slope, which numpy cannot take of Blender's noise) is fitted again with a noise thickness,
   through the statistics of pixels seen alike (numpy does not evaluate Blender's noise), and the
   noise wins where its statistics are closer to the target's than the height fit's by
   :data:`NOISE_MARGIN` (:meth:`~.targets.SphereTarget.statistics_figure`: both on the same rows).

Nothing here imports bpy.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable, Mapping, Sequence

import numpy as np

from ..model.params import LOWER_MEDIA, LayeredParams
from ..model.presets import PRESETS, preset
from ..model.stack_presets import STACK_PRESETS
from . import solve
from .targets import SphereTarget

STRUCTURE_MODES = ("optics", "normal_mode", "base_layer", "lower_medium")  # what a candidate fixes
SCREEN_PIXELS = 240  # the screening sample's pixels (every view together)
SCREEN_STEPS = 6  # optimiser steps from the scan's best order, per candidate
SCREEN_ORDERS = 1  # the scan's orders tried per candidate
FINALISTS = 3
REFINE_PIXELS = 500  # the second round's sample: each finalist's other orders are fitted on it first ...
REFINE_STEPS = 12  # ... with this many optimiser steps each
ORDER_APART_NM = 137.5  # optical thicknesses a quarter of 550 nm apart: half an interference order
FAR_DELTA_E = 5.0  # a best fit this far from its target: the layered model does not show what it shows
NOISE_TRIAL_DELTA_E = 1.0  # a best height fit over this tries a noise thickness too (where the pattern is free)
NOISE_MARGIN = 0.8  # ... which wins where its statistics figure is below this share of the height fit's
FINALIST_MARGIN = 1.25  # a candidate whose screening figure is within this factor of the best's is a finalist too
NORMAL_MODES = ("parallel", "tilted", "correlated")
TILT_START_DEG = 6.0  # a tilted candidate's start where its preset's lower boundary is parallel
TILT_AZIMUTHS_DEG = (90.0, 180.0, 270.0)  # the paper's tilted candidates turned by these, besides their own
STACK_FIXED = ("optics", "normal_mode")  # what a stack asks for (physical optics, a parallel boundary): a pin
# of another value leaves the stacks out
METAL_K = 0.5  # a lower medium whose extinction coefficient exceeds this in every channel is a metal


@dataclass
class Candidate:
    """A structure tried: its label, the start (a preset's values in the structure's modes) and
    what the fit found of it (screening figure, and for a finalist the full fit's)."""

    label: str
    start: LayeredParams
    preset: str = ""  # the preset whose values it starts from
    screen_delta_e: float = float("inf")
    delta_e: float | None = None  # the full fit's mean CIEDE2000 over its sample (finalists only)
    image_delta_e: float | None = None  # ... and over every pixel of the sphere, where numpy computes them
    statistics: float | None = None  # its statistics figure, where a noise thickness was tried against it
    result: solve.FitResult | None = field(default=None, repr=False)

    def modes(self) -> dict[str, str]:
        return {m: getattr(self.start, m) for m in STRUCTURE_MODES}

    def to_record(self) -> dict:
        return {"label": self.label, "modes": self.modes(), "from_preset": self.preset,
                "screen_mean_delta_e_2000": float(self.screen_delta_e),
                "mean_delta_e_2000": None if self.delta_e is None else float(self.delta_e),
                "image_mean_delta_e_2000": None if self.image_delta_e is None else float(self.image_delta_e),
                "thickness_mode": self.start.thickness_mode,
                "statistics_figure": None if self.statistics is None else float(self.statistics)}

    def figure(self) -> float:
        """What ranks a finalist: its figure over every pixel where there is one, else over its sample."""
        return self.image_delta_e if self.image_delta_e is not None else \
            self.delta_e if self.delta_e is not None else np.inf


def _structure(p: LayeredParams) -> tuple:
    """A structure: its modes, whether it has a specular and a diffuse part (a start without one
    cannot find it: its weight's slope vanishes with the lobe), a tilted boundary's azimuth and the
    films of a stack (a stack keeps its films' media and proportions: each preset's is a structure)."""
    azimuth = round(p.tilt_azimuth) % 360 if p.normal_mode == "tilted" else None
    films = None if p.stack is None else repr(p.stack.to_dict())
    return tuple(getattr(p, m) for m in STRUCTURE_MODES) + (p.ks > 0.0, p.kd > 0.0, azimuth, films)


def _label(name: str, p: LayeredParams) -> str:
    if p.stack is not None:
        films = f"{p.stack.count} film{'s' if p.stack.count != 1 else ''}"
        return f"a stack of {films} over {p.lower_medium}, from {name}"
    medium = f" over {p.lower_medium}" if p.optics == "physical" else ""
    turned = f" (azimuth {p.tilt_azimuth:g} deg)" if p.normal_mode == "tilted" else ""
    base = {"none": "", "transparent": ", see-through", "metal": ", metal base"}[p.base_layer]
    diffuse = ", diffuse base" if p.kd > 0.0 else ""
    noise = ", thickness noise" if p.thickness_mode == "noise" else ""
    return f"{p.optics} optics{medium}, lower boundary {p.normal_mode}{turned}{base}{diffuse}{noise}, from {name}"


def candidates(pinned: Mapping[str, str] | None = None, thickness_mode: str | None = None,
               layers: Sequence[str] = ("film",)) -> list[Candidate]:
    """The structures a fit tries: with ``"film"`` in ``layers``, each film preset's, with each lower
    boundary, the paper's tilted ones turned by :data:`TILT_AZIMUTHS_DEG`, physical films over each named
    medium of their kind; with ``"stack"``, each structural preset's stack (its films' media and proportions;
    its period is what the fit finds); ``pinned`` modes (``{"optics": "paper"}``...) imposed on every
    candidate (the candidates that become alike merged, a stack's that a pinned mode would make
    impossible left out), ``thickness_mode`` too where given."""
    pinned = dict(pinned or {})
    out: list[Candidate] = []
    seen: set = set()

    def add(name: str, p: LayeredParams) -> None:
        p = p.replace(**pinned) if pinned else p
        if thickness_mode is not None:
            p = p.replace(thickness_mode=thickness_mode)
        key = _structure(p)
        if key not in seen:
            seen.add(key)
            out.append(Candidate(_label(name, p), p, name))

    if "stack" in layers:
        for name in STACK_PRESETS:
            p = preset(name)
            # tilted lamellae (labradorite) send their light away from the mirror direction a table holds
            if p.normal_mode == "parallel" and all(getattr(p, m) == v for m, v in pinned.items() if m in STACK_FIXED):
                add(name, p)
    films = [name for name in PRESETS if name not in STACK_PRESETS] if "film" in layers else []
    for name in films:  # the presets' own structures first: they claim a structure before a variant does
        add(name, preset(name))
    for name in films:
        p = preset(name)
        for mode in NORMAL_MODES:
            if mode != p.normal_mode:
                q = p.replace(normal_mode=mode)
                add(name, q.replace(tilt=TILT_START_DEG) if mode == "tilted" and p.tilt == 0.0 else q)
    for c in [c for c in out if c.start.optics == "paper" and c.start.normal_mode == "tilted"]:
        for turn in TILT_AZIMUTHS_DEG:  # the paper's prism: its colours run along the tilt's azimuth
            add(c.preset, c.start.replace(tilt_azimuth=(c.start.tilt_azimuth + turn) % 360.0))
    for name in films:  # physical optics over each named medium of the preset's kind (a metal, a dielectric)
        p = preset(name)
        if p.optics == "physical" and p.base_layer != "transparent" and "lower_medium" not in pinned:
            for medium in LOWER_MEDIA[1:]:  # the named ones: "custom" is the values given
                q = p.replace(lower_medium=medium)
                if _metal(q) == _metal(p):
                    add(name, q)
    return out


SURFACE_BASES = {"metal": ("metal",), "see-through": ("transparent",), "dielectric": ("none",)}
SURFACE_SPLIT = 0.5  # a Principled BSDF's Metallic (or Transmission Weight) from which it is a metal (see-through)


def surface_kind(metallic: float | None, transmission: float | None) -> str | None:
    """What a Principled BSDF says its surface is: ``"metal"`` (Metallic from :data:`SURFACE_SPLIT`),
    ``"see-through"`` (Transmission Weight from it), else ``"dielectric"``; None where an input is
    unknown (driven by a link)."""
    if metallic is None or transmission is None:
        return None
    if metallic >= SURFACE_SPLIT:
        return "metal"
    return "see-through" if transmission >= SURFACE_SPLIT else "dielectric"


def for_surface(pool: Sequence[Candidate], kind: str | None) -> list[Candidate]:
    """The candidates of ``pool`` whose base is what the target's material says it is (:func:`surface_kind`:
    a metal's film over a metal, a see-through film over a clear base, a dielectric's over a diffuse
    one): the material's own evidence, which one image under suns and an HDRI shows less surely (a
    metal's tint and a paper film's colour read alike).  The whole pool where ``kind`` is None or where
    none would be left (the user pinned another base)."""
    bases = SURFACE_BASES.get(kind, ())
    kept = [c for c in pool if c.start.base_layer in bases]
    return kept or list(pool)


def for_material(pool: Sequence[Candidate], surface: str | None, uniform_film: bool = False) -> list[Candidate]:
    """The candidates of ``pool`` a Principled material's own evidence allows: its ``surface``'s base
    (:func:`for_surface`) and, for a film of one thickness, a parallel lower boundary (a tilted one, or
    one that follows the thickness's slope, needs a film whose thickness varies: on a sphere it would
    make colours of the sphere's height that the material does not have on another shape).  Each
    rule the whole pool where it would leave none (the user pinned another mode)."""
    kept = for_surface(pool, surface)
    if uniform_film:
        kept = [c for c in kept if c.start.normal_mode == "parallel"] or kept
    return kept


def structure_pool(reflectance: bool = False, pinned: Mapping[str, str] | None = None,
                   surface: str | None = None, uniform_film: bool = False, layer: str | None = None) -> list[Candidate]:
    """The structures a fit with no start chooses among, as the command line, the panel and the
    benchmarks ask for them: :func:`candidates` with the ``pinned`` modes, the thickness by height
    unless pinned (numpy reproduces a height pixel by pixel); for a ``reflectance`` table a smooth,
    uniform film (its lower boundary parallel unless pinned); for a Principled material the
    structures of its ``surface`` and film (:func:`for_material`).  ``layer``: "film" or "stack" only; by
    default a reflectance table's pool holds both (a stack's mirror colours are what a table shows of it),
    any other target's one film."""
    pinned = dict(pinned or {})
    if reflectance:
        pinned.setdefault("normal_mode", "parallel")
    layers = (layer,) if layer else ("film", "stack") if reflectance else ("film",)
    return for_material(candidates(pinned, thickness_mode=pinned.pop("thickness_mode", "height"), layers=layers),
                        surface, uniform_film)


def _metal(p: LayeredParams) -> bool:
    """Whether the lower medium absorbs like a metal (an extinction coefficient above
    :data:`METAL_K` in every channel)."""
    return min(p.k2_r, p.k2_g, p.k2_b) > METAL_K


def sample_target(target, pixels: int = SCREEN_PIXELS):
    """A sample of ``pixels`` of ``target``'s pixels (a sphere target), else the target."""
    if isinstance(target, SphereTarget) and target.pixels > pixels:
        return SphereTarget(target.views, pixels=pixels, uniform_film=target.uniform_film)
    return target


@dataclass
class Selection:
    """The structure chosen and the fit of it, with every candidate's figures."""

    result: solve.FitResult  # its seconds and evaluations the whole selection's
    chosen: Candidate
    candidates: list[Candidate]

    def to_record(self) -> list[dict]:
        return [c.to_record() for c in self.candidates]


def other_order(a: LayeredParams, b: LayeredParams) -> bool:
    """Whether two films' mean optical thicknesses (the green index times the mean thickness) lie
    :data:`ORDER_APART_NM` or more apart: another interference order, which a fit from one does not
    reach from the other (within it, a full fit from either ends alike)."""
    def optical(p: LayeredParams) -> float:
        return p.r1_g * 0.5 * (p.d_min + p.d_max)

    return abs(optical(a) - optical(b)) >= ORDER_APART_NM


def finalists(screened: Sequence[Candidate]) -> list[Candidate]:
    """The candidates fitted in full: the best :data:`FINALISTS` by screening figure, and any
    other within :data:`FINALIST_MARGIN` of the best's."""
    ranked = sorted(screened, key=lambda c: c.screen_delta_e)
    best = ranked[0].screen_delta_e
    return [c for k, c in enumerate(ranked) if k < FINALISTS or c.screen_delta_e <= best * FINALIST_MARGIN]


def select_and_fit(target, pool: Sequence[Candidate], vary: Sequence[str] | None = None, *, starts: int = 3,
                   steps_per_start: int = 40, progress: Callable[[str, int], None] | None = None,
                   should_stop: Callable[[], bool] | None = None, try_noise: bool = False) -> Selection:
    """Screen every candidate of ``pool`` on a sample of ``target``, fit the finalists on all of it,
    keep the lowest mean CIEDE2000; with ``try_noise``, a noise thickness for the best where it stays
    far (the module's step 4).  ``progress(stage, evaluations)`` hears each evaluation, the stage
    ``"screen K/N"``, ``"fit K/N"``, ``"refine K/N"`` or ``"noise 1/1"``; ``should_stop()`` ends it
    (:class:`~.solve.FitCancelled`)."""
    t0 = time.perf_counter()
    total = 0
    small = sample_target(target, SCREEN_PIXELS)
    pool = [replace(c) for c in pool]
    own = {id(c): c.start for c in pool}  # each structure's preset values, before screening moves them

    def hearing(stage: str):
        base = total

        def hear(evaluations: int) -> None:
            if progress is not None:
                progress(stage, base + evaluations)
        return hear

    for k, c in enumerate(pool):
        stage = f"screen {k + 1}/{len(pool)}"
        result = solve.fit(small, c.start, vary, starts=SCREEN_ORDERS, steps_per_start=SCREEN_STEPS,
                           progress=hearing(stage), should_stop=should_stop, try_start=False, index_scan=False)
        c.screen_delta_e, c.start = result.mean_delta_e, result.params
        total += result.evaluations
    last = finalists(pool)
    noise = try_noise and isinstance(target, SphereTarget)

    def full_fit(c: Candidate, stage: str, start: LayeredParams | None = None, **how) -> None:
        """Fit ``c`` (from ``start``, else its screened start) on the whole target; keep the result where it
        beats the candidate's last."""
        nonlocal total
        first = c.start if start is None else start
        result = solve.fit(target, first, vary, steps_per_start=steps_per_start, progress=hearing(stage),
                           should_stop=should_stop, **how)
        total += result.evaluations
        figure = target.image_delta_e(result.params) if hasattr(target, "image_delta_e") else None
        fitted = replace(c, delta_e=result.mean_delta_e, image_delta_e=figure, result=result)
        if c.result is None or fitted.figure() < c.figure():
            c.delta_e, c.image_delta_e, c.result = fitted.delta_e, fitted.image_delta_e, result

    for k, c in enumerate(last):  # each finalist from its screened start (its scan's best order)
        full_fit(c, f"fit {k + 1}/{len(last)}", starts=0)
    if min(c.delta_e for c in last) > solve.GOOD_ENOUGH and starts > 0:  # none matches yet: the other orders
        middle = sample_target(target, REFINE_PIXELS)
        for k, c in enumerate(last):  # each on a sample first; the whole target only where an order beats its own
            stage = f"refine {k + 1}/{len(last)}"
            if middle is target:  # nothing to sample (a table, a small image): every order on the whole target
                full_fit(c, stage, starts=starts, try_start=False)
                continue
            orders = solve.fit(middle, c.start, vary, starts=starts, steps_per_start=REFINE_STEPS,
                               progress=hearing(stage), should_stop=should_stop, try_start=False)
            total += orders.evaluations
            if other_order(own[id(c)], c.start):  # the screening left the preset's own order
                preset_order = solve.fit(middle, own[id(c)], vary, starts=0, steps_per_start=REFINE_STEPS,
                                         progress=hearing(stage), should_stop=should_stop)
                total += preset_order.evaluations
                orders = min((orders, preset_order), key=lambda r: r.mean_delta_e)
            if other_order(orders.params, c.result.params) and \
                    orders.mean_delta_e < solve.sample_delta_e(middle, c.result.params):
                full_fit(c, stage, orders.params, starts=0)
    chosen = min(last, key=Candidate.figure)
    best = chosen.result
    if (noise and chosen.figure() > NOISE_TRIAL_DELTA_E and chosen.start.thickness_mode != "noise"
            and chosen.start.normal_mode != "correlated"):  # numpy has no slope of Blender's noise to tilt by
        start = best.params.replace(thickness_mode="noise")
        c = Candidate(_label(chosen.preset, start), start, chosen.preset, screen_delta_e=chosen.screen_delta_e)
        # The height fit's order first, the scan's other orders only where it falls short (as above).
        result = solve.fit(target, start, vary, starts=starts, steps_per_start=steps_per_start,
                           progress=hearing("noise 1/1"), should_stop=should_stop)
        total += result.evaluations
        c.delta_e, c.result = result.mean_delta_e, result
        c.statistics, chosen.statistics = target.statistics_figure(result.params), target.statistics_figure(best.params)
        pool.append(c)
        if c.statistics < NOISE_MARGIN * chosen.statistics:
            chosen, best = c, result
    pool.sort(key=lambda c: (c is not chosen, c.figure(), c.screen_delta_e))
    return Selection(replace(best, seconds=time.perf_counter() - t0, evaluations=total), chosen, pool)


def far_fit_note(figure: float, selected: bool, how_to_select: str = "without --start") -> str | None:
    """What to tell the user when the best fit is more than :data:`FAR_DELTA_E` from its target (its
    mean CIEDE2000 ``figure``; ``selected``: every structure was tried, else the start's only, and
    ``how_to_select`` says how to try them all), or None."""
    if not figure > FAR_DELTA_E:
        return None
    who = "no structure tried comes" if selected else "the start's structure does not come"
    return (f"{who} within {FAR_DELTA_E:g} CIEDE2000 of the target (the closest: {figure:.2f}): the layered "
            "model does not show what the target shows; the closest fit is written"
            + ("" if selected else f" ({how_to_select} the fit tries every structure)"))
