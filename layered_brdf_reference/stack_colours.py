"""The colour of a film stack's mirror reflection: the add-on's stack optics against tmm.

The reference is tmm's coherent transfer matrices (``tmm.coh_tmm``, both polarisations averaged) for
air | films | lower medium at 1 nm over 380-780 nm, seen under D65 with the CIE 1931 observer
(:mod:`.thin_film`); a disordered stack is averaged over the same draws of its films' thicknesses
(:func:`layered_brdf_addon.model.stack_optics.disorder_draws`), so that the comparison measures the
optics and their colour, not two samplings of the disorder.  The model side is
:func:`layered_brdf_addon.model.stack_optics.stack_colour` (linear Rec.709, out of gamut kept).
"""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.model.media import spectrum
from layered_brdf_addon.model.stack import FilmStack
from layered_brdf_addon.model.stack_optics import (StackResponse, disorder_draws, film_index, lower_index,
                                                   stack_colour)

from . import thin_film
from .film_colours import rgb_to_lab

REFERENCE_NM = np.arange(380.0, 781.0, 1.0)


def tmm_spectrum(stack: FilmStack, n0: float, lower, theta_deg: float, scale: float = 1.0,
                 wavelengths=REFERENCE_NM) -> tuple[np.ndarray, np.ndarray]:
    """tmm's unpolarised ``(R, T)`` of ``stack`` scaled by ``scale`` over a lower medium of complex index
    ``lower`` (one per wavelength), its disorder averaged over the model's draws."""
    lams = np.asarray(wavelengths, dtype=float)
    indices = {f: film_index(f, lams) for f in stack.films}
    draws = disorder_draws(stack) if stack.disorder else np.ones((1, stack.count))
    R, T = np.mean([thin_film.stack_reflectance_transmittance(
        n0, [indices[f] for f in stack.layers], [scale * f.thickness_nm * x for f, x in zip(stack.layers, factors)],
        lower, theta_deg, lams) for factors in draws], axis=0)
    return R, T


def reference_lab(stack: FilmStack, n0: float, lower_medium: str, lower_rgb, theta_deg: float,
                  scale: float = 1.0) -> np.ndarray:
    """Lab (D65) of tmm's reflection of the stack."""
    lower = lower_index(lower_rgb[0], lower_rgb[1], REFERENCE_NM, lower_medium)
    R, _ = tmm_spectrum(stack, n0, lower, theta_deg, scale)
    return thin_film.xyz_to_lab(thin_film.spectrum_to_xyz(REFERENCE_NM, R))


def model_lab(stack: FilmStack, n0: float, lower_medium: str, lower_rgb, theta_deg: float, scale: float = 1.0,
              accuracy: str = "analytic") -> np.ndarray:
    """Lab (D65) of the add-on's colour of the stack's reflection (its RGB, out of gamut kept)."""
    R, _ = stack_colour(stack, n0, lower_rgb, np.cos(np.radians(theta_deg)), scale, accuracy, lower_medium,
                        gamut=False)
    return rgb_to_lab(R)


def stack_error(params, theta_deg: float, scale: float = 1.0, accuracy: str = "analytic") -> float:
    """CIEDE2000 between the model's and tmm's colour of ``params``'s stack (a material with one), seen from the
    medium above it (the outside, or the crystal around tilted lamellae: ``theta_deg`` inside it)."""
    args = (params.stack, StackResponse.of(params).n0, params.lower_medium, (params.r2, params.k2), theta_deg, scale)
    return float(thin_film.delta_e_2000(model_lab(*args, accuracy=accuracy), reference_lab(*args)))


__all__ = ["REFERENCE_NM", "model_lab", "reference_lab", "stack_error", "tmm_spectrum", "spectrum"]
