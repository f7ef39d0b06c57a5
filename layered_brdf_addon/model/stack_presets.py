"""Structural colour presets: stacks of films whose media and thicknesses come from the literature
(docs/stacks.md cites each), over the lower medium the structure lies on.

Each preset's thickness range is its stack's total at 0.95-1.05 (the pattern scales every film alike, so
the colour shifts over the surface as a real structure's spacing does); the media are the measured table's
(:mod:`.media`) or an IOR and k where the literature gives the layer's index and no table holds it.
"""
from __future__ import annotations

from .media import spectrum

SPREAD = 0.05  # each preset's thickness range: its stack's total, 5% either side


def quarter_wave(medium: str, design_nm: float) -> float:
    """The thickness (nm, to 0.1) of a quarter-wave film of ``medium`` at ``design_nm``: ``lambda / (4 n)``."""
    n = spectrum(medium, [design_nm])[0][0]
    return round(design_nm / (4.0 * n), 1)


def _stack_preset(stack: dict, **values) -> dict:
    total = sum(f["thickness_nm"] for f in stack["films"]) * stack.get("periods", 1)
    return dict(optics="physical", stack=stack, d_min=round(total * (1.0 - SPREAD), 1),
                d_max=round(total * (1.0 + SPREAD), 1), **values)


# Quarter-wave layers at the green peak (530 nm) of Chrysochroa fulgidissima (Stavenga et al. 2011: 16
# layers, indices 1.6-1.7), with the complex indices Noyes et al. (2007) measured for a buprestid's two
# layer types (1.68 + 0.03i, 1.55 + 0.14i).
_BEETLE = {"kind": "periodic", "periods": 8, "films": [
    {"ior": 1.68, "k": 0.03, "thickness_nm": round(530.0 / (4 * 1.68), 1)},
    {"ior": 1.55, "k": 0.14, "thickness_nm": round(530.0 / (4 * 1.55), 1)}]}
# A Morpho ridge's shelves as a multilayer (the Kinoshita group's model: cuticle 65 nm, air 130 nm, six
# lamellae), the cuticle's index as Vukusic et al. (1999) measured it (1.56 + 0.06i).
_MORPHO = {"kind": "periodic", "periods": 6, "films": [
    {"ior": 1.56, "k": 0.06, "thickness_nm": 65.0}, {"medium": "air", "thickness_nm": 130.0}]}
# Abalone nacre as Salman et al. (2021) model it: aragonite tablets (1.63) between organic layers (1.43,
# 25 nm), the tablets' thickness spread; 425 nm tablets (red abalone's 400-450 nm), the top 16.
_NACRE = {"kind": "periodic", "periods": 16, "disorder": 0.05, "films": [
    {"ior": 1.63, "thickness_nm": 425.0}, {"ior": 1.43, "thickness_nm": 25.0}]}
# A dichroic reflector (HL)^7 H of TiO2 and SiO2 quarter-waves at 550 nm (Macleod, Thin-Film Optical
# Filters, the quarter-wave stack) on glass: reflects green-yellow, passes magenta.
_H, _L = quarter_wave("tio2_amorphous", 550.0), quarter_wave("silica", 550.0)
_DICHROIC = {"kind": "list", "films": [{"medium": "tio2_amorphous", "thickness_nm": _H},
                                       {"medium": "silica", "thickness_nm": _L}] * 7 +
             [{"medium": "tio2_amorphous", "thickness_nm": _H}]}
# Labradorite's schiller: Boggild's exsolution lamellae, Ca-poor and Ca-rich plagioclase alternating, reflect
# where their period is 128-252 nm (Bragg's lambda = 2 n period across 400-790 nm).  The two lamellae take the
# ends of labradorite's index range (1.559, 1.573), in equal parts; 32 periods of 160 nm (a blue-green
# schiller, the commonest), the stack's 64-film limit (a stone holds thousands, of smaller contrast).  The
# crystal around them is labradorite of the range's middle index (1.566).  (A 5% spread of the lamellae moved
# the reflectance by at most 0.001 and cost 7 times the bake: left out.)
_LABRADORITE = {"kind": "periodic", "periods": 32, "domains": 16, "films": [
    {"ior": 1.559, "thickness_nm": 80.0}, {"ior": 1.573, "thickness_nm": 80.0}]}
# A lens's single-layer anti-reflection coating: MgF2, a quarter wave at 550 nm, on crown glass.
_AR_LENS = {"kind": "list", "films": [{"medium": "mgf2", "thickness_nm": quarter_wave("mgf2", 550.0)}]}

STACK_PRESETS: dict[str, dict] = {
    # Glossy elytra over a dark, pigmented cuticle: what the stack passes is absorbed.
    "jewel_beetle": _stack_preset(_BEETLE, lower_medium="chitin", e0=400.0, ks=1.0, kd=0.0),
    # The ridges spread their light widely (rough), over the melanised ground scale.
    "morpho_blue": _stack_preset(_MORPHO, lower_medium="air", e0=12.0, ks=1.0, kd=0.0),
    # Nacre's milky body shows through the tablets.
    "nacre": _stack_preset(_NACRE, lower_medium="custom", r2_r=1.63, r2_g=1.63, r2_b=1.63, e0=600.0, ks=1.0,
                           kd=0.3, base_r=0.45, base_g=0.43, base_b=0.4),
    # A polished slab cut 12 degrees off the lamellae's plane, a dark body (magnetite and ilmenite inclusions);
    # the lamellae's period drifts from patch to patch (145-175 nm: blue to yellow-green).
    "labradorite": dict(optics="physical", stack=_LABRADORITE, normal_mode="tilted", tilt=12.0, layer_index="ior",
                        layer_ior=1.566, layer_dispersion=0.0, lower_medium="custom", r2_r=1.566, r2_g=1.566,
                        r2_b=1.566, d_min=round(64 * 72.5, 1), d_max=round(64 * 87.5, 1), noise_scale=2.5,
                        noise_detail=3.0, e0=2000.0, e1=3000.0, ks=1.0, kd=1.0, base_r=0.02, base_g=0.02,
                        base_b=0.024),
    "dichroic_glass": _stack_preset(_DICHROIC, lower_medium="glass", e0=3000.0, ks=1.0, kd=0.0,
                                    base_layer="transparent", base_r=0.0, base_g=0.0, base_b=0.0),
    "coated_lens": _stack_preset(_AR_LENS, lower_medium="glass", e0=3000.0, ks=1.0, kd=0.0,
                                 base_layer="transparent", base_r=0.0, base_g=0.0, base_b=0.0),
}

STACK_LABELS: dict[str, str] = {
    "jewel_beetle": "Jewel beetle (Bragg stack)", "morpho_blue": "Morpho blue", "nacre": "Nacre (abalone)",
    "dichroic_glass": "Dichroic glass", "coated_lens": "Coated lens (MgF2)", "labradorite": "Labradorite (schiller)",
}
