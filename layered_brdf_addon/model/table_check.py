"""Baked tables checked against the program they stand for: a bake reads its own texels back as Cycles' Image
Texture reads them, at probe points (views from normal to grazing, lights about the mirror direction where the
sharp lobes' light is, thicknesses over the range, tilt axes at every azimuth), and compares the light its
closures return (:func:`.closure_light.evaluate_closures`) with the closures computed per point.
Where tables cannot hold the program (total internal reflection in the layer, fringes finer than the rows
resolve) the material computes per point instead (:func:`.policy.render_plan`), and says why.

Plain Python and numpy: the Blender layer, the command line and the tests call it.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from concurrent.futures import CancelledError, Future, ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from . import ops_numpy
from .closure_light import evaluate_closures
from .ops_numpy import ShadingPoint, vec
from .params import LayeredParams
from .plan import EffectPlan
from .program import layered_surface
from .shading.surface_prelude import tilted_normal
from .stack_optics import StackResponse
from .table_bake import bake, held_values, table_digest, tabulated_result

PROBE_POINTS = 4096
PROBE_SEED = 20261205  # the same probes for every bake: a check is a function of the values
RELATIVE = 0.02  # a probe's highlight is off where a channel differs by more than 2% of its brightest channel
DARK = 1.0e-3  # (a highlight darker than a thousandth of the brightest is measured against that)


@dataclass(frozen=True)
class Limits:
    """What tables must hold: the L1 difference of the light over the probes (relative), the share of the
    probes' highlights off by more than 2%, and the largest difference of what passes to the base."""

    l1: float
    failing: float
    base: float


# Parallel boundaries: the light within 2% (L1), at most 2% of the probes' highlights off by more than 2%
# (every preset, at Upper Roughness from 0.1 to 0.6: L1 up to 0.8%, highlights 0.0-0.8% off); a tilted
# boundary's exit direction jumps where its path meets the critical angle, a seam the computed image shows and
# tables smooth, so its probes are off more (fig4_tilted and fig6: L1 1.7-2.2%, highlights 11-18% off) where
# renders agree away from the seam.
PARALLEL_LIMITS = Limits(l1=0.02, failing=0.02, base=0.02)
TILTED_LIMITS = Limits(l1=0.03, failing=0.2, base=0.02)


@dataclass(frozen=True)
class TableCheck:
    """How far baked tables are from the program at the probe points (:class:`Limits`' measures), and the
    limits they must hold."""

    l1: float
    failing: float
    base: float
    limits: Limits = PARALLEL_LIMITS

    @property
    def holds(self) -> bool:
        lim = self.limits
        return self.l1 <= lim.l1 and self.failing <= lim.failing and self.base <= lim.base

    def why(self) -> str:
        """Why a material computes per point instead (empty where the tables hold)."""
        if self.holds:
            return ""
        return (f"baked tables would be {100 * self.l1:.1f}% off the computed light ({100 * self.failing:.0f}% of "
                f"highlights off by more than 2%, what passes to the base by up to {self.base:.2f}; they must hold "
                f"{100 * self.limits.l1:g}%, {100 * self.limits.failing:g}% and {self.limits.base:g}): computed per "
                "point")


def probes(params: LayeredParams, n: int, seed: int = PROBE_SEED):
    """Views from normal to grazing about ``n0 = +z``, lights within three lobe widths of the mirror direction
    (where the sharp lobes' light is), thicknesses over the range, tilt axes at every azimuth and the tilted
    lower normals about them."""
    rng = np.random.default_rng(seed)
    cos_v = rng.uniform(0.02, 1.0, n)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    s = np.sqrt(1.0 - cos_v ** 2)
    v = np.stack([s * np.cos(phi), s * np.sin(phi), cos_v], axis=-1)
    n0 = np.zeros_like(v)
    n0[:, 2] = 1.0
    mirror = 2.0 * cos_v[:, None] * n0 - v
    light = mirror + rng.normal(0.0, 3.0 / np.sqrt(max(min(params.e0, params.e1), 1.0)), (n, 3))
    light[:, 2] = np.abs(light[:, 2])
    light /= np.linalg.norm(light, axis=-1, keepdims=True)
    d = rng.uniform(min(params.d_min, params.d_max), max(params.d_min, params.d_max), n)
    azimuth = rng.uniform(0.0, 2.0 * np.pi, n)
    axes = np.stack([-np.sin(azimuth), np.cos(azimuth), np.zeros(n)], -1)
    n1 = np.asarray(tilted_normal(ops_numpy, vec(n0), vec(axes), params.tilt), dtype=float)
    return n0, v, light, d, axes, n1


def check_tables(params: LayeredParams, plan: EffectPlan, layout, texels, points: int = PROBE_POINTS,
                 seed: int = PROBE_SEED) -> TableCheck:
    """How far the tables ``texels`` (``layout``, a bake of ``params`` for ``plan``) are from the program at
    ``points`` probes (``seed``: another set of them)."""
    n0, v, light, d, axes, n1 = probes(params, points, seed)
    if plan.normals != "tilted":
        n1 = n0
    pt = ShadingPoint(held_values(params, ShadingPoint.SOCKETS), n0, v, np.zeros_like(n0))
    stack = StackResponse.of(params) if plan.stack else None
    computed = layered_surface(pt, replace(plan, tables=False), thickness=d, lower=vec(n1), axis=vec(axes),
                               stack=stack)
    tabulated = tabulated_result(params, plan, layout, texels, n0, v, d, axes if plan.normals == "tilted" else None)
    a = evaluate_closures(computed, n0, v, light, plan.lobe)
    b = evaluate_closures(tabulated, n0, v, light, plan.lobe)
    total = float(np.abs(a).sum())
    l1 = float(np.abs(a - b).sum()) / total if total > 0.0 else 0.0
    # At each probe's highlight (the light at the view's mirror direction), as bright as the lobes get there;
    # tilted lamellae's, where the tables are read, is their schiller's (the view mirrored about its normal).
    about = n0
    if plan.stack and plan.normals == "tilted" and plan.specular:
        about = np.broadcast_to(np.asarray(computed.glossy[-1].normal, dtype=float), n0.shape)
    mirror = 2.0 * np.sum(about * v, axis=-1, keepdims=True) * about - v
    am = evaluate_closures(computed, n0, v, mirror, plan.lobe)
    bm = evaluate_closures(tabulated, n0, v, mirror, plan.lobe)
    peak = np.maximum(am.max(axis=-1), DARK * max(float(am.max()), 1e-30))
    off = np.abs(am - bm).max(axis=-1) > RELATIVE * peak
    base = _base_difference(computed, tabulated, d.shape)
    return TableCheck(l1=l1, failing=float(np.mean(off)), base=base,
                      limits=TILTED_LIMITS if plan.normals == "tilted" else PARALLEL_LIMITS)


def base_share(result, shape) -> np.ndarray:
    """What a shading result passes to the base: the Base Shader factor and the transmittance, (..., 4)."""
    return np.concatenate([np.broadcast_to(result.extras["base_weight"], shape)[..., None],
                           np.broadcast_to(np.asarray(result.extras["transmittance"], dtype=float), shape + (3,))],
                          axis=-1)


def _base_difference(computed, tabulated, shape) -> float:
    """The largest difference between what passes to the base, computed and read from tables."""
    diff = np.abs(base_share(computed, shape) - base_share(tabulated, shape))
    return float(np.nanmax(diff)) if diff.size else 0.0


_KEPT = 8
_checked: OrderedDict = OrderedDict()  # table digest -> (layout, texels, check), the most recent last
_lock = threading.RLock()  # re-entered where cancelling a bake runs its done callback
_running: dict = {}  # key -> the Future of a bake started by bake_later, until it is kept
_owned: dict = {}  # owner -> the Future of the last bake it asked for
_worker: ThreadPoolExecutor | None = None


def _key(params: LayeredParams, plan: EffectPlan) -> str:
    return f"{plan.key}:{table_digest(params, plan)}"


def _bake_and_keep(key: str, params: LayeredParams, plan: EffectPlan):
    layout, texels = bake(params, plan)
    # A stack always reads its tables (it has no per-point shader): its check is the tests' and benchmarks'.
    check = None if plan.stack else check_tables(params, plan, layout, texels)
    with _lock:
        _checked[key] = (layout, texels, check)
        _checked.move_to_end(key)
        while len(_checked) > _KEPT:
            _checked.popitem(last=False)
        return _checked[key]


def checked_bake(params: LayeredParams, plan: EffectPlan):
    """``(layout, texels, check)``: the bake of ``params`` for ``plan`` and how far it is from the program (None
    for a film stack's, :func:`check_tables` measures it); the last few are kept (by the tables' digest), so
    that checking a plan and baking its tables bake once, and a bake already running (:func:`bake_later`) is
    waited for, not run again."""
    key = _key(params, plan)
    with _lock:
        if key in _checked:
            _checked.move_to_end(key)
            return _checked[key]
        running = _running.get(key)
    if running is not None:
        try:
            return running.result()
        except CancelledError:  # dropped before it started (another value asked for): bake it now
            pass
    return _bake_and_keep(key, params, plan)


def is_kept(params: LayeredParams, plan: EffectPlan) -> bool:
    """Whether the bake of ``params`` for ``plan`` is kept: :func:`checked_bake` returns it at once."""
    with _lock:
        return _key(params, plan) in _checked


def bake_later(params: LayeredParams, plan: EffectPlan, owner: str = "") -> Future | None:
    """Start the bake of ``params`` for ``plan`` on a worker thread (one at a time, in the order asked), its
    result kept for :func:`checked_bake`; None where it is kept already.  An ``owner`` (a material's shader)
    that asks for other values before its last bake has started drops that one: a slider's drag bakes the
    value it is at when the worker is free and the last one, not every value it passed."""
    global _worker
    key = _key(params, plan)
    with _lock:
        if key in _checked:
            return None
        future = _running.get(key)
        if future is None or future.cancelled():
            if _worker is None:
                _worker = ThreadPoolExecutor(1, thread_name_prefix="layered-brdf-bake")
            future = _worker.submit(_bake_and_keep, key, params, plan)
            _running[key] = future
            future.add_done_callback(lambda f, key=key: _forget(key, f))
        earlier = _owned.get(owner)
        if owner and earlier is not None and earlier is not future:
            earlier.cancel()  # only one not yet started is dropped
        if owner:
            _owned[owner] = future
        return future


def _forget(key: str, future: Future) -> None:
    with _lock:
        if _running.get(key) is future:
            del _running[key]
        for owner in [o for o, f in _owned.items() if f is future]:
            del _owned[owner]


def bake_running(params: LayeredParams, plan: EffectPlan) -> bool:
    """Whether a bake of ``params`` for ``plan`` started by :func:`bake_later` is running or waiting to."""
    with _lock:
        future = _running.get(_key(params, plan))
        return future is not None and not future.done()
