"""Baked spectral tables for the shaders and the fit (no colour-science in Blender).

``data/spectral_tables.json`` is written by ``python -m layered_brdf_reference.spectral``
from colour-science's CIE 1931 CMFs and D65 (see layered_brdf_reference/spectral.py), and so
is ``data/cie_observer.json``: the CMFs and D65 as colour-science tabulates them, and the
linear Rec.709 -> XYZ matrix with its white.  Tests check that both are current.
"""
from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np

PATH = Path(__file__).with_name("data") / "spectral_tables.json"
OBSERVER_PATH = Path(__file__).with_name("data") / "cie_observer.json"
SAMPLE_COUNTS = (4, 8, 16, 32)


@functools.lru_cache(maxsize=None)
def tables(n: int) -> dict:
    """``wavelengths`` (N), ``cauchy`` (N x 3: ``r1(lambda_j) = sum_c cauchy[j][c] r1_c``) and
    ``rgb`` (N x 3: linear Rec.709 of a spectrum sampled at the wavelengths)."""
    data = json.loads(PATH.read_text())
    if str(n) not in data:
        raise ValueError(f"no spectral tables for {n} wavelengths: allowed {', '.join(data)}")
    return data[str(n)]


@functools.lru_cache(maxsize=None)
def observer() -> dict[str, np.ndarray]:
    """The CIE 1931 2 degree observer and D65, read-only arrays: ``cmf_nm`` (N), ``cmf`` (N x 3:
    x-bar, y-bar, z-bar), ``d65_nm`` (M), ``d65`` (M), ``rec709_to_xyz`` (3 x 3, the white
    (1, 1, 1) at Y = 1) and ``white_xy`` (the D65 white's chromaticity)."""
    data = json.loads(OBSERVER_PATH.read_text())
    out = {key: np.asarray(value, dtype=float) for key, value in data.items()}
    for a in out.values():
        a.setflags(write=False)
    return out
