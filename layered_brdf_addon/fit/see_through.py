"""A transparent base layer (``base_layer="transparent"``, a soap film) on the reference sphere:
what the camera sees through the film.

The add-on puts a Transparent BSDF in the Base Shader input, weighted by the program's
``base_weight`` (what the film neither reflects nor absorbs: eq. of
:func:`~..model.program.film_transmittance`, or ``1 - F(v)`` under the paper's optics).  A
camera ray passes it unbent, meets the far side of the sphere from inside (where Cycles turns
the normal towards the ray, so the film there is shaded as seen from the camera, the same
view direction) and passes again to the world.  The pixel is

    front closures + w_front (back closures + w_back background(-v)).

The light that the far side reflects back into the sphere and out again through the front is
left out (the film reflects a few percent: under a tenth of a percent of the pixel).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..model import ops_numpy, program
from ..model.params import LayeredParams
from ..model.plan import EffectPlan
from .cycles_closures import program_inputs


def base_shader_weight(params: LayeredParams | Mapping, n0: np.ndarray, v: np.ndarray,
                       plan: EffectPlan) -> np.ndarray:
    """The Base Shader's factor (P,) at normals ``n0`` seen from ``v``: the shading program's
    own formulas, chosen as its layered surface chooses them.  ``params`` may be the values
    of a stack of parameter sets (:func:`.cycles_closures.stacked_values`): (K, P) then."""
    if plan.optics == "physical" and not plan.passes:
        return np.zeros(n0.shape[:-1])
    inputs = program_inputs(params)
    cos_v = np.clip(np.sum(n0 * v, axis=-1), 0.0, 1.0)
    if plan.optics == "physical":
        w = program.film_transmittance(ops_numpy, ops_numpy.combine(*inputs["r1"]), inputs["r0"],
                                       ops_numpy.combine(*inputs["r2"]), ops_numpy.combine(*inputs["k2"]),
                                       inputs["kd"], cos_v, orders=program.harmonic_count(plan))
    else:
        w = program.base_weight(ops_numpy, inputs["r1"], inputs["r0"], cos_v)
    w = np.asarray(w, dtype=float)
    return np.broadcast_to(w, np.broadcast_shapes(w.shape, n0.shape[:-1]))


def far_side(n0: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a camera ray entering a unit sphere at normal ``n0`` (the point relative to the
    centre) along ``-v`` leaves it: that point (object space), and the normal Cycles shades it
    with (turned towards the ray: into the sphere)."""
    t = 2.0 * np.sum(n0 * v, axis=-1, keepdims=True)
    exit_point = n0 - t * v
    return exit_point, -exit_point


def see_through(params: LayeredParams | Mapping, plan: EffectPlan, n0, v, far, background) -> np.ndarray:
    """What a transparent base adds to the front's pixels (P, 3): ``far`` (P, 3) is the film
    shaded at the far side (:func:`far_side`: normals facing the ray, seen along the same
    view), ``background`` (3,) the world straight behind.  For the values of a stack of
    parameter sets (:func:`base_shader_weight`), ``far`` and the result are (K, P, 3)."""
    v = np.broadcast_to(v, n0.shape)
    w_front = base_shader_weight(params, n0, v, plan)
    w_back = base_shader_weight(params, far_side(n0, v)[1], v, plan)
    return w_front[..., None] * (far + w_back[..., None] * np.asarray(background))
