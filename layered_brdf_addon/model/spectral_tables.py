"""Baked spectral tables for the shaders (no colour-science at render time).

``data/spectral_tables.json`` is written by ``python -m layered_brdf_reference.spectral``
from colour-science's CIE 1931 CMFs and D65 (see layered_brdf_reference/spectral.py); a test
checks that it is current.
"""
from __future__ import annotations

import functools
import json
from pathlib import Path

PATH = Path(__file__).with_name("data") / "spectral_tables.json"
SAMPLE_COUNTS = (4, 8, 16, 32)


@functools.lru_cache(maxsize=None)
def tables(n: int) -> dict:
    """``wavelengths`` (N), ``cauchy`` (N x 3: ``r1(lambda_j) = sum_c cauchy[j][c] r1_c``) and
    ``rgb`` (N x 3: linear Rec.709 of a spectrum sampled at the wavelengths)."""
    data = json.loads(PATH.read_text())
    if str(n) not in data:
        raise ValueError(f"no spectral tables for {n} wavelengths: allowed {', '.join(data)}")
    return data[str(n)]
