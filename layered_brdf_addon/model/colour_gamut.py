"""A colour held within Rec.709's gamut, smoothly: a saturated stack's reflectance (a Bragg peak's red can be
negative in linear Rec.709) as a closure's weight can hold it, without a sharp bend where the tables' cubic
splines would overshoot.  numpy.
"""
from __future__ import annotations

import numpy as np

GAMUT_SOFTNESS = 0.05  # of a colour's brightest channel: how softly a channel outside [0, 1] is brought in


def within_gamut(rgb):
    """Channels of ``rgb`` (..., 3) held within [0, 1] smoothly: ``s log(1 + e^(x / s))`` towards 0 (and its
    mirror towards 1), ``s`` :data:`GAMUT_SOFTNESS` of the colour's brightest channel, so that a colour that
    leaves the gamut (a saturated Bragg peak's red) does not bend sharply where the tables' cubic splines
    would overshoot; within a few ``s`` of the range's inside, a channel is its own value."""
    rgb = np.asarray(rgb, dtype=float)
    s = np.maximum(GAMUT_SOFTNESS * np.max(np.abs(rgb), axis=-1, keepdims=True), 1e-6)
    low = s * np.logaddexp(0.0, rgb / s)
    return 1.0 - s * np.logaddexp(0.0, (1.0 - low) / s)
