"""Tilted lamellae in a crystal (labradorite's schiller, model/shading/lamella_shade.py): their optics against
tmm seen from inside the crystal, their tables against the optics computed per point, the node group and the
OSL shader against the closure form pixel by pixel (the schiller where the lamellae mirror the sun), lossless
lamellae in a white furnace, and tables that a tilt does not rebake."""
from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from layered_brdf_addon.fit.cycles_closures import closure_shading
from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.table_bake import bake, table_digest
from layered_brdf_addon.model.table_check import check_tables
from layered_brdf_reference.compare import agreement, lit_mask
from layered_brdf_reference.stack_colours import stack_error

from constants import MAX_FAILING, REL_TOL
from render_helpers import render_furnace, render_row, ring_means

LABRADORITE = preset("labradorite")
STEEP = LABRADORITE.replace(tilt=50.0, tilt_azimuth=90.0)  # lamellae whose light reaches them near grazing
# The same crystal without lamellae: both films of the crystal's own index reflect nothing.
PLAIN = LABRADORITE.replace(stack={**LABRADORITE.stack.to_dict(), "films": [
    {"ior": 1.566, "thickness_nm": 80.0}, {"ior": 1.566, "thickness_nm": 80.0}]})


@pytest.mark.parametrize("theta", [0.0, 30.0, 50.0])
def test_the_lamellae_reflect_what_tmm_says_inside_the_crystal(theta):
    """The analytic colour of the lamellae's reflection against tmm's spectrum at 1 nm, from the crystal (1.566):
    0-50 degrees inside it, as far as light from outside reaches them (39.7 degrees in the crystal, 12 of tilt)."""
    error = stack_error(LABRADORITE, theta)
    print(f"labradorite at {theta:g} deg inside: CIEDE2000 {error:.3f}")
    assert error <= 0.5


@pytest.mark.parametrize("params", [LABRADORITE, STEEP], ids=["labradorite", "tilted 50 deg"])
def test_the_lamellae_tables_hold_their_optics(params):
    """The tables read as the node group reads them against the lamellae computed per point, 4096 probes, at
    the schiller's highlight (the view mirrored about its closure's normal): a film's limits."""
    plan = plan_effects(params)
    layout, texels = bake(params, plan)
    check = check_tables(params, plan, layout, texels)
    print(params.tilt, check, f"{texels.nbytes / 1024:.0f} KiB")
    assert check.holds, check.why()
    assert texels.nbytes <= 1 << 20


def test_a_tilt_keeps_the_tables_and_the_lamellae_do_not():
    """The tables hold the lamellae's optics over the cosine to their normal: a tilt or its azimuth (the
    geometry, per point) bakes nothing; the period or the crystal's index does."""
    plan = plan_effects(LABRADORITE)
    digest = table_digest(LABRADORITE, plan)
    assert table_digest(LABRADORITE.replace(tilt=30.0, tilt_azimuth=45.0), plan) == digest
    assert table_digest(LABRADORITE.replace(layer_ior=1.57), plan) != digest
    thicker = {**LABRADORITE.stack.to_dict(), "films": [{"ior": 1.559, "thickness_nm": 85.0},
                                                           {"ior": 1.573, "thickness_nm": 85.0}]}
    assert table_digest(LABRADORITE.replace(stack=thicker), plan) != digest


LIT = {"labradorite": LABRADORITE.replace(e0=150.0, e1=200.0),
       "tilted 30, turned": LABRADORITE.replace(e0=150.0, e1=200.0, tilt=30.0, tilt_azimuth=90.0),
       "without lamellae": PLAIN.replace(e0=150.0, e1=200.0)}


@pytest.fixture(scope="module", params=["nodes", "osl"])
def lit(request):
    row = render_row(list(LIT.values()), backend=request.param)
    expected, geo = render_spheres(row.params, row.camera, row.sun, row.centers, thickness=row.passes.thickness,
                                   lower_normals=row.passes.lower_normal, shading=partial(closure_shading))
    return row, expected, geo


@pytest.mark.slow
@pytest.mark.keeps_scene
@pytest.mark.parametrize("name", list(LIT))
def test_lamellae_render_as_their_closure_form(lit, name):
    row, expected, geo = lit
    mask = lit_mask(geo, row.sun.l) & (geo.sphere == list(LIT).index(name))
    ag = agreement(row.passes.beauty, expected, mask, rel_tol=REL_TOL)
    print(f"{name} ({row.backend}): {ag}")
    assert ag.failing_fraction <= MAX_FAILING, str(ag)


@pytest.mark.slow
@pytest.mark.keeps_scene
def test_the_schiller_is_rendered_where_the_lamellae_mirror_the_sun(lit):
    """Against the same crystal without lamellae at the same pixels (its closure form), the lamellae add a blue
    or green schiller of their own, and the render holds it: where they add most, the render adds what the
    closure form says."""
    row, expected, geo = lit
    plain = [PLAIN.replace(e0=150.0, e1=200.0)] + row.params[1:]
    without, _ = render_spheres(plain, row.camera, row.sun, row.centers, thickness=row.passes.thickness,
                                lower_normals=row.passes.lower_normal, shading=partial(closure_shading))
    mask = geo.mask & (geo.sphere == 0)
    added = expected[..., :3] - without[..., :3]
    schiller = mask & (added[..., 2] > 0.5 * added[..., 2][mask].max())
    rendered = (row.passes.beauty[..., :3] - without[..., :3])[schiller].mean(0)
    print(f"{row.backend}: schiller on {schiller.sum()} px, added {added[schiller].mean(0).round(4)}, "
          f"rendered {rendered.round(4)}")
    assert schiller.sum() >= 10 and added[..., 2][mask].max() > 0.01
    mean = added[schiller].mean(0)
    assert mean[0] < 0.3 * mean.max()  # the lamellae's Bragg peak: blue to green, no red
    assert np.abs(rendered - mean).max() < 0.1 * mean.max()


@pytest.mark.slow
@pytest.mark.keeps_scene
@pytest.mark.parametrize("backend", ["nodes", "osl"])
def test_lossless_lamellae_return_what_they_receive(backend):
    """The crystal's top, its lamellae and a clear base in a uniform white world: what the top and the lamellae
    reflect and what they pass add up to what arrives, centre and rim, lamellae tilted 12 and 50 degrees (where
    they reflect most of what reaches them near grazing and the top sends much of it back inside)."""
    clear = LABRADORITE.replace(kd=0.0, base_layer="transparent", base_r=0.0, base_g=0.0, base_b=0.0, e1=600.0)
    rings = {"centre": (0.8, 1.01), "rim": (0.05, 0.3)}
    values = ring_means(render_furnace([clear, STEEP.replace(kd=0.0, base_layer="transparent", e1=600.0)],
                                       backend, 48, 64), ["labradorite", "steep"], rings)
    for key, got in values.items():
        print(backend, key, got.round(4))
        assert np.abs(got - 1.0).max() <= 0.02, (key, got)
