"""Lights other than a sun: renders vs the exact model integrated by Monte Carlo in numpy.

The shaders approximate the exact BRDF by closures (docs/closure-decomposition.md);
under extended lights the error is averaged over each lobe.  We assert a relative L1
over the visible sphere of at most 8% (measured: see the printed values).
"""
import numpy as np
import pytest

from layered_brdf_addon.model import preset
from layered_brdf_reference.compare import relative_l1
from layered_brdf_addon.model.geometry import dot
from layered_brdf_reference.lighting import area_light_shading, environment_shading
from layered_brdf_addon.model.sphere import Sun, sphere_geometry, thickness_field

pytestmark = pytest.mark.slow

PARAMS = preset("fig4_parallel").replace(thickness_mode="height", d_min=0.0, d_max=400.0, kd=0.5, e0=60.0,
                                         e1=100.0)
L1_BOUND = 0.08


def _scene(samples):
    from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, reset_blender
    from layered_brdf_addon.blender.material import apply_layered_material

    reset_blender()
    cam = camera_for(1, 48)
    spheres = build_scene(SceneSpec(camera=cam, sun=Sun(), samples=samples))
    apply_layered_material(spheres[0], PARAMS, "nodes")
    return cam


def _pixels(cam):
    geo = sphere_geometry(cam)
    mask = geo.mask & (dot(geo.n0, geo.view) > 0.1)
    n0 = geo.n0[mask]
    d = thickness_field(PARAMS)(geo.p_object[mask])
    return geo, mask, n0, d


def test_uniform_environment():
    from layered_brdf_addon.blender.scene import render_passes, set_uniform_environment

    cam = _scene(samples=256)
    set_uniform_environment(1.0)
    img = render_passes().beauty
    geo, mask, n0, d = _pixels(cam)
    expected = environment_shading(PARAMS, n0, n0, d, geo.view, samples=1024)
    err = relative_l1(img[mask], expected, np.ones(len(n0), bool))
    print(f"uniform environment: relative L1 {err:.4f} over {len(n0)} pixels")
    assert err <= L1_BOUND


def test_area_light():
    from layered_brdf_addon.blender.scene import render_passes, set_area_light

    cam = _scene(samples=256)
    l = np.array([np.sin(np.radians(40.0)), -np.cos(np.radians(40.0)), 0.0])
    z = l
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, z, 4.0 * l
    set_area_light(m, size=1.5, power=300.0)
    img = render_passes().beauty
    geo, mask, n0, d = _pixels(cam)
    expected = area_light_shading(PARAMS, n0, n0, d, geo.view, geo.p_world[mask], m, 1.5, 300.0, samples=576)
    lit = expected.sum(-1) > 1e-4 * expected.sum(-1).max()
    err = relative_l1(img[mask][lit], expected[lit], np.ones(lit.sum(), bool))
    print(f"area light: relative L1 {err:.4f} over {lit.sum()} lit pixels")
    assert err <= L1_BOUND
