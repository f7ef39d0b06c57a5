"""A clear soap film vanishes in a white furnace: rendered by Cycles, the film's reflection and what it
passes to its clear base add up to the light it receives, from the centre to the rim, in the node group
(baked tables and computed per point) and the OSL shader (docs/energy.md)."""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.model.presets import preset

pytestmark = pytest.mark.slow

HEIGHT = 48
SAMPLES = 64
RINGS = {"centre": (0.8, 1.01), "rim": (0.05, 0.3)}  # view cosines
TOL = 0.03  # the goal 0.02 and the render's noise at 64 samples (a ring's mean)

SOAP = preset("soap_bubble")
FILMS = {
    "soap bubble": SOAP,
    "soap 250 nm": SOAP.replace(d_min=250.0, d_max=250.0, e0=8e4, e1=1e5),
    "soap 500 nm": SOAP.replace(d_min=500.0, d_max=500.0, e0=8e4, e1=1e5),
    "soap 500 nm, computed": SOAP.replace(d_min=500.0, d_max=500.0, evaluation="arithmetic"),
}


def furnace(backend: str) -> dict:
    from render_helpers import render_furnace, ring_means

    return ring_means(render_furnace(list(FILMS.values()), backend, HEIGHT, SAMPLES), FILMS, RINGS)


@pytest.fixture(scope="module", params=["nodes", "osl"])
def rendered(request):
    return request.param, furnace(request.param)


@pytest.mark.keeps_scene
@pytest.mark.parametrize("ring", list(RINGS))
@pytest.mark.parametrize("name", list(FILMS))
def test_a_clear_soap_film_returns_what_it_receives(rendered, name, ring):
    backend, values = rendered
    got = values[(name, ring)]
    print(f"{backend}: {name}, {ring}: {got.round(4)}")
    assert np.abs(got - 1.0).max() <= TOL
