"""The shader's inputs: a direction from a socket, every parameter kept within its range, and
the per-parameter values grouped as the program's shading takes them.
"""
from __future__ import annotations

from ..dispersion import WAVELENGTHS_NM, abbe_index
from ..params import LayeredParams, iter_sockets, socket_units
from ..socket_units import ROUGHNESS, from_socket, socket_range
from .step import shader_function

FLOAT_LIMIT = 1.0e38  # an infinite component of a direction input counts as this
R1_RANGE = (LayeredParams.spec("r1_r").min, LayeredParams.spec("r1_r").max)  # the layer's indices' range


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


def parameter_value(ops, spec, units, x):
    """A parameter's value from ``x``, the value of a socket holding ``units`` (:mod:`..socket_units`),
    within the parameter's range: ``x`` clamped to the socket's range (a texture or a driver may feed
    any value; a NaN is the lower bound), then turned into the parameter's units where the socket
    holds something else (a Roughness, an angle in radians), and held to the parameter's largest value."""
    lo, hi = socket_range(units, spec.min, spec.max)
    x = ops.clamp_input(x, lo, hi)
    if units == ROUGHNESS:
        return ops.minimum(from_socket(ops, units, x), spec.max)
    return from_socket(ops, units, x)


def parameter_input(ops, spec):
    """A parameter's value from its socket on the backend of ``ops`` (:func:`parameter_value`)."""
    return parameter_value(ops, spec, socket_units(spec, getattr(ops, "SOCKETS", "osl")), ops.input(spec.name))


def clamped_inputs(ops, plan=None):
    """Every shader input in its parameter's units and range (:func:`parameter_input`); with a
    ``plan`` whose layer index is "ior", the three indices ``r1_r, r1_g, r1_b`` are the IOR and
    Dispersion's (:func:`layer_indices`), not their sockets'."""
    P = {spec.name: ops.named(f"{spec.name}_c", parameter_input(ops, spec)) for spec in iter_sockets()
         if plan is None or plan.index != "ior" or not spec.name.startswith("r1_")}
    if plan is not None and plan.index == "ior":
        P.update(zip(("r1_r", "r1_g", "r1_b"), layer_indices(ops, P["layer_ior"], P["layer_dispersion"])))
    return P


@shader_function
def layer_index_at(ops, ior, dispersion, wavelength_nm):
    """The layer's index at ``wavelength_nm`` from its IOR (at the d line, 587.6 nm) and its
    Dispersion (20 / V_d, V_d the Abbe number), as glTF's KHR_materials_dispersion defines them,
    within the indices' range."""
    return ops.clamp(abbe_index(ior, dispersion, wavelength_nm), R1_RANGE[0], R1_RANGE[1])


def layer_indices(ops, ior, dispersion):
    """The layer's indices at the R, G and B channels' wavelengths (:func:`layer_index_at`)."""
    return tuple(ops.named(f"r1_{c}_c", layer_index_at(ops, ior, dispersion, lam))
                 for c, lam in zip("rgb", WAVELENGTHS_NM))


def program_inputs(P):
    """The inputs of :func:`shade` from the per-parameter values ``P``."""
    return dict(r1=(P["r1_r"], P["r1_g"], P["r1_b"]), r0=P["r0"], e0=P["e0"], e1=P["e1"], ks=P["ks"], kd=P["kd"],
                base=(P["base_r"], P["base_g"], P["base_b"]), r2=(P["r2_r"], P["r2_g"], P["r2_b"]),
                k2=(P["k2_r"], P["k2_g"], P["k2_b"]))

