"""The exact model on the reference scene's spheres: the ``shading`` of
:func:`layered_brdf_addon.model.sphere.render_spheres` that the closure form is measured against."""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.model.geometry import dot
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams

from .exact_model import layered_brdf


def exact_shading(params: LayeredParams, n0, n1, d, l, v, wavelengths=WAVELENGTHS_NM):
    """Outgoing radiance per unit sun irradiance: ``<l, n0> (ks rho + kd base rho_d / pi)``."""
    cos_l = np.maximum(dot(n0, l), 0.0)
    i = np.broadcast_to(-np.asarray(l), np.shape(n0))
    o = np.broadcast_to(np.asarray(v), np.shape(n0))
    return cos_l[..., None] * layered_brdf(i, o, n0, n1, d, params, ng=n0, wavelengths=wavelengths)
