"""The closure form stays close to its exact model under an HDRI: every artist preset on a
sphere lit by Blender's bundled forest HDRI, Monte Carlo over the environment with the same
light directions for both (layered_brdf_reference/hdri_accuracy.py)."""
from __future__ import annotations

import pytest

from layered_brdf_addon.model.presets import ARTIST_PRESETS, preset
from layered_brdf_reference.hdri_accuracy import closure_error

pytestmark = pytest.mark.slow

HDRI = "forest"
L1_LIMIT = 0.05  # relative L1 of the closure form against the exact model, per preset


@pytest.mark.parametrize("name", list(ARTIST_PRESETS))
def test_closure_form_is_close_to_the_exact_model_under_an_hdri(name):
    err = closure_error(preset(name), HDRI)
    print(f"{name}: L1 {err['l1']:.3f}, exact {err['exact'].round(4)}, closure {err['closure'].round(4)}")
    assert err["l1"] <= L1_LIMIT


def test_the_check_sees_a_wrong_closure_form():
    """A transmitted lobe five times wider seen from outside (e1 / 5) moves the closure form
    and the exact model apart differently: the check fails it."""
    from layered_brdf_reference import hdri_accuracy as H

    p = preset("anodised_titanium")
    assert closure_error(p.replace(e1=p.e1 / 25.0), HDRI)["l1"] > L1_LIMIT
    assert H.SAMPLES >= 128
