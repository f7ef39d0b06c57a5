"""Comparing rendered pixels with expected ones (per-pixel tolerance, failing fraction)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from layered_brdf_addon.model.geometry import dot


@dataclass
class Agreement:
    failing_fraction: float  # share of masked pixels off by more than the tolerance
    max_relative: float  # largest relative difference in the mask
    median_relative: float
    pixels: int

    def __str__(self):
        return (f"{self.failing_fraction:.2%} of {self.pixels} pixels fail; relative error median "
                f"{self.median_relative:.2e}, max {self.max_relative:.2e}")


def agreement(actual, expected, mask, rel_tol: float, abs_floor: float | None = None) -> Agreement:
    """A pixel fails when any channel is off by more than ``rel_tol * |expected| + abs_floor``.

    ``abs_floor`` defaults to ``rel_tol`` times 1% of the largest expected value in the mask.
    """
    actual = np.asarray(actual, dtype=float)[mask]
    expected = np.asarray(expected, dtype=float)[mask]
    if expected.size == 0:
        raise ValueError("empty mask")
    if abs_floor is None:
        abs_floor = rel_tol * 0.01 * float(np.max(np.abs(expected)))
    err = np.abs(actual - expected)
    fail = np.any(err > rel_tol * np.abs(expected) + abs_floor, axis=-1)
    rel = np.max(err / np.maximum(np.abs(expected), abs_floor / max(rel_tol, 1e-12)), axis=-1)
    return Agreement(float(fail.mean()), float(rel.max()), float(np.median(rel)), int(fail.size))


def lit_mask(geometry, l, threshold: float = 0.1):
    """Pixels on a sphere with ``<n0, l>`` and ``<n0, v>`` above ``threshold`` (off terminator and silhouette)."""
    return geometry.mask & (dot(geometry.n0, l) > threshold) & (dot(geometry.n0, geometry.view) > threshold)


def highlight_mask(expected, mask, fraction: float = 0.05):
    """Pixels of ``mask`` brighter than ``fraction`` of the expected maximum (sum of channels)."""
    s = np.asarray(expected).sum(axis=-1)
    return mask & (s > fraction * s[mask].max())


def relative_l1(actual, expected, mask) -> float:
    """``sum |actual - expected| / sum |expected|`` over ``mask`` (all channels)."""
    a = np.asarray(actual)[mask]
    e = np.asarray(expected)[mask]
    return float(np.abs(a - e).sum() / np.abs(e).sum())


def centroids(image, mask):
    """Intensity-weighted (row, col) centroid of each channel over ``mask``, shape (C, 2)."""
    rows, cols = np.nonzero(mask)
    w = np.asarray(image)[mask]
    tot = w.sum(axis=0)
    return np.stack([(w * rows[:, None]).sum(0) / tot, (w * cols[:, None]).sum(0) / tot], axis=-1)
