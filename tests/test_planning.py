"""Effect planning: the decision per preset, and that dropping an inactive effect changes
no pixel while dropping an active one does."""
import numpy as np
import pytest

from layered_brdf_addon.model import PRESETS, preset
from layered_brdf_addon.model.plan import EffectPlan
from layered_brdf_addon.model.policy import plan_effects

from constants import MAX_FAILING, REL_TOL
from render_helpers import render_row

EXPECTED = {
    # name: (specular, diffuse, thickness, normals, dispersion, harmonics of the beams in the layer)
    "fig3_old_metal": (False, True, "noise", "parallel", False, False),
    "fig3_thin_film": (False, True, "noise", "parallel", False, False),
    "fig3_clay": (False, True, "noise", "parallel", False, False),
    "fig4_parallel": (True, True, "noise", "parallel", True, False),
    "fig4_tilted": (True, True, "noise", "tilted", True, False),
    "fig5_correlated": (True, False, "noise", "correlated", True, False),
    "fig6_thin": (True, True, "noise", "tilted", True, False),
    "fig6_medium": (True, True, "noise", "tilted", True, False),
    "fig6_thick": (True, True, "noise", "tilted", True, False),
    # Physical films: water, oil, chitin and glass disperse too little to move the lobes apart; every
    # film's rim calls for the beams that bounce in the layer.
    "soap_bubble": (True, False, "height", "parallel", False, True),
    "oil_slick": (True, True, "noise", "parallel", False, True),
    "beetle_shell": (True, True, "noise", "parallel", False, True),
    "anodised_titanium": (True, False, "noise", "parallel", True, True),
    "old_metal": (True, False, "noise", "parallel", True, True),
    "glazed_clay": (True, True, "noise", "parallel", False, True),
    # Film stacks: one lobe of the stack's reflectance, read from tables (no transmitted lobes, no harmonics).
    "jewel_beetle": (True, False, "noise", "parallel", False, False),
    "morpho_blue": (True, False, "noise", "parallel", False, False),
    "nacre": (True, True, "noise", "parallel", False, False),
    "labradorite": (True, True, "noise", "tilted", False, False),
    "dichroic_glass": (True, False, "noise", "parallel", False, False),
    "coated_lens": (True, False, "noise", "parallel", False, False),
}


def test_every_preset_has_an_asserted_plan():
    assert set(EXPECTED) == set(PRESETS)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_planner_decision(name):
    plan = plan_effects(preset(name))
    assert (plan.specular, plan.diffuse, plan.thickness, plan.normals, plan.dispersion,
            plan.multibeam) == EXPECTED[name]
    assert plan.stack == (preset(name).stack is not None) and (plan.tables or not plan.stack)


def test_planner_rules():
    p = preset("fig4_tilted")
    assert plan_effects(p.replace(tilt=0.0)).normals == "parallel"
    assert plan_effects(p.replace(d_min=70.0, d_max=70.0)).thickness == "constant"
    assert plan_effects(p.replace(normal_mode="correlated", d_min=70.0, d_max=70.0)).normals == "parallel"
    assert plan_effects(p.replace(normal_mode="correlated", bump_strength=0.0)).normals == "parallel"
    assert not plan_effects(p.replace(ks=0.0)).specular
    assert not plan_effects(p.replace(kd=0.0)).diffuse
    assert not plan_effects(p.replace(r1_r=1.5, r1_g=1.5, r1_b=1.5)).dispersion


# Pairs rendered with the planned shader and with a shader that also carries an effect
# the parameters make invisible; and one pair where an active effect is dropped.
EQUAL = preset("fig4_tilted").replace(r1_r=1.5, r1_g=1.5, r1_b=1.5, thickness_mode="height", d_min=0.0,
                                      d_max=500.0)
# Computed closures in both of a pair (baked tables are compared with them in test_tables.py).
FLAT = preset("fig4_tilted").replace(tilt=0.0, d_min=120.0, d_max=120.0, evaluation="arithmetic")
DISPERSIVE = preset("fig6_medium").replace(thickness_mode="height", evaluation="arithmetic")


@pytest.fixture(scope="module", params=["nodes", "osl"])
def pairs(request):
    full = EffectPlan.full(thickness="noise", normals="tilted")
    cases = [
        (EQUAL, plan_effects(EQUAL)),
        (EQUAL, EffectPlan(**{**plan_effects(EQUAL).to_dict(), "dispersion": True})),
        (FLAT, plan_effects(FLAT)),
        (FLAT, full),
        (DISPERSIVE, plan_effects(DISPERSIVE)),
        (DISPERSIVE, EffectPlan(**{**plan_effects(DISPERSIVE).to_dict(), "dispersion": False})),
    ]
    row = render_row([c[0] for c in cases], backend=request.param, plans=[c[1] for c in cases], height=48)
    w = row.camera.height
    tiles = [row.passes.beauty[:, k * w:(k + 1) * w] for k in range(len(cases))]
    return tiles


def test_inactive_effects_change_no_pixel(pairs):
    for a, b in ((0, 1), (2, 3)):
        scale = max(pairs[a].max(), 1e-6)
        assert np.max(np.abs(pairs[a] - pairs[b])) <= 1e-4 * scale, (a, b)


def test_dropping_an_active_effect_changes_the_image(pairs):
    diff = np.abs(pairs[4] - pairs[5])
    assert diff.max() > 0.05 * pairs[4].max()


def test_interference_cutoff_constant_matches_its_measurement():
    from layered_brdf_reference import spectral
    from layered_brdf_addon.model.policy import INTERFERENCE_CUTOFF_OPTICAL_NM

    assert spectral.interference_cutoff_optical_nm(1.0) == pytest.approx(INTERFERENCE_CUTOFF_OPTICAL_NM, rel=0.01)


def test_thick_spectral_layers_drop_interference_thin_and_rgb_keep_it():
    thick = preset("soap_bubble").replace(d_min=6000.0, d_max=9000.0)
    assert plan_effects(thick.replace(accuracy="spectral32")).interference is False
    assert plan_effects(thick.replace(accuracy="analytic")).interference is False
    assert plan_effects(thick.replace(accuracy="rgb")).interference is True  # three wavelengths never average out
    assert plan_effects(preset("soap_bubble").replace(accuracy="spectral32")).interference is True
    assert plan_effects(preset("soap_bubble").replace(accuracy="analytic")).interference is True


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["nodes", "osl"])
def test_dropping_averaged_interference_changes_little_and_matches_closure_form(backend):
    """Past the cut-off the band-averaged image without the interference term stays within
    a few per cent of the full spectral shader (the cut-off is 1 CIEDE2000 on colour)."""
    from layered_brdf_reference import closures
    from layered_brdf_addon.model import render_spheres
    from layered_brdf_reference.compare import agreement, lit_mask

    p = preset("glazed_clay").replace(thickness_mode="height", d_min=9000.0, d_max=9500.0, accuracy="spectral32",
                                      r1_r=1.5, r1_g=1.5, r1_b=1.5, e0=20.0, e1=20.0)
    planned = plan_effects(p)
    assert planned.interference is False
    full = EffectPlan(**{**planned.to_dict(), "interference": True})
    row = render_row([p, p], backend=backend, plans=[planned, full], height=48)
    expected, geo = render_spheres([p], row.camera, row.sun, row.centers[:1], shading=closures.closure_shading)
    mask = lit_mask(geo, row.sun.l) & (geo.sphere == 0)
    ag = agreement(row.passes.beauty, expected, mask, rel_tol=REL_TOL)
    assert ag.failing_fraction <= MAX_FAILING, str(ag)
    w = row.camera.height
    a, b = row.passes.beauty[:, :w], row.passes.beauty[:, w:2 * w]
    sel = mask[:, :w]
    assert np.abs(a[sel].mean(0) - b[sel].mean(0)).max() <= 0.03 * b[sel].mean(0).max()
