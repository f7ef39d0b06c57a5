"""The shader's inputs: a direction from a socket, every parameter kept within its range, and
the per-parameter values grouped as the program's shading takes them.
"""
from __future__ import annotations

from ..params import iter_sockets
from .step import shader_function

FLOAT_LIMIT = 1.0e38  # an infinite component of a direction input counts as this


@shader_function
def direction_input(ops, v):
    """A direction from a socket, scaled by its largest component so that a huge but finite
    vector keeps its direction (squaring it would overflow float32).  A vector with a NaN
    component becomes 0, and so falls back wherever it is normalised; an infinite component
    counts as the largest finite one."""
    x, y, z = ops.components(v)
    # "c < 1 or c > 0" holds for every number but NaN.
    valid = (ops.gt(ops.lt(x, 1.0) + ops.gt(x, 0.0), 0.5) * ops.gt(ops.lt(y, 1.0) + ops.gt(y, 0.0), 0.5)
             * ops.gt(ops.lt(z, 1.0) + ops.gt(z, 0.0), 0.5))
    xs = ops.clamp(ops.nan_to_zero(x), -FLOAT_LIMIT, FLOAT_LIMIT)
    ys = ops.clamp(ops.nan_to_zero(y), -FLOAT_LIMIT, FLOAT_LIMIT)
    zs = ops.clamp(ops.nan_to_zero(z), -FLOAT_LIMIT, FLOAT_LIMIT)
    largest = ops.maximum(ops.maximum(ops.abs(xs), ops.abs(ys)), ops.abs(zs))
    return ops.combine(xs, ys, zs) * (valid / largest)


def clamped_inputs(ops):
    """Every shader input, clamped to its parameter's allowed range (a texture or a driver
    may feed any value)."""
    return {spec.name: ops.named(f"{spec.name}_c", ops.clamp_input(ops.input(spec.name), spec.min, spec.max))
            for spec in iter_sockets()}


def program_inputs(P):
    """The inputs of :func:`shade` from the per-parameter values ``P``."""
    return dict(r1=(P["r1_r"], P["r1_g"], P["r1_b"]), r0=P["r0"], e0=P["e0"], e1=P["e1"], ks=P["ks"], kd=P["kd"],
                base=(P["base_r"], P["base_g"], P["base_b"]), r2=(P["r2_r"], P["r2_g"], P["r2_b"]),
                k2=(P["k2_r"], P["k2_g"], P["k2_b"]))
