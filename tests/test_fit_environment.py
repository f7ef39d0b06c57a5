"""The closure form under an HDRI (fit/environment.py): identities a constant environment
pins down, and the numpy twin against Cycles' own render of the reference sphere under a
bundled HDRI."""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.fit.cycles_closures import beckmann_eval, phong_ramp_eval, shade_closures
from layered_brdf_addon.fit.environment import Environment, direction_to_uv, uv_to_direction
from layered_brdf_addon.model.geometry import safe_normalize
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.program import Closure, ShadingResult

from constants import ENVIRONMENT_TWIN_DELTA_E

UNIFORM = np.ones((32, 64, 3))


def _hemisphere_integral(evaluate, N, v, samples=400_000, seed=3):
    """Brute-force ``int f(v, l) dl`` over the sphere of directions (f includes the cosine)."""
    rng = np.random.default_rng(seed)
    l = safe_normalize(rng.normal(size=(samples, 3)))
    return 4.0 * np.pi * np.mean(evaluate(np.broadcast_to(N, l.shape), np.broadcast_to(v, l.shape), l))


def _one_glossy(N, alpha=None, exponent=None, weight=(1.0, 1.0, 1.0)):
    cl = Closure(name="test", weight=tuple(np.array([w]) for w in weight), normal=N[None],
                 alpha=np.array([alpha or 0.0]), anisotropy=np.array([0.0]), tangent=None,
                 exponent=np.array([exponent or 0.0]))
    return ShadingResult(glossy=[cl], diffuse=None)


def test_the_mapping_is_blenders_and_inverts():
    rng = np.random.default_rng(0)
    d = safe_normalize(rng.normal(size=(100, 3)))
    assert np.allclose(uv_to_direction(*direction_to_uv(d)), d)
    # Blender: +x looks at the image's middle, +z at its top row (stored last).
    assert np.allclose(direction_to_uv(np.array([1.0, 0.0, 0.0])), (0.5, 0.5))
    assert np.isclose(direction_to_uv(np.array([0.0, 0.0, 1.0]))[1], 1.0)


def test_a_constant_environment_gives_its_radiance_and_pi_irradiance():
    env = Environment(UNIFORM * 2.0)
    rng = np.random.default_rng(1)
    d = safe_normalize(rng.normal(size=(50, 3)))
    assert np.allclose(env.radiance(d), 2.0)
    assert np.allclose(env.radiance(d, 0.5), 2.0)
    assert np.allclose(env.irradiance(d), 2.0 * np.pi, rtol=0.01)


@pytest.mark.parametrize("alpha", [0.05, 0.3])
@pytest.mark.parametrize("view_deg", [0.0, 60.0])
def test_a_glossy_closure_under_a_constant_environment_gives_its_albedo(alpha, view_deg):
    N = np.array([0.0, 0.0, 1.0])
    a = np.radians(view_deg)
    v = np.array([np.sin(a), 0.0, np.cos(a)])
    albedo = _hemisphere_integral(lambda n, vv, l: beckmann_eval(n, vv, l, alpha), N, v)
    got = Environment(UNIFORM).shade(_one_glossy(N, alpha=alpha), N[None], v[None])
    assert got[0] == pytest.approx(np.full(3, albedo), rel=0.03)


def test_a_phong_closure_under_a_constant_environment_gives_its_albedo():
    N = np.array([0.0, 0.0, 1.0])
    v = safe_normalize(np.array([0.5, 0.0, 1.0]))
    albedo = _hemisphere_integral(lambda n, vv, l: phong_ramp_eval(n, vv, l, 200.0), N, v)
    got = Environment(UNIFORM).shade(_one_glossy(N, exponent=200.0), N[None], v[None], lobe_kind="phong")
    assert got[0] == pytest.approx(np.full(3, albedo), rel=0.03)


def test_a_sharp_lobe_sees_a_bright_patch_where_it_points():
    img = np.zeros((64, 128, 3))
    img[40:44, 60:68] = 100.0  # a patch above the horizon, towards +x
    env = Environment(img)
    centre = uv_to_direction(np.array(64 / 128), np.array(42 / 64))
    N = safe_normalize(centre + np.array([1.0, 0.0, 0.0]))  # mirrors +x view onto the patch
    v = np.array([1.0, 0.0, 0.0])
    towards = env.shade(_one_glossy(N, alpha=0.02), N[None], v[None])
    away = env.shade(_one_glossy(-N * np.array([1, 1, -1]), alpha=0.02), N[None], v[None])
    assert towards[0, 0] > 10.0 and away[0, 0] < 1e-3


def test_an_environment_with_nan_is_refused():
    bad = UNIFORM.copy()
    bad[3, 4, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        Environment(bad)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["anodised_titanium", "oil_slick"])
def test_the_numpy_twin_matches_cycles_under_an_hdri(name):
    import bpy

    from layered_brdf_addon.blender import lookdev
    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                                  set_hdri_environment)
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.blender.principled_target import environment_of
    from layered_brdf_addon.fit import colour_space
    from layered_brdf_addon.model.sphere import lower_normal, sphere_geometry, thickness_field

    reset_blender()
    p = preset(name).replace(thickness_mode="height", base_layer="none")
    spec = SceneSpec(camera=camera_for(1, 64), samples=256, threads=2)
    [sphere] = build_scene(spec)
    set_hdri_environment(lookdev.hdri_path("forest.exr"))
    sphere.data.materials.append(apply_layered_material(bpy.data.materials.new(name), p))
    observed = render_passes().beauty
    geo = sphere_geometry(spec.camera)
    rows, cols = np.nonzero(geo.mask)
    n0, p_obj = geo.n0[rows, cols], geo.p_object[rows, cols]
    d = thickness_field(p)(p_obj)
    plan = plan_effects(p)
    closures = shade_closures(p, n0, lower_normal(p, n0, p_obj, d), d, geo.view, plan)
    predicted = environment_of(lookdev.hdri_path("forest.exr")).shade(closures, n0, geo.view, plan.lobe, ng=n0)
    obs = observed[rows, cols, :3]
    white = colour_space.white_of(obs)
    de = colour_space.delta_e_2000(colour_space.lab(np.maximum(predicted, 0.0), white),
                                   colour_space.lab(np.maximum(obs, 0.0), white))
    assert float(np.mean(de)) <= ENVIRONMENT_TWIN_DELTA_E
