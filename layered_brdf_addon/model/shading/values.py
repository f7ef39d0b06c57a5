"""Channel values.

A channel value is a scalar (one wavelength, the spectral modes) or a triple (the three
RGB channels at once, one component each: a shader evaluates them as one vector).  The
arithmetic is the same; only the directions differ per channel, so they are computed
channel by channel.
"""
from __future__ import annotations


def channels(ops, x):
    """The per-channel scalars of a channel value."""
    return list(ops.components(x)) if ops.is_vector(x) else [x]


def gather(ops, parts):
    """A channel value from per-channel scalars."""
    if len(parts) == 3:
        return ops.combine(*parts)
    return parts[0]


def spread(ops, x, like):
    """``x`` (one channel's scalar) as a channel value shaped like ``like``."""
    return ops.combine(x, x, x) if ops.is_vector(like) and not ops.is_vector(x) else x
