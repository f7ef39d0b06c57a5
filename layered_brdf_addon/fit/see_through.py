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

import numpy as np

from ..model import ops_numpy, program
from ..model.params import LayeredParams
from ..model.plan import EffectPlan


def base_shader_weight(params: LayeredParams, n0: np.ndarray, v: np.ndarray, plan: EffectPlan) -> np.ndarray:
    """The Base Shader's factor (P,) at normals ``n0`` seen from ``v``: the shading program's
    own formulas, chosen as its layered surface chooses them."""
    if plan.optics == "physical" and not plan.passes:
        return np.zeros(n0.shape[:-1])
    inputs = program.program_inputs(params.to_dict())
    cos_v = np.clip(np.sum(n0 * v, axis=-1), 0.0, 1.0)
    if plan.optics == "physical":
        w = program.film_transmittance(ops_numpy, ops_numpy.combine(*inputs["r1"]), inputs["r0"],
                                       ops_numpy.combine(*inputs["r2"]), ops_numpy.combine(*inputs["k2"]),
                                       inputs["kd"], cos_v, orders=program.harmonic_count(plan))
    else:
        w = program.base_weight(ops_numpy, inputs["r1"], inputs["r0"], cos_v)
    return np.broadcast_to(np.asarray(w, dtype=float), n0.shape[:-1])


def far_side(n0: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a camera ray entering a unit sphere at normal ``n0`` (the point relative to the
    centre) along ``-v`` leaves it: that point (object space), and the normal Cycles shades it
    with (turned towards the ray: into the sphere)."""
    t = 2.0 * np.sum(n0 * v, axis=-1, keepdims=True)
    exit_point = n0 - t * v
    return exit_point, -exit_point


def see_through(params: LayeredParams, plan: EffectPlan, n0, v, shade_side, background) -> np.ndarray:
    """What a transparent base adds to the front's pixels (P, 3): ``shade_side(n0, p_object)``
    shades the film at the far side (normals facing the ray), ``background`` (3,) is the world
    straight behind."""
    v = np.broadcast_to(v, n0.shape)
    w_front = base_shader_weight(params, n0, v, plan)
    p_far, n_far = far_side(n0, v)
    w_back = base_shader_weight(params, n_far, v, plan)
    return w_front[:, None] * (shade_side(n_far, p_far) + w_back[:, None] * np.asarray(background)[None, :])
