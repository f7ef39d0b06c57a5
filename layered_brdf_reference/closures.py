"""The closure form (:mod:`layered_brdf_addon.fit.cycles_closures`, what the shaders render
evaluated the way Cycles evaluates its closures) and a single-lobe baseline to compare it with.
"""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.fit.cycles_closures import (  # noqa: F401  (the reference's names)
    CLOSURE_WEIGHT_CUTOFF, INV_2PI, beckmann_eval, beckmann_lambda, closure_shading, ensure_valid_specular_reflection,
    evaluate_closures, glossy_alphas, phong_peak, phong_ramp_eval, program_inputs, shade_closures)
from layered_brdf_addon.model import program
from layered_brdf_addon.model.geometry import dot
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams

from .exact_model import diffuse_rho, specular_brdf


def single_lobe_shading(params: LayeredParams, n0, n1, d, l, v, exponent=None, wavelengths=WAVELENGTHS_NM,
                        lobe_kind="phong"):
    """Baseline: one Phong lobe per channel about the mirror direction, its weight the exact
    ``rho`` at the mirror configuration, exponent ``e0`` unless given."""
    n0 = np.asarray(n0, dtype=float)
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    r_v = 2.0 * dot(v, n0)[..., None] * n0 - v
    rho = specular_brdf(-r_v, v, n0, n1, params.r1, d, params.e0, params.e1, params.r0, wavelengths, ng=n0)
    cos_v = np.clip(dot(v, n0), 0.0, 1.0)
    e = float(params.e0 if exponent is None else exponent)
    peak = phong_peak(cos_v, e)
    amp = params.ks * rho * cos_v[..., None]
    w = np.where(peak[..., None] > 0, amp / np.where(peak > 0, peak, 1.0)[..., None], 0.0)
    res = program.ShadingResult(glossy=[program.Closure("single", n0, np.full(cos_v.shape, e), None,
                                                        (w[..., 0], w[..., 1], w[..., 2]))])
    spec = evaluate_closures(res, n0, v, l, "phong")
    kd = diffuse_rho(params.r1, d, params.r0, wavelengths) * params.kd * np.asarray(params.base_color)
    return spec + kd * (np.maximum(dot(n0, np.asarray(l)), 0.0) / np.pi)[..., None]
