"""White furnace: under a uniform white world, each preset's rendered albedo equals the
closure form's, integrated by Monte Carlo in numpy (docs/physical-optics.md, "White furnace
with every base layer", says by how much the model itself exceeds 1)."""
import numpy as np
import pytest

from layered_brdf_addon.model import PRESETS, preset
from layered_brdf_reference.closures import evaluate_closures, shade_closures
from layered_brdf_addon.model.geometry import dot
from layered_brdf_reference.lighting import environment_shading
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.sphere import lower_normal, sphere_geometry, thickness_field

pytestmark = pytest.mark.slow

NAMES = sorted(PRESETS)
# Furnace tests need numpy to know d: noise patterns are replaced by the height pattern.
PARAMS = [preset(n).replace(thickness_mode="height", base_layer="none") for n in NAMES]


@pytest.fixture(scope="module")
def furnace():
    from layered_brdf_addon.blender.scene import render_passes, set_uniform_environment

    from render_helpers import render_row

    row = render_row(PARAMS, backend="nodes", height=32, samples=128)
    set_uniform_environment(1.0)
    row.passes = render_passes()
    return row


def _pixels(row, k, every=4):
    geo = sphere_geometry(row.camera, row.centers)
    sel = geo.mask & (geo.sphere == k) & (dot(geo.n0, geo.view) > 0.2)
    idx = np.argwhere(sel)[::every]
    return geo, idx


@pytest.mark.parametrize("name", NAMES)
def test_white_furnace_albedo_matches_closure_form(furnace, name):
    k = NAMES.index(name)
    p = PARAMS[k]
    geo, idx = _pixels(furnace, k)
    n0 = geo.n0[idx[:, 0], idx[:, 1]]
    d = thickness_field(p)(geo.p_object[idx[:, 0], idx[:, 1]])
    n1 = lower_normal(p, n0, geo.p_object[idx[:, 0], idx[:, 1]], d)
    def shading(params, n0_, n1_, d_, l, v):
        res = shade_closures(params, n0_, n1_, d_, v, plan_effects(params))
        return evaluate_closures(res, n0_, v, l, params.lobe)

    want = environment_shading(p, n0, n1, d, geo.view, samples=256, shading=shading).mean(0)
    got = furnace.passes.beauty[idx[:, 0], idx[:, 1]].mean(0)
    print(f"{name}: rendered albedo {got.round(4)}, closure form {want.round(4)}")
    assert np.allclose(got, want, rtol=0.03, atol=2e-3)
