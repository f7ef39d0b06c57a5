"""The colour of a smooth thin film, from transfer-matrix optics (``tmm``) and CIE colorimetry.

An independent reference for the add-on's physical optics: the stack is
outside | film | below, with semi-infinite outside and below media and a film of
thickness ``d`` in nanometres; light comes from the outside medium at ``theta``.

Conventions:

* reflectance is unpolarised, ``(R_s + R_p) / 2``, from ``tmm.coh_tmm`` (coherent,
  so a film's interference is kept at every thickness);
* complex indices are ``n + 1j*k`` with ``k >= 0`` absorbing, tmm's own convention:
  its fields go as ``exp(+i k_z z)`` with ``k_z = 2 pi n cos(theta) / lambda``, so
  ``k > 0`` decays (tmm asserts ``n.real * n.imag >= 0`` for the outer media; here
  ``k < 0`` is refused everywhere);
* colour is the reflectance seen under CIE D65 with the CIE 1931 2° observer,
  summed on the given wavelengths (colour-science's tabulated CMFs and D65 SPD,
  linearly interpolated there) and scaled so that a perfect white reflector has Y = 1;
* RGB is scene-linear Rec.709 (sRGB primaries, D65 white, RGB (1, 1, 1) -> Y = 1);
  Lab and ΔE2000 are relative to the CIE D65 white point xy = (0.3127, 0.3290).
"""
from __future__ import annotations

import colour
import numpy as np
import tmm

WAVELENGTHS_NM = np.arange(380, 781, 5)

_OBSERVER = "CIE 1931 2 Degree Standard Observer"
_D65_XY = np.asarray(colour.CCS_ILLUMINANTS[_OBSERVER]["D65"], dtype=float)
_REC709 = colour.RGB_COLOURSPACES["ITU-R BT.709"]


def _per_wavelength(value, count: int, name: str) -> np.ndarray:
    values = np.broadcast_to(np.asarray(value, dtype=complex), (count,))
    if np.any(values.imag < 0):
        raise ValueError(f"{name}: the imaginary part k of n + 1j*k must be >= 0 (absorbing)")
    return values


def film_reflectance_transmittance(n_outside, n_film, n_below, thickness_nm, theta_deg,
                                   wavelengths_nm) -> tuple[np.ndarray, np.ndarray]:
    """Unpolarised reflectance and transmittance of outside | film | below, per wavelength.

    ``n_outside`` is real (lossless); ``n_film`` and ``n_below`` are numbers or arrays
    per wavelength, ``n + 1j*k`` with ``k >= 0``.  ``T`` is the power that enters the
    below medium (absorbed there when it absorbs); ``1 - R - T`` is absorbed in the film.
    """
    if not float(thickness_nm) >= 0:
        raise ValueError("thickness_nm must be >= 0")
    return stack_reflectance_transmittance(n_outside, [n_film], [thickness_nm], n_below, theta_deg, wavelengths_nm)


def stack_reflectance_transmittance(n_outside, n_films, thicknesses_nm, n_below, theta_deg,
                                    wavelengths_nm) -> tuple[np.ndarray, np.ndarray]:
    """Unpolarised reflectance and transmittance of outside | films (top first) | below, per wavelength:
    :func:`film_reflectance_transmittance` for any number of films (``n_films``: one index or one per
    wavelength each; ``thicknesses_nm``: nm each)."""
    lams = np.atleast_1d(np.asarray(wavelengths_nm, dtype=float))
    n0 = _per_wavelength(n_outside, lams.size, "n_outside")
    if np.any(n0.imag != 0) or np.any(n0.real <= 0):
        raise ValueError("n_outside must be real and positive")
    films = [_per_wavelength(n, lams.size, "n_film") for n in n_films]
    n2 = _per_wavelength(n_below, lams.size, "n_below")
    d = [np.inf, *(float(t) for t in thicknesses_nm), np.inf]
    theta = np.radians(float(theta_deg))
    r = np.empty(lams.size)
    t = np.empty(lams.size)
    for i, lam in enumerate(lams):
        stack = [n0[i].real, *(n[i] for n in films), n2[i]]
        s = tmm.coh_tmm("s", stack, d, theta, lam)
        p = tmm.coh_tmm("p", stack, d, theta, lam)
        r[i] = 0.5 * (s["R"] + p["R"])
        t[i] = 0.5 * (s["T"] + p["T"])
    return r, t


def film_reflectance(n_outside, n_film, n_below, thickness_nm, theta_deg, wavelengths_nm) -> np.ndarray:
    """Unpolarised reflectance ``(R_s + R_p) / 2`` of outside | film | below, per wavelength."""
    return film_reflectance_transmittance(n_outside, n_film, n_below, thickness_nm, theta_deg,
                                          wavelengths_nm)[0]


def _tabulated(sd, lams: np.ndarray) -> np.ndarray:
    domain = sd.domain
    if lams.min() < domain[0] or lams.max() > domain[-1]:
        raise ValueError(f"wavelengths must lie in [{domain[0]:g}, {domain[-1]:g}] nm")
    values = np.asarray(sd.values, dtype=float)
    if values.ndim == 1:
        return np.interp(lams, domain, values)
    return np.stack([np.interp(lams, domain, v) for v in values.T], axis=-1)


def spectrum_to_xyz(wavelengths_nm, reflectance) -> np.ndarray:
    """XYZ of a reflectance spectrum (last axis: wavelength) under D65; a perfect white has Y = 1.

    A sum over the given wavelengths with widths ``np.gradient(wavelengths_nm)``: on a
    regular grid, colour-science's ``sd_to_XYZ(method="Integration")`` divided by 100.
    """
    lams = np.asarray(wavelengths_nm, dtype=float)
    refl = np.asarray(reflectance, dtype=float)
    if lams.ndim != 1 or lams.size < 2 or refl.shape[-1:] != lams.shape:
        raise ValueError("reflectance's last axis must match a 1-D array of >= 2 wavelengths")
    cmfs = _tabulated(colour.MSDS_CMFS[_OBSERVER], lams)
    weights = (_tabulated(colour.SDS_ILLUMINANTS["D65"], lams) * np.gradient(lams))[:, None] * cmfs
    return refl @ weights / weights[:, 1].sum()


def linear_rec709_to_xyz(rgb) -> np.ndarray:
    """Scene-linear Rec.709 RGB (last axis) to XYZ; (1, 1, 1) is the D65 white with Y = 1."""
    return np.asarray(rgb, dtype=float) @ np.asarray(_REC709.matrix_RGB_to_XYZ).T


def xyz_to_lab(xyz) -> np.ndarray:
    """CIE L*a*b* of XYZ (white Y = 1) relative to D65."""
    return np.asarray(colour.XYZ_to_Lab(np.asarray(xyz, dtype=float), _D65_XY))


def delta_e_2000(lab1, lab2) -> np.ndarray:
    """CIEDE2000 difference of two Lab colours (last axis)."""
    return np.asarray(colour.delta_E(np.asarray(lab1, dtype=float), np.asarray(lab2, dtype=float),
                                     method="CIE 2000"))


def film_lab(n_outside, n_film, n_below, thicknesses_nm, theta_deg, wavelengths=WAVELENGTHS_NM) -> np.ndarray:
    """Lab (D65) of the film's reflection, one row per thickness."""
    lams = np.asarray(wavelengths, dtype=float)
    spectra = np.array([film_reflectance(n_outside, n_film, n_below, d, theta_deg, lams)
                        for d in np.atleast_1d(np.asarray(thicknesses_nm, dtype=float))])
    return xyz_to_lab(spectrum_to_xyz(lams, spectra))
