"""Baked tables fitted to the exact model, texel by texel, the way LTC tables are built.

The add-on's tables (:mod:`layered_brdf_addon.model.table_bake`) hold what the closure form's
moment matching gives at each view cosine and thickness.  Here each texel's glossy weights are
instead the non-negative least-squares fit of the same closures (their widths and anisotropy kept)
to the exact model's specular light (:mod:`.exact_model`) over light directions at that view and
thickness: the runtime cost is the same, only the texels differ.  :func:`table_shading` renders
any tables on numpy as Cycles evaluates the group's closures, for the measurements of
benchmarks/fitted_tables.py.
"""
from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np

from layered_brdf_addon.fit.cycles_closures import evaluate_closures
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.plan import EffectPlan
from layered_brdf_addon.model.shading.closures import Closure, ShadingResult
from layered_brdf_addon.model.table_bake import _grid, bake, tabulated_result

from .lighting import _phong_dirs, _phong_pdf, brdf_times_cos

LIGHTS = 256  # light directions per texel
LOBE_SHARE = 2.0 / 3.0  # of them about the mirror direction (the rest cosine-distributed)
WIDTHS = (0.7, 0.85, 1.0, 1.2, 1.45)  # each closure's Roughness times these, the best kept per texel


def table_shading(plan: EffectPlan, layout, texels):
    """``shading(params, n0, n1, d, l, v)`` of the group reading ``texels`` (pixel per unit irradiance,
    the signature of :func:`.lighting.environment_shading`'s ``shading``)."""

    def shading(params, n0, n1, d, l, v):
        res = tabulated_result(params, plan, layout, texels, n0, v, d)
        return evaluate_closures(res, n0, v, l)

    return shading


def _lights(n0, v, e, rng, count):
    """``count`` light directions per point (count, P, 3) from the mixture of cosine sampling and a
    Phong lobe of exponent ``e`` about the mirror direction, and their densities."""
    P = n0.shape[0]
    r_v = 2.0 * np.sum(v * n0, axis=-1, keepdims=True) * n0 - v
    N0, RV = np.broadcast_to(n0, (count, P, 3)), np.broadcast_to(r_v, (count, P, 3))
    u1, u2, u3 = rng.random((count, P)), rng.random((count, P)), rng.random((count, P))
    l = np.where((u3 < LOBE_SHARE)[..., None], _phong_dirs(RV, e, u1, u2), _phong_dirs(N0, 1.0, u1, u2))
    pdf = (1.0 - LOBE_SHARE) * _phong_pdf(N0, 1.0, l) + LOBE_SHARE * _phong_pdf(RV, e, l)
    return l, pdf


def _unit_closure(cl, rep, width=1.0) -> Closure:
    """Closure ``cl`` of unit weight and its Roughness times ``width``, its per-point values repeated
    for every light (``rep``)."""
    def each(x):
        return rep(np.asarray(x, dtype=float))

    alpha = np.clip(np.asarray(cl.alpha, dtype=float) * width * width, 1e-8, 1.0)
    return Closure(cl.name, each(cl.normal), None, each(alpha), (1.0, 1.0, 1.0), each(cl.anisotropy),
                   each(cl.tangent))


def _nnls2(A, b):
    """Per row, the non-negative least-squares ``x`` (K <= 2 columns) of ``A x = b``; A: (P, M, K), b: (P, M)."""
    G = np.einsum("pmk,pml->pkl", A, A)
    r = np.einsum("pmk,pm->pk", A, b)
    K = A.shape[-1]
    out = np.zeros(r.shape)
    best = np.full(r.shape[0], np.inf)
    candidates = [[k] for k in range(K)] + ([list(range(K))] if K == 2 else [])
    for cols in candidates:
        g = G[:, cols][:, :, cols]
        x = np.linalg.solve(g + 1e-30 * np.eye(len(cols)), r[:, cols][..., None])[..., 0]
        if np.any(x < 0.0, axis=-1).all():
            continue
        full = np.zeros(r.shape)
        full[:, cols] = np.maximum(x, 0.0)
        resid = np.einsum("pmk,pk->pm", A, full) - b
        err = np.sum(resid * resid, axis=-1)
        ok = np.all(x >= 0.0, axis=-1) & (err < best)
        out[ok], best[ok] = full[ok], err[ok]
    return out


def fit_tables(params: LayeredParams, plan: EffectPlan, lights: int = LIGHTS, seed: int = 0,
               fit_widths: bool = True):
    """``params``'s tables with each texel's glossy weights (and, with ``fit_widths``, Roughness among
    :data:`WIDTHS` times the baked one) fitted to the exact model's specular light: non-negative least
    squares over ``lights`` directions, weighted by their inverse density (the L2 distance over the
    hemisphere).  Returns (layout, texels, fitted_texels)."""
    layout, texels = bake(params, plan)
    if not plan.specular:
        return layout, texels, texels.copy()
    rng = np.random.default_rng(seed)
    v, d = _grid(layout.width, layout.height, params.d_min, params.d_max)
    v, d = v.reshape(-1, 3), d.reshape(-1)
    n0 = np.zeros_like(v)
    n0[:, 2] = 1.0
    e = max(0.5 * min(params.e0, params.e1 / max(params.r1) ** 2), 1.0)
    l, pdf = _lights(n0, v, e, rng, lights)  # (M, P, 3)
    M, P = pdf.shape
    rep = lambda a: np.broadcast_to(a, (M,) + a.shape).reshape((M * P,) + a.shape[1:])  # noqa: E731
    L = l.reshape(-1, 3)
    spec = (brdf_times_cos(params, rep(n0), rep(n0), rep(d), rep(v), L)
            - brdf_times_cos(params.replace(ks=0.0), rep(n0), rep(n0), rep(d), rep(v), L)).reshape(M, P, 3)
    res = tabulated_result(params, replace(plan, tables=True), layout, texels, n0, v, d)
    w = 1.0 / np.sqrt(np.maximum(pdf, 1e-12) * M)  # (M, P): rows of the L2 integral's estimator
    widths = WIDTHS if fit_widths else (1.0,)
    basis = [[evaluate_closures(ShadingResult(glossy=[_unit_closure(cl, rep, s)]), rep(n0), rep(v), L)
              .reshape(M, P, 3) * w[..., None] for s in widths] for cl in res.glossy]
    fitted = texels.copy()
    K = len(layout.closures)
    best = np.full(P, np.inf)
    for combo in itertools.product(range(len(widths)), repeat=K):
        weights = np.zeros((P, K, 3))
        err = np.zeros(P)
        for c in range(3):
            ks = [k for k, (_, weighs) in enumerate(layout.closures) if c in weighs]
            if not ks:
                continue
            A = np.stack([basis[k][combo[k]][..., c] for k in ks], axis=-1).transpose(1, 0, 2)  # (P, M, K)
            b = (spec[..., c] * w).T
            x = _nnls2(A, b) if len(ks) <= 2 else np.stack([_nnls_loop(A[p], b[p]) for p in range(P)])
            weights[:, ks, c] = x
            resid = np.einsum("pmk,pk->pm", A, x) - b
            err += np.sum(resid * resid, axis=-1)
        better = err < best
        best[better] = err[better]
        flat = fitted.reshape(fitted.shape[0], P, 4)  # a view: texels in the order of the points
        for k in range(K):
            for c in layout.closures[k][1]:
                flat[k, better, c] = weights[better, k, c]
            rough = texels[k, ..., 3].reshape(-1) * widths[combo[k]]
            flat[k, better, 3] = np.minimum(rough[better], 1.0)
    return layout, texels, fitted


def _nnls_loop(A, b):
    from scipy.optimize import nnls

    return nnls(A, b)[0]
