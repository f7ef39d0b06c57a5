"""The colour of a film stack's mirror reflection: the add-on's stack optics against tmm.

The reference is tmm's coherent transfer matrices (``tmm.coh_tmm``, both polarisations averaged) for
air | films | lower medium at 1 nm over 380-780 nm, seen under D65 with the CIE 1931 observer
(:mod:`.thin_film`); a disordered stack is averaged over the same draws of its films' thicknesses
(:func:`layered_brdf_addon.model.stack_optics.disorder_draws`), so that the comparison measures the
optics and their colour, not two samplings of the disorder.  A stack's domains (coherent copies one under
the other, their light added as power) are tmm's coherent domain per polarisation, piled one domain at a
time as a pile of plates adds its light (Stokes).  The model side is
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
    if stack.domains > 1:
        return tuple(np.mean([_domains(stack, n0, [indices[f] for f in stack.layers], [
            scale * f.thickness_nm * x for f, x in zip(stack.layers, factors)], lower, theta_deg, lams)
            for factors in draws], axis=0))
    R, T = np.mean([thin_film.stack_reflectance_transmittance(
        n0, [indices[f] for f in stack.layers], [scale * f.thickness_nm * x for f, x in zip(stack.layers, factors)],
        lower, theta_deg, lams) for factors in draws], axis=0)
    return R, T


def _domains(stack: FilmStack, n0: float, films, thicknesses, lower, theta_deg: float, lams):
    """Unpolarised ``(R, T)`` of ``stack.domains`` copies of the films in the medium ``n0``, the last over
    ``lower``: per polarisation, tmm's coherent domain (with ``n0`` below it, and with ``lower``), the domains
    added one at a time from the bottom up, the light between them summed as powers."""
    import tmm

    theta = np.radians(theta_deg)
    d = [np.inf, *thicknesses, np.inf]
    R, T = np.zeros(lams.size), np.zeros(lams.size)
    for i, lam in enumerate(lams):
        for pol in "sp":
            def coherent(below):
                out = tmm.coh_tmm(pol, [n0, *(n[i] for n in films), below], d, theta, lam)
                return out["R"], out["T"]
            (Rd, Td), (Rb, Tb) = coherent(n0), coherent(lower[i])
            for _ in range(stack.domains - 1):  # one more domain on top of what lies below
                inv = 1.0 / (1.0 - Rd * Rb)
                Rb, Tb = Rd + Td * Td * Rb * inv, Td * Tb * inv
            R[i] += 0.5 * Rb
            T[i] += 0.5 * Tb
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
