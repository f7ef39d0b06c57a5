"""The closure form: the layered BRDF as Cycles closures with view-dependent weights.

Neither an OSL shader nor a node group sees the light direction.  They can only
return a weighted sum of built-in closures (glossy lobes with a normal of their
own, a diffuse lobe), the weights computed from the view direction ``v``.  This
module is the numpy twin of what ``osl/layered_brdf.osl`` and the node group
compute, so a render can be predicted pixel by pixel, and the distance of the
closure form from the exact ``rho(i, o)`` measured (docs/closure-decomposition.md).

Per channel ``c`` and shading point, with ``r_v`` the mirror of ``v`` about ``n0``:

* **reflected lobe** about ``r_v`` (closure normal ``n0``), exponent ``e0``,
  amplitude ``A_R = ks F(v) (e0 + 2)/(2 pi)``;
* **transmitted lobe** about ``l*_c``, the light direction whose path through the
  layer (refract at ``n0``, mirror at ``n1``, refract out) leaves along ``v``
  (closure normal ``normalize(v + l*_c)``), exponent ``e1 / r1^2`` (the in-layer
  lobe seen from outside), amplitude ``A_T = ks (1 - F(l*)) Tc(t_o) (e1 + 2)/(2 pi r1^2)``;
* **interference lobe** ``2 cos(2 Phi) sqrt(R T)``: the geometric mean of two
  Phong lobes is a Phong lobe of exponent ``(e0 + e1')/2`` about the weighted
  centre ``normalize(e0 r_v + e1' l*)``, amplitude
  ``2 cos(2 Phi) sqrt(A_R A_T) exp(-e0 e1' delta^2 / (4 (e0 + e1')))``, with
  ``delta`` the angle between the two centres and ``Phi`` eq. 3 at that centre.

The interference lobe is folded into the other two (Cycles clamps negative closure
weights to 0, so destructive interference cannot be a closure; constructive
interference is folded too, a closure fewer per channel): the non-negative
least-squares fit of the three lobes by the reflected and transmitted lobes
(Gaussian approximation of the lobes in the tangent plane).

Each amplitude is the pixel value per unit irradiance at the lobe's centre, and is
turned into a closure weight by dividing by that closure's own value there
(Beckmann: ``D / (4 cos (1 + 2 Lambda))``; Phong: ``cos (e + 2)/(2 pi)``).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ..model import ops_numpy, program
from ..model.closure_light import (  # noqa: F401 (Cycles' closures on numpy, moved to the model: its users')
    CLOSURE_WEIGHT_CUTOFF, INV_2PI, _lambda_from, beckmann_eval, beckmann_lambda, ensure_valid_specular_reflection,
    evaluate_closures, glossy_alphas, phong_peak, phong_ramp_eval)
from ..model.params import WAVELENGTHS_NM, LayeredParams
from ..model.plan import EffectPlan
from ..model.policy import plan_effects
from ..model.shading.lamella_shade import lamella_geometry, lamella_shade, response_optics
from ..model.shading.stack_shade import stack_shade
from ..model.stack_optics import StackResponse


def parameter_values(params: LayeredParams | Mapping) -> dict:
    """The per-parameter values the program reads: a :class:`LayeredParams`'s, or a mapping
    of them as it is (:func:`stacked_values`)."""
    return dict(params) if isinstance(params, Mapping) else params.to_dict()


def program_inputs(params: LayeredParams | Mapping) -> dict:
    return program.program_inputs(parameter_values(params))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def stack_key(params: LayeredParams) -> tuple:
    """What the parameter sets of one stack share (:func:`stacked_values`): their
    :class:`EffectPlan` (the program's control flow) and every value that is not a number (a
    mode, a named medium, the base layer), which a column cannot hold."""
    return plan_effects(params), tuple((k, v) for k, v in params.to_dict().items() if not _is_number(v))


def stacked_values(params_list: Sequence[LayeredParams]) -> dict:
    """The values of ``K`` parameter sets for one run of the program: a value the sets share
    stays a number, one that differs becomes a column (K, 1), which broadcasts against the
    per-point arrays (N,) and (N, 3).  Every result of the run then has a leading axis K:
    one run shades every set, where a run per set would repeat the Python work of the
    program's many small steps K times.  The sets must share one :func:`stack_key`."""
    dicts = [p.to_dict() for p in params_list]
    out = {}
    for name, value in dicts[0].items():
        values = [d[name] for d in dicts]
        differ = values.count(value) < len(values)
        out[name] = np.array(values, dtype=float)[:, None] if _is_number(value) and differ else value
    return out


def points_shape(n0, n1, d, v, params=None) -> tuple:
    """The shape of the shading points, the vector axis left out: that of ``n0``, grown by
    whatever the thickness, lower normal, view or the columns of stacked ``params`` add (a
    stack's leading axis: a stack that differs only in the layer's index leaves the geometry
    without it)."""
    columns = [np.shape(x) for x in params.values() if isinstance(x, np.ndarray)] \
        if isinstance(params, Mapping) else []
    return np.broadcast_shapes(np.shape(n0)[:-1], np.shape(n1)[:-1], np.shape(d), np.shape(v)[:-1], *columns)


def shade_closures(params: LayeredParams | Mapping, n0, n1, d, v, plan: EffectPlan | None = None,
                   wavelengths=WAVELENGTHS_NM):
    """Run the shading program on numpy arrays: the closures the shaders return.

    ``params``: a :class:`LayeredParams`, or the values of a stack of them
    (:func:`stacked_values`, with their ``plan``)."""
    shape = points_shape(n0, n1, d, v, params)
    n0 = np.broadcast_to(np.asarray(n0, dtype=float), shape + (3,))
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    d = np.broadcast_to(np.asarray(d, dtype=float), shape)
    plan = plan or plan_effects(params)
    if plan.stack:  # a film stack's one lobe, or tilted lamellae's, from its optics (the shaders read tables)
        values = {k: v for k, v in params.to_dict().items() if isinstance(v, float)}
        response = StackResponse.of(params)
        if plan.normals == "tilted":
            n1 = np.broadcast_to(np.asarray(n1, dtype=float), n0.shape)
            geo = lamella_geometry(ops_numpy, plan, values, ops_numpy.vec(n0), ops_numpy.vec(n1), ops_numpy.vec(v))
            return lamella_shade(ops_numpy, plan, values, geo, *response_optics(response, d))
        return stack_shade(ops_numpy, plan, values, ops_numpy.vec(n0), ops_numpy.vec(v), d, response)
    return program.shade(ops_numpy, program_inputs(params), ops_numpy.vec(n0), ops_numpy.vec(n1), d,
                         ops_numpy.vec(v), plan, wavelengths)


def closure_shading(params: LayeredParams | Mapping, n0, n1, d, l, v, wavelengths=WAVELENGTHS_NM, ng=None,
                    plan: EffectPlan | None = None):
    """What the shaders render per unit sun irradiance (same signature as
    ``layered_brdf_reference.exact_spheres.exact_shading``).

    ``params`` may be the values of a stack of parameter sets (:func:`stacked_values`, with
    their ``plan``): the result then has the stack's leading axis."""
    plan = plan or plan_effects(params)
    n0 = np.broadcast_to(np.asarray(n0, dtype=float), points_shape(n0, n1, d, v, params) + (3,))
    res = shade_closures(params, n0, n1, d, v, plan, wavelengths)
    return evaluate_closures(res, n0, v, l, plan.lobe, ng)
