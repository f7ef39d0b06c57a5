"""Energy-keeping lobes (the physical mode): each closure returns, integrated over the hemisphere,
the share of the light that its lobe carries, at every incidence and roughness.

The paper's lobe ``(e + 2)/(2 pi) cos^e`` about the mirror direction returns about ``cos theta`` of
its amplitude (the light cosine under the integral), and a Beckmann closure loses to shadowing,
masking and the horizon what its microfacets send below it, up to half at Roughness 1.  In the
physical mode a lobe's amplitude is the reflectance it carries (the film's, from thin-film optics)
times its normalised peak ``(e + 2)/(2 pi)``, and a closure's weight is that reflectance divided by
the closure's own directional albedo at unit weight (:func:`closure_albedo`): a Beckmann closure's
from a closed form fitted to Cycles' closure (``layered_brdf_reference/lobe_albedo.py``, baked in
``data/closure_albedo.json``), a Phong closure's from :func:`phong_lobe_albedo`.  Scaling a lobe
by its albedo is the energy compensation of Kulla and Conty (2017) in its simplest form: the lobe
keeps its shape and returns what it carries.
"""
from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np

from .step import shader_function

ALBEDO_PATH = Path(__file__).resolve().parents[1] / "data" / "closure_albedo.json"
ALBEDO_FLOOR = 0.3  # below every albedo of the fitted range (0.46 at Roughness 1, normal view)
INV_2PI = 0.5 / math.pi
GRAZING_LIMIT = 1e3  # the grazing measure alpha tan(theta) is held below this (float32 powers)


@functools.lru_cache(maxsize=None)
def albedo_coefficients() -> tuple[float, ...]:
    """The twelve coefficients of :func:`closure_albedo` (``data/closure_albedo.json``)."""
    return tuple(json.loads(ALBEDO_PATH.read_text())["coefficients"])


def _albedo_form(ops, ax, ay, mu, c):
    """The closed form: ``1 - L_across - L_within``, losses to the lobe's width across the plane of
    the view (``ax``) and within it (``ay``), both fading where the view grazes a rough surface
    (``g = ay tan(theta)``, Beckmann's masking variable), the within loss peaking at moderate ``g``."""
    g = ops.minimum(ay * ops.sqrt(ops.maximum(1.0 - mu * mu, 0.0)) / ops.maximum(mu, 1e-4), GRAZING_LIMIT)
    across = c[0] * ops.power(ops.maximum(ax, 1e-6), c[1]) / (1.0 + c[2] * ops.power(ops.maximum(g, 1e-9), c[3]))
    bump = c[4] * ops.power(ops.maximum(g, 1e-9), c[5]) / (1.0 + c[6] * ops.power(ops.maximum(g, 1e-9), c[7]))
    rough = c[8] * ops.power(ops.maximum(ay, 1e-6), c[9]) / (1.0 + c[10] * ops.power(ops.maximum(g, 1e-9), c[11]))
    return 1.0 - across - bump - rough


def closure_albedo_numpy(ax, ay, mu, coefficients=None):
    """:func:`closure_albedo` on numpy arrays with the given coefficients (the fit's own use)."""
    from .. import ops_numpy  # the numpy backend is not the program's: imported where numpy runs it

    c = albedo_coefficients() if coefficients is None else coefficients
    return np.clip(_albedo_form(ops_numpy, np.asarray(ax, float), np.asarray(ay, float), np.asarray(mu, float), c),
                   ALBEDO_FLOOR, 1.0)


@shader_function
def closure_albedo(ops, a_x, a_y, mu):
    """Directional albedo of Cycles' Beckmann closure at unit weight, seen at cosine ``mu``, with
    alphas ``a_x`` across the plane of the view and the closure normal and ``a_y`` within it (what
    :func:`.lobes.lobe_alphas` gives): a closed form, within 0.035 of the closure (0.023 for alphas
    up to 0.35) over alphas 0.003-1 and cosines 0.01-1."""
    return ops.clamp(_albedo_form(ops, a_x, a_y, mu, albedo_coefficients()), ALBEDO_FLOOR, 1.0)


@shader_function
def phong_lobe_albedo(ops, e, mu):
    """Directional albedo of the paper's lobe ``(e + 2)/(2 pi) cos^e`` about a direction at cosine
    ``mu`` (Cycles' ``phong_ramp`` at unit weight): ``mu`` for a sharp lobe above the horizon, the
    part above it of a lobe that crosses it, ``1/sqrt(2 pi e)`` when its centre lies on it.  A
    Gaussian lobe of width ``s = 1/sqrt(e + 1)`` about an elevation ``b``: ``b P(b/s) + s p(b/s)``,
    the normal distribution written with a logistic (within 1% of it)."""
    s = 1.0 / ops.sqrt(ops.maximum(e, 0.0) + 1.0)
    b = mu
    x = b / s
    cdf = 1.0 / (1.0 + ops.exp(x * -1.702))
    pdf = ops.exp(x * x * -0.5) * (1.0 / math.sqrt(2.0 * math.pi))
    return ops.clamp(b * cdf + s * pdf, 1e-4, 1.0)


# The mean cosine between a view and the microfacet normals it sees (microfacet_cosine): fitted to Beckmann's
# visible normals by quadrature (layered_brdf_reference/lobe_albedo.visible_cosine).
FACET_COEFFICIENTS = (0.8834, 1.1232, 0.3089)


@shader_function
def microfacet_cosine(ops, e, mu):
    """The mean cosine between the view, at cosine ``mu`` to the normal, and the normals of the microfacets
    it sees on a boundary whose lobe has the Phong exponent ``e`` (Beckmann ``alpha^2 = 2 / (4 e + 2)``): the
    angle at which a rough boundary's microfacets reflect on average, less grazing than the view near the
    rim.  ``sqrt(mu^2 + (c0 alpha)^2 (1 - mu^2)^c2) / sqrt(1 + c1 alpha^2)``, within 0.031 of the
    quadrature for alphas up to 0.4, 0.072 up to 1; ``mu`` for a smooth boundary."""
    c0, c1, c2 = FACET_COEFFICIENTS
    a2 = 2.0 / (4.0 * ops.maximum(e, 0.0) + 2.0)
    sin2 = ops.maximum(1.0 - mu * mu, 1e-12)
    spread = ops.power(sin2, c2) * (a2 * (c0 * c0))
    return ops.clamp(ops.sqrt((mu * mu + spread) / (1.0 + c1 * a2)), 0.0, 1.0)


def carried(ops, amplitude, e):
    """The reflectance an energy-keeping lobe of exponent ``e`` carries: its amplitude over its normalised
    peak ``(e + 2)/(2 pi)``."""
    return amplitude / ((e + 2.0) * INV_2PI)


def energy_peak(ops, e, a_x, a_y, mu, *, lobe):
    """The value at its centre (light cosine included) of a closure of unit weight that carries
    unit albedo, per unit of the lobe's normalised peak ``(e + 2)/(2 pi)``: the closure's albedo
    times that peak (the physical mode's :func:`.lobes.lobe_peak`)."""
    albedo = phong_lobe_albedo(ops, e, mu) if lobe == "phong" else closure_albedo(ops, a_x, a_y, mu)
    return albedo * ((e + 2.0) * INV_2PI)
