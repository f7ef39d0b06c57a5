"""Thin-film optics (``optics="physical"``) rendered by Cycles, node group and OSL, against
the numpy closure form of the same shading program, pixel by pixel: a film on a metal and one
on water (three harmonics each: the rim calls for them), a tilted lower boundary, the paper's RGB
and a spectral mode, a diffuse part under the film."""
from functools import partial

import pytest

from layered_brdf_reference import closures as C
from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_reference.compare import agreement, lit_mask

from constants import MAX_FAILING, REL_TOL
from render_helpers import render_row

pytestmark = pytest.mark.slow

CASES = {
    "titanium": preset("anodised_titanium").replace(e0=150.0, e1=900.0),  # three harmonics, a metal below
    "oil": preset("oil_slick").replace(e0=200.0, e1=430.0, kd=0.6, base_r=0.3, base_g=0.3, base_b=0.3),
    "tilted": preset("fig6_medium").replace(optics="physical", lower_medium="glass", kd=0.0),
    "rgb": preset("beetle_shell").replace(accuracy="rgb", e0=200.0, e1=490.0),
    "spectral": preset("fig4_parallel").replace(optics="physical", lower_medium="water", accuracy="spectral8",
                                                kd=0.0),
}
NAMES = list(CASES)
BACKENDS = ["nodes", "osl"]


def test_the_cases_cover_the_physical_plans():
    plans = {n: plan_effects(p) for n, p in CASES.items()}
    assert all(p.optics == "physical" for p in plans.values())
    assert plans["titanium"].multibeam and plans["oil"].multibeam and not plans["titanium"].passes
    assert plans["tilted"].normals == "tilted" and plans["spectral"].spectral == 8 and plans["oil"].diffuse


@pytest.fixture(scope="module")
def rows():
    return {b: render_row([CASES[n] for n in NAMES], backend=b) for b in BACKENDS}


def _closure_form(row):
    return render_spheres(row.params, row.camera, row.sun, row.centers, thickness=row.passes.thickness,
                          shading=partial(C.closure_shading))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", NAMES)
def test_render_matches_the_closure_form(rows, backend, name):
    row = rows[backend]
    expected, geo = _closure_form(row)
    mask = lit_mask(geo, row.sun.l) & (geo.sphere == NAMES.index(name))
    ag = agreement(row.passes.beauty, expected, mask, rel_tol=REL_TOL)
    print(f"{name} ({backend}): {ag}")
    assert ag.failing_fraction <= MAX_FAILING, str(ag)
    assert expected[mask].max() > 0.01  # light leaves where the model says it does
