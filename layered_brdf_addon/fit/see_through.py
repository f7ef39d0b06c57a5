"""A transparent base layer (``base_layer="transparent"``, a soap film) on the reference sphere:
what the camera sees through the film.

The add-on adds a Transparent BSDF tinted by the shader's Transmittance, what the film passes per
channel (what it neither reflects nor absorbs at that point and incidence, the program's
``passed_to_base``; ``1 - F(v)`` under the paper's optics).  A camera ray passes it unbent, meets
the far side of the sphere from inside (where Cycles turns the normal towards the ray, so the
film there is shaded as seen from the camera, the same view direction) and passes again to the
world.  The pixel is

    front closures + t_front (back closures + t_back background(-v)).

The light that the far side reflects back into the sphere and out again through the front is
left out (the film reflects a few percent: under a tenth of a percent of the pixel).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..model import ops_numpy
from ..model.shading.base_shader import passed_at
from ..model.params import LayeredParams
from ..model.plan import EffectPlan
from .cycles_closures import program_inputs


def base_transmittance(params: LayeredParams | Mapping, result, n0: np.ndarray, v: np.ndarray,
                       plan: EffectPlan) -> np.ndarray:
    """What passes to a clear base per channel (..., 3), from the program's ``result`` at normals ``n0``
    seen from ``v`` (:func:`.cycles_closures.shade_closures`): the shading program's own formula.
    ``params`` may be the values of a stack of parameter sets (:func:`.cycles_closures.stacked_values`)."""
    cos_v = np.clip(np.sum(np.asarray(n0) * np.asarray(v), axis=-1), 0.0, 1.0)
    _, passed = passed_at(ops_numpy, plan, program_inputs(params), cos_v, result.extras.get("reflected"))
    passed = np.asarray(passed, dtype=float)
    return np.broadcast_to(passed, np.broadcast_shapes(passed.shape, np.shape(n0)))


def far_side(n0: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a camera ray entering a unit sphere at normal ``n0`` (the point relative to the
    centre) along ``-v`` leaves it: that point (object space), and the normal Cycles shades it
    with (turned towards the ray: into the sphere)."""
    t = 2.0 * np.sum(n0 * v, axis=-1, keepdims=True)
    exit_point = n0 - t * v
    return exit_point, -exit_point


def see_through(front, back, far, background) -> np.ndarray:
    """What a transparent base adds to the front's pixels (..., 3): ``front`` and ``back`` are what the
    film passes per channel where the ray enters and where it leaves (:func:`base_transmittance`),
    ``far`` the film shaded at the far side (:func:`far_side`: normals facing the ray, seen along the
    same view), ``background`` (3,) the world straight behind."""
    return front * (far + back * np.asarray(background))
