"""Spectral and analytic modes of the shading program: baked tables, the numpy closure form, and the
shaders against it."""
import json

import numpy as np
import pytest

from layered_brdf_addon.model import preset
from layered_brdf_addon.model.spectral_tables import PATH, SAMPLE_COUNTS
from layered_brdf_addon.model.sphere import OrthoCamera, render_spheres
from layered_brdf_reference import closures
from layered_brdf_reference.spectral import shader_tables

from constants import MAX_FAILING, REL_TOL, SUN_40



def test_baked_tables_are_current():
    data = json.loads(PATH.read_text())
    for n in SAMPLE_COUNTS:
        want = shader_tables(n)
        for key in ("wavelengths", "cauchy", "rgb"):
            assert np.allclose(data[str(n)][key], want[key], rtol=0, atol=1e-12), (n, key)



def test_spectral_closure_form_converges_to_32_wavelengths():
    cam = OrthoCamera(width=48, height=48)
    sun = SUN_40
    imgs = {}
    for a in ("spectral8", "spectral16", "spectral32"):
        p = preset("fig6_medium").replace(thickness_mode="height", accuracy=a)
        imgs[a], geo = render_spheres(p, cam, sun, shading=closures.closure_shading)
        assert np.all(np.isfinite(imgs[a])) and np.all(imgs[a] >= 0)
    e8 = np.abs(imgs["spectral8"] - imgs["spectral32"]).sum()
    e16 = np.abs(imgs["spectral16"] - imgs["spectral32"]).sum()
    assert e16 < e8


MODES = ("spectral4", "spectral8", "spectral16", "spectral32")


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["nodes", "osl"])
@pytest.mark.parametrize("kd", [0.0, 0.5])
def test_spectral_shaders_match_closure_form(backend, kd):
    """Every spectral mode and the analytic mode, dispersive (Fig. 6) and not, thin and thick, in
    one render per backend and diffuse weight."""
    from layered_brdf_reference.compare import agreement, lit_mask

    from render_helpers import render_row

    cases = [preset("fig6_medium").replace(thickness_mode="height", accuracy=a, kd=kd) for a in MODES]
    cases.append(preset("fig4_parallel").replace(thickness_mode="height", accuracy="spectral16", kd=kd,
                                                 r1_r=1.5, r1_g=1.5, r1_b=1.5))
    analytic = preset("fig6_medium").replace(thickness_mode="height", accuracy="analytic", kd=kd)
    cases += [analytic, analytic.replace(d_min=800.0, d_max=3000.0),
              preset("fig4_parallel").replace(thickness_mode="height", accuracy="analytic", kd=kd,
                                              r1_r=1.5, r1_g=1.5, r1_b=1.5)]
    if backend == "osl":
        cases.append(cases[1].replace(lobe="phong"))
    row = render_row(cases, backend=backend, height=48)
    expected, geo = render_spheres(row.params, row.camera, row.sun, row.centers, shading=closures.closure_shading)
    for k, p in enumerate(cases):
        mask = lit_mask(geo, row.sun.l) & (geo.sphere == k)
        ag = agreement(row.passes.beauty, expected, mask, rel_tol=REL_TOL)
        print(backend, p.accuracy, kd, ag)
        assert ag.failing_fraction <= MAX_FAILING, f"{p.accuracy}: {ag}"
