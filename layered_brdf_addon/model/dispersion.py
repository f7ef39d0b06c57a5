"""The layer's index from an IOR and a Dispersion, as glTF's KHR_materials_dispersion (which
Blender's glTF importer and exporter carry) defines them: an Abbe number ``V_d = 20 / Dispersion``
and the Cauchy law through the d line,

    n(lambda) = IOR + (IOR - 1) / V_d * (523655 nm^2 / lambda^2 - 1.5168),

so that ``n(587.56 nm) = IOR`` and ``n_F - n_C = (IOR - 1) / V_d``.  A Cauchy law ``A + B / lambda^2``
is what the spectral modes fit through the three channel indices: they recover this one exactly.
bpy-free, numpy-free (a shader step and plain Python share :func:`abbe_index`).
"""
from __future__ import annotations

WAVELENGTHS_NM = (645.0, 525.0, 445.0)  # the R, G, B channels' wavelengths (params.WAVELENGTHS_NM)
D_LINE_NM = 587.56
F_LINE_NM = 486.13
C_LINE_NM = 656.27
_K = 523655.0  # nm^2: D_LINE_NM^2 * 1.5168
_OFFSET = 1.5168


def abbe_index(ior, dispersion, wavelength_nm: float):
    """The index at ``wavelength_nm`` (numbers, or program values of any backend)."""
    return ior + (ior - 1.0) * dispersion * ((_K / (wavelength_nm * wavelength_nm) - _OFFSET) / 20.0)


def abbe_indices(ior, dispersion) -> tuple:
    """The indices at the R, G and B channels' wavelengths."""
    return tuple(abbe_index(ior, dispersion, lam) for lam in WAVELENGTHS_NM)


def ior_and_dispersion(n_rgb) -> tuple[float, float]:
    """The IOR and Dispersion of the Cauchy law closest (least squares in ``1 / lambda^2``) to the
    indices ``n_rgb`` at the channels' wavelengths: how a measured medium becomes the two sockets."""
    xs = [1.0 / (lam * lam) for lam in WAVELENGTHS_NM]
    mx, my = sum(xs) / 3.0, sum(n_rgb) / 3.0
    b = sum((x - mx) * (y - my) for x, y in zip(xs, n_rgb)) / sum((x - mx) ** 2 for x in xs)
    a = my - b * mx
    ior = a + b / (D_LINE_NM * D_LINE_NM)
    spread = b * (1.0 / F_LINE_NM ** 2 - 1.0 / C_LINE_NM ** 2)  # n_F - n_C
    dispersion = 20.0 * spread / (ior - 1.0) if ior > 1.0 and spread > 0.0 else 0.0
    return ior, dispersion
