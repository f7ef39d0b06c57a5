"""The structural colours look like their names under each of Blender's five bundled HDRIs of the docs: hues,
saturation, brightness and a mirror-like reflection where claimed, on spheres (layered_brdf_reference/
look_bounds.py holds the bounds, STACK_LOOKS)."""
from __future__ import annotations

import pytest

from layered_brdf_addon.model.presets import STACK_PRESETS, preset
from layered_brdf_reference.look_bounds import STACK_LOOKS, failures

from test_looks import measure_rows

pytestmark = pytest.mark.slow

HDRIS = ("forest", "courtyard", "interior", "sunset", "city")
ROWS = [(name, preset(name)) for name in STACK_PRESETS]


@pytest.fixture(scope="module")
def looks():
    return {hdri: measure_rows(hdri, ROWS)[0] for hdri in HDRIS}


def test_every_structural_preset_has_a_look():
    assert set(STACK_LOOKS) == set(STACK_PRESETS)


# The coated lens has no colour of its own to hold: its look is its weaker highlight (below).
COLOURED = [name for name in STACK_PRESETS if name != "coated_lens"]


@pytest.mark.keeps_scene
@pytest.mark.parametrize("hdri", HDRIS)
@pytest.mark.parametrize("name", COLOURED)
def test_a_structural_colour_looks_like_its_name(looks, name, hdri):
    stats = looks[hdri][name]
    print(f"{name} under {hdri}: {stats}")
    assert failures(name, stats) == [], f"{name} should read as {STACK_LOOKS[name].description} under {hdri}"


def test_a_coated_lens_reflects_less_than_bare_glass_in_its_highlight():
    """The lens's look is what it does not reflect: under a sun, its highlight (the sun's reflection, a
    rendered peak no background reaches) is a third of bare glass's (1.3% of the light reflected at 550 nm
    against 4.3%)."""
    from layered_brdf_addon.model.sphere import sphere_geometry
    from render_helpers import render_row

    lens = preset("coated_lens").replace(e0=300.0)
    row = render_row([lens, lens.replace(stack=None, d_min=0.0, d_max=0.0)], height=48, samples=4)
    geo = sphere_geometry(row.camera, row.centers)
    peaks = [float(row.passes.beauty[geo.mask & (geo.sphere == k)][:, :3].sum(-1).max()) for k in range(2)]
    print(f"highlight: coated {peaks[0]:.4f}, bare {peaks[1]:.4f}")
    assert peaks[0] < 0.6 * peaks[1]
