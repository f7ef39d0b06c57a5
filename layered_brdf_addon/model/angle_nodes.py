"""A disordered stack's response at a few view angles, joined by cubics: what a table's grid of angles needs
at a fraction of the cost.

A stack's reflectance, once summed over each channel's band, is smooth in the view angle; computed at
:data:`ANGLE_NODES` cosines (uniform in ``sqrt(cos)``, finer towards grazing where it turns fastest) per
thickness row and joined by cubic Hermite curves with Catmull-Rom slopes (a minimum keeps its curve), it
stands for the response at every cosine of the row.  numpy; no bpy.
"""
from __future__ import annotations

import numpy as np

from .stack_optics import hemispherical_mean

ANGLE_NODES = 33  # cosines a disordered stack's optics are baked at (uniform in sqrt(cos), joined by cubics)


class NodeResponse:
    """A :class:`.stack_optics.StackResponse` computed at :data:`ANGLE_NODES` cosines per thickness of ``rows``
    and joined by cubic Hermite curves in ``sqrt(cos)`` (Catmull-Rom slopes): what a table's grid needs at a
    fraction of the cost, the stack's reflectance being smooth in the angle once summed over each channel's
    band.  ``colour`` takes thicknesses of ``rows`` only."""

    def __init__(self, response, rows, nodes: int = ANGLE_NODES):
        self.response = response
        self.rows = np.asarray(rows, dtype=float)
        self.x = np.linspace(0.0, 1.0, nodes)
        R, T = response.colour(self.x[:, None] ** 2, self.rows[None, :])  # (nodes, rows, 3)
        self.R, self.T = R, T

    def hemispherical(self, d):
        """The hemisphere's mean from the cubics (at thicknesses of ``rows``: no optics computed again)."""
        return hemispherical_mean(self.colour, d)

    def _at(self, values, x, row):
        n = len(self.x) - 1
        h = 1.0 / n
        i = np.clip((x / h).astype(int), 0, n - 1)
        t = (x - i * h) / h
        y0, y1 = values[i, row], values[i + 1, row]
        slopes = np.diff(values, axis=0) / h  # (n, rows, 3)
        m = np.zeros_like(values)
        m[1:-1] = 0.5 * (slopes[:-1] + slopes[1:])  # Catmull-Rom: a minimum keeps its curve
        m[0], m[-1] = slopes[0], slopes[-1]
        t = t[..., None]
        h00, h10, h01, h11 = 2 * t ** 3 - 3 * t ** 2 + 1, t ** 3 - 2 * t ** 2 + t, -2 * t ** 3 + 3 * t ** 2, \
            t ** 3 - t ** 2
        return h00 * y0 + h10 * h * m[i, row] + h01 * y1 + h11 * h * m[i + 1, row]

    def colour(self, cos0, d):
        cos0, d = np.broadcast_arrays(np.asarray(cos0, dtype=float), np.asarray(d, dtype=float))
        row = np.clip(np.searchsorted(self.rows, d), 0, len(self.rows) - 1)
        if not np.allclose(self.rows[row], d, rtol=1e-9, atol=1e-6):
            return self.response.colour(cos0, d)
        x = np.sqrt(np.clip(cos0, 0.0, 1.0))
        return self._at(self.R, x, row), self._at(self.T, x, row)
