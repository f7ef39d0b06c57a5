"""The colour of a smooth film's mirror reflection: the add-on's shading program against tmm.

The model side runs the program's amplitude step in numpy on parallel boundaries, with the
reflected, transmitted and interference lobes coinciding at the mirror direction and
normalised to 1 (``ks = 1``, ``(e + 2) / (2 pi) = 1``), so that the lobes integrated about
the mirror direction read as the film's reflectance per RGB channel (linear Rec.709).  The
reference is tmm's unpolarised reflectance spectrum of air | film | below with the media's
measured ``n(lambda)``, ``k(lambda)``, seen under D65 (:mod:`.thin_film`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from layered_brdf_addon.fit.mirror import UNIT_LOBE_EXPONENT, mirror_reflectance
from layered_brdf_addon.model.media import layer_index_values, spectrum
from layered_brdf_addon.model.params import LayeredParams

from . import thin_film

OUTSIDE_INDEX = 1.0  # air above the film
ANGLES_DEG = (0.0, 30.0, 60.0)
ACCURACIES = ("analytic", "rgb")
OPTICS = ("physical", "paper")


@dataclass(frozen=True)
class FilmCase:
    """A film medium on a lower medium over a range of thicknesses (nm)."""

    name: str
    film: str
    below: str
    d_min: float
    d_max: float

    def thicknesses(self, *, step_nm: float | None = None, count: int | None = None) -> np.ndarray:
        """The range sampled every ``step_nm``, or at ``count`` even steps (both ends included)."""
        if count is None:
            count = int(round((self.d_max - self.d_min) / step_nm)) + 1
        return np.linspace(self.d_min, self.d_max, count)


CASES = (
    FilmCase("soap (water on air)", "water", "air", 100.0, 1000.0),
    FilmCase("oil on water", "oil", "water", 100.0, 1000.0),
    FilmCase("chitin on air", "chitin", "air", 100.0, 1000.0),
    FilmCase("TiO2 on titanium", "tio2_amorphous", "titanium", 20.0, 300.0),
    FilmCase("TiO2 on aluminium", "tio2_amorphous", "aluminium", 20.0, 300.0),
)


def film_params(film: str, below: str, thickness_nm, optics: str = "physical",
                accuracy: str = "analytic") -> LayeredParams:
    """The material of a smooth film of ``film`` on ``below`` over the given thicknesses."""
    d = np.asarray(thickness_nm, dtype=float)
    return LayeredParams.from_dict(dict(
        layer_index_values(film), optics=optics, lower_medium=below, accuracy=accuracy, r0=OUTSIDE_INDEX,
        ks=1.0, e0=UNIT_LOBE_EXPONENT, e1=UNIT_LOBE_EXPONENT, d_min=float(d.min()), d_max=float(d.max()),
        normal_mode="parallel"))


def model_film_rgb(film: str, below: str, thickness_nm, theta_deg: float, optics: str = "physical",
                   accuracy: str = "analytic") -> np.ndarray:
    """The model's reflectance of the smooth film, linear Rec.709, one row per thickness
    (:func:`layered_brdf_addon.fit.mirror.mirror_reflectance`)."""
    p = film_params(film, below, thickness_nm, optics, accuracy)
    return mirror_reflectance(p, theta_deg, np.atleast_1d(np.asarray(thickness_nm, dtype=float)))


def rgb_to_lab(rgb) -> np.ndarray:
    """Lab (D65) of linear Rec.709 RGB (last axis)."""
    return thin_film.xyz_to_lab(thin_film.linear_rec709_to_xyz(rgb))


def complex_index(name: str, wavelengths_nm) -> np.ndarray:
    """``n + 1j k`` of a medium at the given wavelengths (the table's 10 nm samples interpolated)."""
    n, k = spectrum(name, wavelengths_nm)
    return np.asarray(n) + 1j * np.asarray(k)


def reference_film_lab(film: str, below: str, thickness_nm, theta_deg: float,
                       wavelengths_nm=thin_film.WAVELENGTHS_NM) -> np.ndarray:
    """Lab (D65) of tmm's reflectance spectrum of air | film | below, one row per thickness."""
    lams = np.asarray(wavelengths_nm, dtype=float)
    return thin_film.film_lab(OUTSIDE_INDEX, complex_index(film, lams), complex_index(below, lams),
                              np.atleast_1d(thickness_nm), theta_deg, lams)


def film_errors(film: str, below: str, thickness_nm, theta_deg: float, optics: str = "physical",
                accuracy: str = "analytic", reference_lab=None) -> np.ndarray:
    """CIEDE2000 between the model's and tmm's colour of the film, one per thickness;
    ``reference_lab``: :func:`reference_film_lab` of the same arguments, where already known."""
    if reference_lab is None:
        reference_lab = reference_film_lab(film, below, thickness_nm, theta_deg)
    model = rgb_to_lab(model_film_rgb(film, below, thickness_nm, theta_deg, optics, accuracy))
    return thin_film.delta_e_2000(model, reference_lab)


# --------------------------------------------------------------------------
# What the lobes return: the BRDF integrated over the hemisphere at one incidence.
ALBEDO_ANGLES_DEG = (0.0, 30.0, 60.0, 80.0)
ALBEDO_ROUGHNESS = 0.1  # the films' Roughness (Beckmann alpha 0.01): a smooth film
FORMS = ("closures", "exact")


def conformal_film(film: str, below: str, thickness_nm, roughness: float = ALBEDO_ROUGHNESS,
                   accuracy: str = "analytic") -> LayeredParams:
    """A film of ``film`` on ``below`` whose two boundaries are equally rough seen from outside (the
    paper's in-layer lobe is ``r1^2`` times narrower: ``e1 = e0 r1^2``), parallel, of Roughness
    ``roughness`` (``e0 = (Roughness^-4 - 1) / 2``), no diffuse part."""
    p = film_params(film, below, thickness_nm, "physical", accuracy)
    e0 = (roughness ** -4 - 1.0) / 2.0
    return p.replace(e0=e0, e1=e0 * p.r1[1] ** 2, kd=0.0)


def _exact_outgoing(params, n0, n1, d, o, light):
    """``f(i, o) <n0, o>`` with the light arriving from ``light`` (its direction, away from the surface):
    integrated over the sampled ``o``, the exact model's directional albedo at that incidence."""
    from layered_brdf_addon.model.geometry import dot

    from .exact_model import layered_brdf

    f = layered_brdf(-light, o, n0, n1, d, params, ng=n0)
    return np.maximum(dot(n0, o), 0.0)[..., None] * f


def directional_albedo(film: str, below: str, thickness_nm, theta_deg: float, form: str = "closures",
                       roughness: float = ALBEDO_ROUGHNESS, samples: int = 16384, seed: int = 1) -> np.ndarray:
    """The conformal film's directional albedo at ``theta_deg`` (linear Rec.709, one row per thickness):
    ``form="closures"``: the closures the shaders return (:mod:`.closures`, Cycles' own evaluation),
    integrated over the light's directions for the view at ``theta_deg`` (what a white furnace renders);
    ``"exact"``: the exact model integrated over the outgoing directions for light from ``theta_deg``.
    Monte Carlo (:func:`.lighting.environment_shading`), the same samples for every thickness."""
    from .closures import closure_shading
    from .lighting import environment_shading

    d = np.atleast_1d(np.asarray(thickness_nm, dtype=float))
    p = conformal_film(film, below, d, roughness)
    n = np.tile([0.0, 0.0, 1.0], (d.size, 1))
    t = math.radians(theta_deg)
    v = np.array([math.sin(t), 0.0, math.cos(t)])
    shading = closure_shading if form == "closures" else _exact_outgoing
    return environment_shading(p, n, n, d, v, samples=samples, seed=seed, shading=shading)
