"""What every material's tables share: the texels' grid over the view and the thickness, the shader's input
values as the sockets hold them, and how many texels a material's tables may have.  numpy; no bpy.
"""
from __future__ import annotations

import math

import numpy as np

from .params import LayeredParams, iter_sockets, socket_values
from .plan import EffectPlan

SAMPLES_PER_FRINGE = 24  # texels along d per interference fringe of the bluest channel (measured: docs/tables.md)
SAMPLES_PER_HARMONIC_FRINGE = 10  # and per fringe of the highest harmonic of the beams that bounce in the layer
# (m fringes per fringe of the first; their amplitudes fall as |r01 r12|^m)
MIN_THICKNESS_SAMPLES = 8
MAX_TABLE_BYTES = 1 << 20  # a material's tables, at most (float32 RGBA texels)
MAX_THICKNESS_SAMPLES = 1024
SHORTEST_NM = 400.0  # the bluest wavelength a plan evaluates (spectral modes reach below the RGB channels' 465 nm)


def texel_grid(width: int, height: int, d_min, d_max, azimuths: int = 1):
    """View directions, thicknesses and lower normals' azimuths (from the view's plane: the view's azimuth
    from the lower normal, turned over) of the texels, (A, H, W): n0 = +z, the view in the xz plane towards
    +x, at ``sqrt(cos_v) = i / (W - 1)`` (with azimuths, at the angle ``pi/2 (1 - i / (W - 1))``)."""
    c = np.cos((1.0 - np.linspace(0.0, 1.0, width)) * (0.5 * math.pi)) if azimuths > 1 else \
        np.linspace(0.0, 1.0, width) ** 2
    t = np.linspace(0.0, 1.0, height) if height > 1 else np.zeros(1)
    a = np.linspace(0.0, math.pi, azimuths) if azimuths > 1 else np.zeros(1)
    A, T, C = np.meshgrid(a, t, c, indexing="ij")
    v = np.stack([np.sqrt(np.maximum(1.0 - C * C, 0.0)), np.zeros_like(C), C], axis=-1)
    return v, d_min + (d_max - d_min) * T, A


def azimuth_frame(phi):
    """The frame a tilted boundary's texels are baked in, at the lower normal's azimuths ``phi`` (n0 = +z, the
    view towards +x): the tilt axis ``t = (-sin phi, cos phi, 0)`` and ``w = t x n0 = (cos phi, sin phi, 0)``,
    the lower normal's direction along the surface (:func:`.shading.tables.lower_frame`; the view lies on the
    side of ``-t``, so ``b = -t``)."""
    zero = np.zeros_like(phi)
    return np.stack([-np.sin(phi), np.cos(phi), zero], axis=-1), np.stack([np.cos(phi), np.sin(phi), zero], axis=-1)


def held_values(params: LayeredParams, backend: str, plan: EffectPlan | None = None) -> dict:
    """The shader's input values as the sockets of ``backend`` hold them (float32): what the shader reads,
    and what reading a material's sockets back gives again.  With ``plan``, only those it reads: a layer
    given by its IOR and Dispersion does not read the three indices (derived from them, they may differ in
    their last bit once read back), one given by its three indices not the IOR and Dispersion."""
    values = socket_values({spec.name: getattr(params, spec.name) for spec in iter_sockets()}, backend)
    unread = () if plan is None else ("layer_ior", "layer_dispersion") if plan.index == "channels" else \
        ("r1_r", "r1_g", "r1_b")
    return {k: float(np.float32(v)) for k, v in values.items() if k not in unread}
