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
BARE = "coated_lens"  # measured as the lens's look too: the same glass without its coating
ROWS = [(name, preset(name)) for name in STACK_PRESETS] + \
       [(BARE, preset("coated_lens").replace(stack=None, d_min=0.0, d_max=0.0))]


@pytest.fixture(scope="module")
def looks():
    out = {}
    for hdri in HDRIS:
        stats, _ = measure_rows(hdri, ROWS[:-1])
        stats["bare glass"] = measure_rows(hdri, ROWS[-1:])[0][BARE]
        out[hdri] = stats
    return out


def test_every_structural_preset_has_a_look():
    assert set(STACK_LOOKS) == set(STACK_PRESETS)


@pytest.mark.keeps_scene
@pytest.mark.parametrize("hdri", HDRIS)
@pytest.mark.parametrize("name", list(STACK_PRESETS))
def test_a_structural_colour_looks_like_its_name(looks, name, hdri):
    stats = looks[hdri][name]
    print(f"{name} under {hdri}: {stats}")
    assert failures(name, stats) == [], f"{name} should read as {STACK_LOOKS[name].description} under {hdri}"


@pytest.mark.keeps_scene
@pytest.mark.parametrize("hdri", HDRIS)
def test_a_coated_lens_reflects_less_than_bare_glass(looks, hdri):
    coated, bare = looks[hdri]["coated_lens"], looks[hdri]["bare glass"]
    print(f"{hdri}: mirror correlation coated {coated.reflects:.3f}, bare {bare.reflects:.3f}")
    assert coated.reflects < bare.reflects
