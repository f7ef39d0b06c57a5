"""The shading program, written once for every backend that runs it.

``layered_surface(ops, plan)`` is the whole shader: it reads the material's inputs,
computes the layer's thickness and lower normal at the shading point (the surface
prelude), and returns the closures that stand for the layered BRDF (the decomposition
of docs/closure-decomposition.md) with the shader's other outputs.  ``ops`` supplies
arithmetic and the shading point's geometry: numpy arrays (:mod:`.ops_numpy`, the
closure form used to predict renders), Blender shader nodes (the node group) or OSL
source text (the OSL shader).  Python control flow depends only on the
:class:`~.plan.EffectPlan`, never on parameter values, so every parameter stays a live
shader input.

Functions marked :func:`shader_function` are the program's named steps: the OSL backend
emits each as an OSL function of the same name, the others run them inline.

Values: scalars and 3-vectors of the backend; Python floats are constants.

This module is the program's top (:func:`layered_surface`, :func:`shade`); its steps live
in :mod:`.shading`, one part per module, and every name of theirs is importable from here:

* :mod:`.shading.step`: :func:`shader_function`;
* :mod:`.shading.closures`: :class:`Closure`, :class:`ShadingResult`;
* :mod:`.shading.values`: channel values (a scalar or an RGB triple);
* :mod:`.shading.fresnel`: the paper's Fresnel terms (eqs. 7-9);
* :mod:`.shading.thin_film`: thin-film optics (the physical mode);
* :mod:`.shading.lobes`: lobe shapes and the closures that carry them;
* :mod:`.shading.fold`: the interference lobe folded into the other two;
* :mod:`.shading.interference`: the path difference, the band-integrated cosine, harmonics;
* :mod:`.shading.placement`: where each channel's lobes lie (eqs. 4, 5, 10, 11);
* :mod:`.shading.amplitudes`: the lobes' amplitudes (eqs. 3-9) and the diffuse factor;
* :mod:`.shading.channel_program`: the program of one channel or three;
* :mod:`.shading.spectral_mode`: the spectral modes, one wavelength after the other;
* :mod:`.shading.surface_prelude`: thickness and lower normal at the shading point;
* :mod:`.shading.inputs`: the shader's inputs, clamped;
* :mod:`.shading.base_shader`: what reaches the Base Shader;
* :mod:`.shading.stack_shade`, :mod:`.shading.lamella_shade`: a stack of films, parallel or tilted lamellae;
* :mod:`.shading.tables`: the closures read from a material's baked tables.
"""
from __future__ import annotations

from .params import WAVELENGTHS_NM
from .plan import EffectPlan
from .shading.amplitudes import diffuse_rho, film_amplitudes, film_diffuse_rho, lobe_amplitudes
from .shading.base_shader import CLEAR_K, base_transmittance, base_weight, passed_at, passed_to_base
from .shading.channel_program import LOBE_PLACEMENT, channel_block, channel_lobes, diffuse_colour
from .shading.closures import Closure, ShadingResult
from .shading.fold import FOLD_BASIS, FOLD_RIDGE, fold_basis, fold_interference, fold_weights, lobe_correlation
from .shading.fresnel import fresnel_f0, schlick, transmission_factor
from .shading.inputs import FLOAT_LIMIT, clamped_inputs, direction_input, program_inputs
from .shading.interference import band_cosine, harmonics, interference_cosine, interference_path
from .shading.lobes import (ANISO_FLOOR, INV_2PI, MIN_COS, angle2, beckmann_lambda, closure_for, closure_tangent,
                            glossy_alphas, lobe_alphas, lobe_peak, lobe_shape)
from .shading.placement import exit_direction, interference_centre, layer_path, lobe_geometry
from .shading.spectral_mode import merged_group_weights, shade_spectral, spectral_groups, spectral_step
from .shading.lamella_shade import lamella_geometry, lamella_shade, response_optics, tabulated_lamellae
from .shading.stack_shade import stack_shade
from .shading.step import shader_function
from .shading.tables import TableLayout, tabulated_shade
from .shading.surface_prelude import (DEG, D_LIMIT, GRADIENT_STEP, correlated_normal, layer_thickness, lower_normal,
                                      pattern_inputs, pattern_thickness, tangent_axis, thickness_at,
                                      thickness_factor, thickness_gradient, tilt_axis, tilt_axis_about,
                                      tilted_normal)
from .shading.thin_film import (HARMONICS_MULTIBEAM, beam_sums, c_abs2, c_div, c_mul, c_sqrt, film_beams,
                                fresnel_reflectance, harmonic_count, lower_amplitudes, optics_settings, top_amplitudes)
from .shading.values import channels, gather, spread

__all__ = [
    "shader_function", "Closure", "ShadingResult", "channels", "gather", "spread", "fresnel_f0", "schlick",
    "transmission_factor", "HARMONICS_MULTIBEAM", "beam_sums", "c_abs2", "c_div", "c_mul", "c_sqrt", "film_beams",
    "fresnel_reflectance", "harmonic_count", "lower_amplitudes", "optics_settings", "top_amplitudes",
    "ANISO_FLOOR", "INV_2PI", "MIN_COS", "angle2", "beckmann_lambda", "closure_for", "closure_tangent",
    "glossy_alphas", "lobe_alphas", "lobe_peak", "lobe_shape", "FOLD_BASIS", "FOLD_RIDGE", "fold_basis",
    "fold_interference", "fold_weights", "lobe_correlation", "band_cosine", "harmonics", "interference_cosine",
    "interference_path", "exit_direction", "interference_centre", "layer_path", "lobe_geometry", "diffuse_rho",
    "film_amplitudes", "film_diffuse_rho", "lobe_amplitudes", "LOBE_PLACEMENT", "channel_block", "channel_lobes",
    "diffuse_colour", "merged_group_weights", "shade_spectral", "spectral_groups", "spectral_step", "DEG",
    "D_LIMIT", "GRADIENT_STEP", "correlated_normal", "layer_thickness", "lower_normal", "pattern_inputs",
    "pattern_thickness", "tangent_axis", "thickness_at", "thickness_factor", "thickness_gradient",
    "tilt_axis", "tilt_axis_about", "tilted_normal",
    "FLOAT_LIMIT", "clamped_inputs", "direction_input", "program_inputs", "CLEAR_K", "base_weight",
    "base_transmittance", "passed_at", "passed_to_base", "TableLayout", "tabulated_shade", "lamella_shade",
    "tabulated_lamellae", "lamella_geometry", "stack_shade", "shade", "layered_surface",
    "surface_geometry",
]


def shade(ops, P, n0, n1, d, v, plan: EffectPlan, wavelengths=WAVELENGTHS_NM) -> ShadingResult:
    """Closures of the layered BRDF at one shading point.

    ``P``: dict with ``r1`` (3 values), ``r0``, ``e0``, ``e1``, ``ks``, ``kd``, ``base``
    (3 values); ``n0``, ``n1``: unit normals; ``d``: thickness (nm); ``v``: unit view
    direction (towards the camera).
    """
    if plan.spectral:
        return shade_spectral(ops, P, n0, n1, d, v, plan)
    res = ShadingResult()
    optics = optics_settings(plan)
    if plan.diffuse:
        res.diffuse = diffuse_colour(ops, P, d, wavelengths, band=plan.analytic, dispersion=plan.dispersion,
                                     interference=plan.interference, footprint=plan.analytic and plan.footprint,
                                     **optics)
    if not plan.specular:
        return res
    inputs = dict(r1=ops.combine(*P["r1"]), lam=tuple(float(x) for x in wavelengths), e0=P["e0"], e1=P["e1"],
                  ks=P["ks"], r0=P["r0"], n0=n0, n1=n1, v=v, d=d)
    if optics:
        inputs.update(n2=ops.combine(*P["r2"]), k2=ops.combine(*P["k2"]))
    if not plan.dispersion:
        # Equal indices: every channel's lobes have the same centre and exponent, placed
        # once (by green's index); each channel keeps its own amplitudes.
        inputs["r1_lobes"] = P["r1"][1]
    # The analytic mode's variant of the block (the paper's RGB keeps its interference).
    band = dict(band=True, interference=plan.interference, footprint=plan.footprint) if plan.analytic else {}
    b = ops.call("channels" if plan.dispersion else "channels, shared lobes", channel_block, inputs, lobe=plan.lobe,
                 **band, **optics)
    res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, P["e0"], v, ops.components(b["AR"]),
                                  energy=bool(optics)))
    w = ops.components(b["w_T"])
    if optics:
        res.extras["reflected"] = b["reflected"]
    if not plan.dispersion:
        res.glossy.append(Closure("transmit", b["N_T0"], b["e_T"], b["alpha_T"], w, b["aniso_T"], b["U_T0"]))
        return res
    # Each channel's lobes have their own centres and exponents: a closure per channel.
    e, alpha, aniso = (ops.components(b[f"{k}_T"]) for k in ("e", "alpha", "aniso"))
    for c in range(3):
        weight = tuple(w[c] if k == c else 0.0 for k in range(3))
        res.glossy.append(Closure(f"transmit_{'rgb'[c]}", b[f"N_T{c}"], e[c], alpha[c], weight,
                                  aniso[c], b[f"U_T{c}"]))
    return res


def surface_geometry(ops, plan: EffectPlan, *, thickness=None, lower=None, axis=None):
    """The shader's first stages at one shading point: ``(P, n0, v, p_obj, pattern, d, axis, n1)``, the inputs
    kept within their ranges, the upper normal, the view, the object-space position, the thickness pattern (None
    where there is none or the thickness is given), the thickness (nm), the tilt axis (None where the boundary
    is not tilted) and the lower normal.  A caller that brings its own thickness, lower normal or tilt axis
    (numpy: a render's AOVs, probe points, a fit's thickness levels) passes them (``lower``: the lower normal)
    and they are taken as given;
    the shaders compute all three."""
    with ops.stage("Inputs, each kept within its range; the upper normal n0"):
        P = clamped_inputs(ops, plan)
        # A zero-length or NaN Normal input (unconnected, or a broken texture) falls back to
        # the shading normal.
        n0 = ops.normalize(direction_input(ops, ops.input("Normal")), ops.shading_normal())
        v = ops.incoming()
        p_obj = ops.object_position()
    pattern = None
    with ops.stage("Layer thickness d (nm): noise, height or your Thickness input"):
        if thickness is None:
            pattern = pattern_thickness(ops, P, p_obj, plan)
            d = layer_thickness(ops, P, p_obj, plan, pattern)
        else:
            d = thickness
    with ops.stage("Lower boundary normal n1: parallel, tilted or following d"):
        if axis is None and plan.normals == "tilted":
            axis = tilt_axis(ops, P, n0)
        n1 = lower_normal(ops, P, n0, p_obj, d, plan, pattern, axis) if lower is None else lower
    return P, n0, v, p_obj, pattern, d, axis, n1


def layered_surface(ops, plan: EffectPlan, layout: TableLayout | None = None, *, thickness=None, lower=None,
                    axis=None, stack=None) -> ShadingResult:
    """The whole shader at one shading point, from the material's inputs; a plan with ``tables``
    reads the closures from the material's baked tables, of ``layout`` (:mod:`.shading.tables`).
    ``thickness``, ``lower`` (the lower normal), ``axis``: what a caller brings of its own
    (:func:`surface_geometry`).  A film stack's plan computes its closures on numpy only, from ``stack``
    (:class:`.stack_optics.StackResponse`); the shaders read them from tables.

    ``extras`` carries the shader's other outputs: ``thickness`` (nm), ``lower_normal``,
    ``upper_normal`` (world space), ``base_weight`` (the factor of the Base Shader input) and
    ``transmittance`` (what reaches the base per channel: the colour of a clear base's Transparent BSDF).
    """
    P, n0, v, p_obj, pattern, d, axis, n1 = surface_geometry(ops, plan, thickness=thickness, lower=lower, axis=axis)
    lamellae = plan.stack and plan.normals == "tilted"
    if plan.tables and lamellae:
        with ops.stage("Tilted lamellae in a crystal: the top's gloss and the schiller read from the material's baked "
                       "tables (the view's angle and azimuth from the lamellae; the cosine to them, d)"):
            res = tabulated_lamellae(ops, plan, layout, P, n0, v, d, axis)
    elif plan.tables:
        with ops.stage("Lobes and interference from the material's baked tables: the view's angle, d "
                       "(and the view's azimuth from the lower normal)"):
            res = tabulated_shade(ops, plan, layout, P, n0, v, d, axis)
    elif plan.stack:
        if stack is None:
            raise ValueError(f"plan {plan.key}: a film stack's closures are computed from its optics on numpy "
                             "(stack=StackResponse); the shaders read them from its tables")
        if lamellae:
            with ops.stage("Tilted lamellae in a crystal: the top's gloss, the schiller through the top"):
                res = lamella_shade(ops, plan, P, lamella_geometry(ops, plan, P, n0, n1, v), *response_optics(stack, d))
        else:
            with ops.stage("A stack of films: its reflectance in one lobe, what it passes to the base"):
                res = stack_shade(ops, plan, P, n0, v, d, stack)
    else:
        with ops.stage("Lobes and interference: eqs. 3-11 (specular), 14-18 (diffuse)"):
            inputs = program_inputs(P)
            res = shade(ops, inputs, n0, n1, d, v, plan)
        weight, transmittance = passed_to_base(ops, plan, inputs, v, n0, res.extras.get("reflected"))
        res.extras.update(base_weight=weight, transmittance=transmittance)
    res.extras.update(thickness=d, lower_normal=n1, upper_normal=n0)
    return res
