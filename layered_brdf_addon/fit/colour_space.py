"""Perceptual distances of linear Rec.709 colours: CIELAB and CIEDE2000, in numpy alone.

A render holds radiances, not reflectances: colours are put on the CIELAB scale relative
to a white of luminance ``white_y`` (the target's bright end), so a difference reads the
same in a dim and a bright target.

The CIE tables (the 1931 2 degree observer, D65, the Rec.709 primaries' matrix) are
colour-science's, baked into ``model/data/cie_observer.json`` (:func:`..model.spectral_tables.observer`),
so the fit runs in Blender's own Python; tests/test_colour_space.py holds these formulas to
colour-science's.
"""
from __future__ import annotations

import numpy as np

from ..model.spectral_tables import observer

# CIE 1976 L*a*b*: the cube root's linear toe below (6/29)^3 (CIE 15:2004, eq. 8.4-8.6).
_DELTA = 6.0 / 29.0


def _matrix() -> np.ndarray:
    return observer()["rec709_to_xyz"]


def _white_xyz() -> np.ndarray:
    x, y = observer()["white_xy"]
    return np.array([x / y, 1.0, (1.0 - x - y) / y])


def _f(t: np.ndarray) -> np.ndarray:
    return np.where(t > _DELTA ** 3, np.cbrt(t), t / (3.0 * _DELTA * _DELTA) + 4.0 / 29.0)


def xyz_to_lab(xyz) -> np.ndarray:
    """CIE L*a*b* of XYZ (last axis) against the D65 white at Y = 1."""
    f = _f(np.asarray(xyz, dtype=float) / _white_xyz())
    return np.stack([116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]),
                     200.0 * (f[..., 1] - f[..., 2])], axis=-1)


def lab(rgb, white_y=1.0) -> np.ndarray:
    """CIE L*a*b* (D65) of scene-linear Rec.709 RGB (last axis), ``white_y`` the luminance of white:
    one number, or one per colour (an array of ``rgb``'s shape without its last axis, or one that
    broadcasts to it)."""
    white = np.maximum(np.asarray(white_y, dtype=float), 1e-12)[..., None]
    return xyz_to_lab(np.asarray(rgb, dtype=float) @ _matrix().T / white)


def luminance(rgb) -> np.ndarray:
    return np.asarray(rgb, dtype=float) @ _matrix()[1]


def _hue_deg(b: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Hue angle in [0, 360) degrees; 0 for an achromatic colour."""
    return np.where((a == 0) & (b == 0), 0.0, np.degrees(np.arctan2(b, a)) % 360.0)


def delta_e_2000(lab1, lab2) -> np.ndarray:
    """CIEDE2000 difference of two Lab colours (last axis), ``k_L = k_C = k_H = 1``
    (CIE 142-2001; Sharma, Wu and Dalal 2005, eq. 1-22, their conventions for the mean hue)."""
    l1, a1, b1 = np.moveaxis(np.asarray(lab1, dtype=float), -1, 0)
    l2, a2, b2 = np.moveaxis(np.asarray(lab2, dtype=float), -1, 0)
    c_bar = 0.5 * (np.hypot(a1, b1) + np.hypot(a2, b2))
    c7 = c_bar ** 7
    g = 0.5 * (1.0 - np.sqrt(c7 / (c7 + 25.0 ** 7)))
    a1p, a2p = (1.0 + g) * a1, (1.0 + g) * a2
    c1p, c2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p, h2p = _hue_deg(b1, a1p), _hue_deg(b2, a2p)
    chromatic = c1p * c2p != 0.0

    dh = h2p - h1p
    dh = np.where(dh > 180.0, dh - 360.0, np.where(dh < -180.0, dh + 360.0, dh))
    dh = np.where(chromatic, dh, 0.0)
    d_l, d_c = l2 - l1, c2p - c1p
    d_h = 2.0 * np.sqrt(c1p * c2p) * np.sin(np.radians(dh) / 2.0)

    l_bar, cp_bar = 0.5 * (l1 + l2), 0.5 * (c1p + c2p)
    h_sum = h1p + h2p
    h_bar = np.where(np.abs(h1p - h2p) <= 180.0, h_sum / 2.0,
                     np.where(h_sum < 360.0, (h_sum + 360.0) / 2.0, (h_sum - 360.0) / 2.0))
    h_bar = np.where(chromatic, h_bar, h_sum)
    t = (1.0 - 0.17 * np.cos(np.radians(h_bar - 30.0)) + 0.24 * np.cos(np.radians(2.0 * h_bar))
         + 0.32 * np.cos(np.radians(3.0 * h_bar + 6.0)) - 0.20 * np.cos(np.radians(4.0 * h_bar - 63.0)))
    d_theta = 30.0 * np.exp(-(((h_bar - 275.0) / 25.0) ** 2))
    cp7 = cp_bar ** 7
    r_c = 2.0 * np.sqrt(cp7 / (cp7 + 25.0 ** 7))
    l50 = (l_bar - 50.0) ** 2
    s_l = 1.0 + 0.015 * l50 / np.sqrt(20.0 + l50)
    s_c = 1.0 + 0.045 * cp_bar
    s_h = 1.0 + 0.015 * cp_bar * t
    r_t = -np.sin(np.radians(2.0 * d_theta)) * r_c
    return np.sqrt((d_l / s_l) ** 2 + (d_c / s_c) ** 2 + (d_h / s_h) ** 2 + r_t * (d_c / s_c) * (d_h / s_h))


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
    obs = observer()
    lams = np.asarray(wavelengths_nm, dtype=float)
    bar = np.stack([np.interp(lams, obs["cmf_nm"], column) for column in obs["cmf"].T], axis=-1)
    weights = (np.interp(lams, obs["d65_nm"], obs["d65"]) * np.gradient(lams))[:, None] * bar
    xyz = np.asarray(reflectance, dtype=float) @ weights / weights[:, 1].sum()
    return xyz @ np.linalg.inv(_matrix()).T
