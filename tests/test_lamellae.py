"""Tilted lamellae in a crystal (labradorite's schiller, model/shading/lamella_shade.py): their optics against
tmm seen from inside the crystal, their domains against tmm's incoherent layers, their tables against the
optics computed per point, the node group and the OSL shader against the closure form pixel by pixel (the
schiller where the lamellae mirror the sun), lossless lamellae in a white furnace, and tables that a tilt does
not rebake (its azimuth)."""
from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from layered_brdf_addon.fit.cycles_closures import closure_shading
from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_addon.model.errors import ParameterError
from layered_brdf_addon.model.stack import FilmStack
from layered_brdf_addon.model.stack_optics import film_index, stack_spectra
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


def _inc_tmm(stack: FilmStack, host: float, lower: complex, theta: float, lam: float):
    """tmm's incoherent sum of ``stack.domains`` coherent copies of the films, 0.1 mm of the crystal between
    them (``tmm.inc_tmm``: the crystal's layers incoherent), over ``lower``; unpolarised ``(R, T)``."""
    import tmm

    films = [complex(film_index(f, [lam])[0]) for f in stack.layers]
    thick = [f.thickness_nm for f in stack.layers]
    n, d, c = [host], [np.inf], ["i"]
    for k in range(stack.domains):
        n, d, c = n + films, d + thick, c + ["c"] * len(films)
        if k < stack.domains - 1:
            n, d, c = n + [host], d + [1.0e5], c + ["i"]
    n, d, c = n + [lower], d + [np.inf], c + ["i"]
    out = [tmm.inc_tmm(pol, n, d, c, np.radians(theta), lam) for pol in "sp"]
    return 0.5 * (out[0]["R"] + out[1]["R"]), 0.5 * (out[0]["T"] + out[1]["T"])


# A strong contrast (polarising at an angle: the domains add their light per polarisation).
STRONG = {"kind": "periodic", "periods": 4, "films": [{"ior": 1.3, "thickness_nm": 100.0},
                                                      {"ior": 2.0, "thickness_nm": 65.0}]}


@pytest.mark.parametrize("domains", [2, 5, 16])
@pytest.mark.parametrize("lower", [1.566, 1.45 + 0.0j], ids=["in the crystal", "over glass"])
@pytest.mark.parametrize("films", [LABRADORITE.stack.to_dict(), STRONG], ids=["labradorite", "strong contrast"])
def test_domains_add_their_light_as_tmm_incoherent_layers_say(domains, lower, films):
    """Domains of a stack one under the other (a tenth of a millimetre of crystal between them: no phase
    survives) against tmm's incoherent layers, at labradorite's Bragg peak and off it, 0-50 degrees inside the
    crystal: per wavelength within the single-precision sum's 1e-4."""
    stack = FilmStack.from_dict({**films, "domains": domains})
    lams = np.array([420.0, 480.0, 500.0, 520.0, 640.0])
    for theta in (0.0, 30.0, 50.0):
        R, T = stack_spectra(stack, 1.566, np.full(lams.shape, complex(lower)), np.cos(np.radians(theta)), 1.0, lams)
        ref = np.array([_inc_tmm(stack, 1.566, complex(lower), theta, lam) for lam in lams]).T
        print(domains, lower, theta, np.round(R, 4), np.round(ref[0], 4))
        assert np.abs(R - ref[0]).max() <= 1e-4 and np.abs(T - ref[1]).max() <= 1e-4


def test_domains_make_the_schiller_brighter_and_only_lamellae_have_them():
    """Sixteen domains of labradorite's 64 lamellae (the preset's) reflect several times what one does at its
    Bragg peak; a
    stack whose films lie parallel to the top has no crystal around it to hold domains: refused, naming them."""
    lams = np.arange(480.0, 520.0, 0.5)
    one, many = (np.max(stack_spectra(FilmStack.from_dict({**LABRADORITE.stack.to_dict(), "domains": n}), 1.566,
                                      np.full(lams.shape, 1.566 + 0j), 1.0, 1.0, lams)[0]) for n in (1, 16))
    print(f"Bragg peak: one domain {one:.3f}, 16 domains {many:.3f}")
    assert many > 5.0 * one
    with pytest.raises(ParameterError) as e:
        preset("jewel_beetle").replace(stack={**preset("jewel_beetle").stack.to_dict(), "domains": 4})
    assert e.value.name == "stack.domains" and "tilted" in str(e.value)
    for bad in (0, 2.5, -1, 5000, True, "4"):
        with pytest.raises(ParameterError) as e:
            FilmStack.from_dict({**LABRADORITE.stack.to_dict(), "domains": bad})
        assert e.value.name == "stack.domains" and "[1, 4096]" in str(e.value)


@pytest.mark.parametrize("params", [LABRADORITE, STEEP], ids=["labradorite", "tilted 50 deg"])
def test_the_lamellae_tables_hold_their_optics(params):
    """The tables read as the node group reads them against the lamellae computed per point, 4096 probes, at
    the schiller's highlight (the view mirrored about its closure's normal): a tilted film's limits."""
    plan = plan_effects(params)
    layout, texels = bake(params, plan)
    check = check_tables(params, plan, layout, texels)
    print(params.tilt, check, f"{texels.nbytes / 1024:.0f} KiB")
    assert check.holds, check.why()
    assert texels.nbytes <= 1 << 20


def test_the_azimuth_keeps_the_tables_and_the_tilt_and_lamellae_do_not():
    """The tables hold the lamellae's optics over the cosine to them and the geometry over the view's angle and
    azimuth from them: the tilt's azimuth (which turns the lamellae point by point) bakes nothing; the tilt,
    the period or the crystal's index does."""
    plan = plan_effects(LABRADORITE)
    digest = table_digest(LABRADORITE, plan)
    assert table_digest(LABRADORITE.replace(tilt_azimuth=45.0), plan) == digest
    assert table_digest(LABRADORITE.replace(tilt=30.0), plan) != digest
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
