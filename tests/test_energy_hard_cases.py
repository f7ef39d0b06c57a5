"""Energy-keeping lobes at the edges of their range: Roughness 0 and 1, grazing views (cosines below
1e-4), a film seen at its critical angle, a lower medium of extinction 10.  The closures stay finite and
return at most what arrives, with what passes to a clear base: by quadrature per closure (numpy, the
program the shaders run), and rendered in a white furnace by the node group and the OSL shader."""
from __future__ import annotations

import math

import numpy as np
import pytest

from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.presets import preset

SOAP = preset("soap_bubble").replace(d_min=400.0, d_max=400.0)


def _exponent(roughness: float) -> float:
    """The Phong exponent of a Roughness, ``(Roughness^-4 - 1) / 2``, within the parameter's range (Roughness 0:
    the sharpest lobe the parameters allow)."""
    most = LayeredParams.spec("e0").max
    return most if roughness <= 0.0 else min(0.5 * (roughness ** -4 - 1.0), most)


HARD = {
    "Roughness 0": SOAP.replace(e0=_exponent(0.0), e1=_exponent(0.0)),
    "Roughness 1": SOAP.replace(e0=_exponent(1.0), e1=_exponent(1.0)),
    "Roughness 1, lower only": SOAP.replace(e1=_exponent(1.0)),
    # A film of lower index than the outside: total internal reflection beyond cos 0.6.
    "critical angle": SOAP.replace(r0=1.5, layer_ior=1.2, layer_dispersion=0.0),
    "extinction 10": SOAP.replace(lower_medium="custom", r2_r=2.0, r2_g=2.0, r2_b=2.0, k2_r=10.0, k2_g=10.0,
                                  k2_b=10.0, base_layer="none"),
    "rough metal": preset("anodised_titanium").replace(e0=_exponent(1.0), e1=_exponent(1.0), k2_r=10.0),
}
VIEW_COS = (1.0, 0.6, 0.6001, 0.5999, 0.05, 1e-3, 5e-5)
TOL = 0.035  # the closed form of the closures' albedo at rough, grazing lobes (test_lobe_energy.py)
NOISE = 0.06  # the 95th percentile of a 64-sample render of a rough film sits this far above its mean


@pytest.mark.parametrize("mu", VIEW_COS, ids=lambda m: f"cos {m:g}")
@pytest.mark.parametrize("name", list(HARD))
def test_hard_films_stay_finite_and_return_at_most_what_arrives(name, mu):
    from test_lobe_energy import _returned_and_passed

    returned, passed = _returned_and_passed(HARD[name], math.degrees(math.acos(mu)))
    total = returned + passed
    print(f"{name} at cos {mu:g}: reflected {returned.round(4)}, passed {passed.round(4)}")
    assert np.all(np.isfinite(total)) and np.all(returned >= 0.0) and np.all(passed >= 0.0)
    assert np.all(total <= 1.0 + TOL)


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["nodes", "osl"])
def test_hard_films_in_a_white_furnace(backend):
    """Each ball's mean at most 1 (and the closed form's error), its 95th percentile too (and the render's
    noise); every pixel finite."""
    from layered_brdf_addon.model.geometry import dot
    from layered_brdf_addon.model.sphere import sphere_geometry

    from render_helpers import render_furnace

    cases = [p.replace(evaluation="arithmetic") for p in HARD.values()] + list(HARD.values())
    row = render_furnace(cases, backend, height=32, samples=64)
    passes = row.passes
    assert np.all(np.isfinite(passes.beauty))
    geo = sphere_geometry(row.camera, row.centers)
    names = [f"{n}, computed" for n in HARD] + list(HARD)
    for k, name in enumerate(names):
        sel = geo.mask & (geo.sphere == k) & (dot(geo.n0, geo.view) > 0.02)
        p95 = np.percentile(passes.beauty[sel][:, :3], 95, axis=0)
        mean = passes.beauty[sel][:, :3].mean(0)
        print(f"{backend}: {name}: mean {mean.round(3)}, p95 {p95.round(3)}")
        assert np.all(mean <= 1.0 + TOL) and np.all(p95 <= 1.0 + NOISE), \
            f"{name} returns {mean.round(3)} (p95 {p95.round(3)}) of the light it receives"
