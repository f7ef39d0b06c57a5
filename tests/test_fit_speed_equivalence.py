"""The fit's shortcuts give what shading one view and one parameter set at a time gives: the
sun views shaded in one run of the program, parameter sets stacked in one run (a fit's
slopes, a noise's thickness levels), a transparent base's far side in the same run as its
front, and the slopes' own forward differences, which are scipy's."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

from layered_brdf_addon.fit import colour_space
from layered_brdf_addon.fit.cycles_closures import closure_shading, shade_closures
from layered_brdf_addon.fit.environment import Environment
from layered_brdf_addon.fit.free import FreeParameters, default_vary
from layered_brdf_addon.fit.see_through import base_transmittance, far_side
from layered_brdf_addon.fit.solve import DIFF_STEP, _Objective
from layered_brdf_addon.fit.targets import NOISE_MEDIAN, SphereTarget, SphereView, noise_levels
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.sphere import lower_normal, thickness_field
from layered_brdf_reference.fit_cases import CAMERA, SUNS, views_of

SAME = 1e-10  # relative: the same arithmetic, in another order at most

PARAMS = {
    "soap, seen through": preset("soap_bubble"),
    "soap, opaque": preset("soap_bubble").replace(base_layer="none"),
    "soap, seen through, noise": preset("soap_bubble").replace(thickness_mode="noise"),
    "oil, noise": preset("oil_slick"),
    "titanium": preset("anodised_titanium").replace(thickness_mode="height"),
    "paper, seen through": preset("fig4_tilted").replace(thickness_mode="height", base_layer="transparent"),
    "paper, phong": preset("fig4_tilted").replace(thickness_mode="height", lobe="phong"),
}


@pytest.fixture(scope="module")
def target() -> SphereTarget:
    """Two suns and an environment."""
    env = Environment(np.random.default_rng(0).random((32, 64, 3)) * 2.0)
    env_view = SphereView(np.random.default_rng(1).random((96, 96, 3)), CAMERA, None, environment=env)
    return SphereTarget(views_of(preset("oil_slick").replace(thickness_mode="height"), SUNS) + [env_view],
                        pixels=600)


def view_by_view(target: SphereTarget, params) -> np.ndarray:
    """The sampled pixels shaded a view at a time, each side of the sphere on its own, for one
    parameter set: the plain composition of the model's functions."""
    plan, field_ = plan_effects(params), thickness_field(params)
    out = []
    for pts in target._points:
        view, v = pts["view"], pts["v"]
        n0 = pts["n0"]
        d_noise = np.full(len(n0), params.d_min + (params.d_max - params.d_min) * NOISE_MEDIAN)

        def side(n, p):
            """The side's pixels and what it passes to a clear base."""
            d = d_noise if field_ is None else field_(p)
            n1 = lower_normal(params, n, p, d)
            vv = np.broadcast_to(v, n.shape)
            res = shade_closures(params, n, n1, d, vv, plan)
            passed = base_transmittance(params, res, n, vv, plan)
            if view.environment is not None:
                return view.environment.shade(res, n, v, plan.lobe, ng=n), passed
            return view.sun.strength * closure_shading(params, n, n1, d, view.sun.l, v, ng=n, plan=plan), passed

        pixels, t_front = side(n0, pts["p_object"])
        if params.base_layer == "transparent":
            p_far, n_far = far_side(n0, v)
            behind = np.zeros(3) if view.environment is None else view.environment.radiance(-v)
            far, t_back = side(n_far, p_far)
            pixels = pixels + t_front * (far + t_back * behind)
        out.append(pixels)
    return np.concatenate(out)


@pytest.mark.parametrize("name", sorted(PARAMS))
def test_the_views_shaded_in_one_run_are_the_views_shaded_one_by_one(target, name):
    got, expected = target.predict(PARAMS[name]), view_by_view(target, PARAMS[name])
    assert np.allclose(got, expected, rtol=SAME, atol=SAME * np.abs(expected).max())


def test_stacked_parameter_sets_are_the_sets_shaded_one_by_one(target):
    base = list(PARAMS.values())
    sets = base + [p.replace(d_min=p.d_min * 1.01) for p in base] + [p.replace(e0=p.e0 * 0.9) for p in base]
    many = target.predict_many(sets)
    for shaded, params in zip(many, sets):
        one = target.predict(params)
        assert np.allclose(shaded, one, rtol=SAME, atol=SAME * np.abs(one).max())
    pixelwise = [p for p in sets if not target.matches_statistics(p)]
    for lab, params in zip(target.features_many(pixelwise), pixelwise):
        assert np.allclose(lab, target.features(params), rtol=SAME, atol=SAME)


def test_a_noise_thickness_levels_shaded_together_are_its_levels_one_by_one(target):
    params = PARAMS["soap, seen through, noise"]
    levels = target._levels_lab(params)
    for k, u in enumerate(noise_levels(params.noise_detail)):
        level = params.d_min + (params.d_max - params.d_min) * u
        one = target.predict(params.replace(d_min=level, d_max=level, thickness_mode="noise"))
        assert np.allclose(levels[:, k], colour_space.lab(one, target.white_y), rtol=SAME, atol=SAME)


@pytest.mark.parametrize("name", ["soap, seen through", "titanium"])
def test_the_slopes_are_scipys_forward_differences(target, name):
    params = PARAMS[name]
    free = FreeParameters(default_vary(params), params)
    objective = _Objective(target, free, None, None)
    lo, hi = free.bounds()
    near_bounds = lo + (hi - lo) * np.where(np.arange(lo.size) % 2 == 0, 1.0 - 1e-7, 1e-7)  # steps turned back
    for x in (free.vector(params, 0.05), near_bounds):
        expected = approx_derivative(objective, x, method="2-point", rel_step=DIFF_STEP, bounds=(lo, hi))
        # Rounding of the stacked and the single evaluations differs by about 1e-16 of a value, which a
        # forward difference divides by its step: a slope one run finds 0 the other may find as noise, measured
        # up to 1.8e-6 of the largest slope on Blender 5.0's numpy, depending on the tests run before.
        assert np.allclose(objective.jacobian(x), expected, rtol=1e-6, atol=1e-5 * np.abs(expected).max())
