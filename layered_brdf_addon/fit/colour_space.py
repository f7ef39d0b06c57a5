"""Perceptual distances of linear Rec.709 colours: CIELAB and CIEDE2000 (colour-science).

A render holds radiances, not reflectances: colours are put on the CIELAB scale relative
to a white of luminance ``white_y`` (the target's bright end), so a difference reads the
same in a dim and a bright target.
"""
from __future__ import annotations

import numpy as np

_REC709_TO_XYZ = None
_D65_XY = np.array([0.3127, 0.3290])


def _matrix() -> np.ndarray:
    global _REC709_TO_XYZ
    if _REC709_TO_XYZ is None:
        import colour

        _REC709_TO_XYZ = np.asarray(colour.RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ, dtype=float)
    return _REC709_TO_XYZ


def lab(rgb, white_y: float = 1.0) -> np.ndarray:
    """CIE L*a*b* (D65) of scene-linear Rec.709 RGB (last axis), ``white_y`` the luminance of white."""
    import colour

    xyz = np.asarray(rgb, dtype=float) @ _matrix().T / max(float(white_y), 1e-12)
    return np.asarray(colour.XYZ_to_Lab(xyz, _D65_XY))


def luminance(rgb) -> np.ndarray:
    return np.asarray(rgb, dtype=float) @ _matrix()[1]


def delta_e_2000(lab1, lab2) -> np.ndarray:
    """CIEDE2000 difference of two Lab colours (last axis)."""
    import colour

    return np.asarray(colour.delta_E(np.asarray(lab1, dtype=float), np.asarray(lab2, dtype=float),
                                     method="CIE 2000"))


def white_of(rgb, mask=None, percentile: float = 99.0) -> float:
    """The luminance a target's colours are measured against: its ``percentile`` brightest,
    at least 1e-6 (a black target has no scale of its own)."""
    y = luminance(rgb)
    if mask is not None:
        y = y[mask]
    return max(float(np.percentile(y, percentile)) if y.size else 0.0, 1e-6)


VISIBLE_NM = (380.0, 700.0)  # a reflectance spectrum must span this to give a colour


def spectrum_to_rgb(wavelengths_nm, reflectance) -> np.ndarray:
    """Linear Rec.709 RGB of reflectance spectra (last axis: wavelength) under D65, the CIE
    1931 observer; a perfect white is (1, 1, 1).  Summed over the given wavelengths with
    widths ``np.gradient(wavelengths_nm)``, the tables interpolated to them."""
    import colour

    lams = np.asarray(wavelengths_nm, dtype=float)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    bar = np.stack([np.interp(lams, cmfs.domain, v) for v in np.asarray(cmfs.values, dtype=float).T], axis=-1)
    weights = (np.interp(lams, d65.domain, np.asarray(d65.values, dtype=float)) * np.gradient(lams))[:, None] * bar
    xyz = np.asarray(reflectance, dtype=float) @ weights / weights[:, 1].sum()
    return xyz @ np.linalg.inv(_matrix()).T
