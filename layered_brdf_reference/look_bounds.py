"""What each artist preset should look like, as numbers a render can be checked against (the
bounds of tests/test_looks.py; a "look" of the Asset Browser is something else: a material
marked as an asset, blender/assets.py).

A look is judged on the object's pixels of a render under an HDRI (linear Rec.709): which
hues its colourful pixels take (HSV hue in degrees: red 0, yellow 60, green 120, cyan 180,
blue 240, magenta 300), how saturated and how bright it is, and whether it mirrors its
surroundings like a metal or a glaze (the correlation of each pixel's luminance with the
environment's luminance in the mirror direction).  bpy-free: the measurements are numpy,
the render is the caller's.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from layered_brdf_addon.fit.environment import direction_to_uv

COLOURFUL = 0.15  # HSV saturation above which a pixel counts as coloured
HUE_SECTORS = 6  # red, yellow, green, cyan, blue, magenta: 60 degrees each, centred on the primaries
REFLECTION_SIGMA_PX = 2.0  # detail finer than this is what a mirror copies and diffuse light does not


@dataclass(frozen=True)
class Look:
    """Bounds on a preset's render: ``hues`` ((from, to) degrees, wrapping past 360) that hold at
    least ``hue_share`` of the colourful pixels; ``saturation`` the range of the median
    saturation; ``sectors`` the least number of hue sectors holding 5% each (a rainbow);
    ``reflects`` the least mirror correlation (None: not checked); ``luminance`` the range of
    the median luminance."""

    description: str
    hues: tuple[tuple[float, float], ...] = ()
    hue_share: float = 0.0
    saturation: tuple[float, float] = (0.0, 1.0)
    sectors: int = 0
    reflects: float | None = None
    luminance: tuple[float, float] = (0.0, np.inf)


# Measured on a 64 px sphere under Blender's forest, courtyard and interior HDRIs, 8 samples
# (tests/test_looks.py); each look must hold under all three; the bounds sit between the tuned
# presets and the looks they replaced (docs/looks.md).
LOOKS: dict[str, Look] = {
    "soap_bubble": Look("a clear film with swirls of colour", sectors=2, saturation=(0.3, 1.0),
                        reflects=0.1),
    "oil_slick": Look("rainbow bands on a dark wet base", sectors=4, saturation=(0.3, 1.0), reflects=0.25,
                      luminance=(0.0, 0.12)),
    "beetle_shell": Look("a saturated green-to-blue jewel over a dark base", hues=((90.0, 270.0),),
                         hue_share=0.6, saturation=(0.5, 1.0), reflects=0.15, luminance=(0.0, 0.25)),
    "anodised_titanium": Look("deep blue to purple (gold where thinnest) over a grey metal",
                              hues=((195.0, 355.0),), hue_share=0.45, saturation=(0.3, 1.0), reflects=0.2),
    "old_metal": Look("tarnished bronze with patchy thin films", hues=((330.0, 60.0),), hue_share=0.45,
                      saturation=(0.25, 0.8), reflects=0.1, luminance=(0.0, 0.4)),
    "glazed_clay": Look("terracotta under a glossy glaze with a thin-film sheen", hues=((330.0, 40.0),),
                        hue_share=0.7, saturation=(0.4, 1.0), reflects=0.1),
}


# The structural colours (film stacks, docs/stacks.md), under Blender's five bundled HDRIs of the docs
# (forest, courtyard, interior, sunset, city; tests/test_stack_looks.py).
STACK_LOOKS: dict[str, Look] = {
    # Green at normal incidence (the 530 nm Bragg peak), blue-shifted towards the rim as every Bragg stack is.
    "jewel_beetle": Look("a metallic green-to-blue jewel over a dark body", hues=((90.0, 260.0),),
                         hue_share=0.5, saturation=(0.5, 1.0), reflects=0.3, luminance=(0.0, 0.1)),
    "morpho_blue": Look("an electric blue sheen over a dark scale", hues=((180.0, 270.0),), hue_share=0.6,
                        saturation=(0.5, 1.0), luminance=(0.0, 0.1)),
    "nacre": Look("a pale, pearly body with soft colours", saturation=(0.0, 0.55), sectors=3,
                  luminance=(0.05, 0.3), reflects=0.2),
    "dichroic_glass": Look("clear glass that reflects bright, shifting colours", sectors=4, saturation=(0.3, 1.0),
                           reflects=0.5),
    # A dark polished stone: the top mirrors the world, the tilted lamellae add a blue schiller (the Bragg peak of
    # their 145-175 nm period) where they mirror a bright part of it.  Measured: blue 0.28 (courtyard, whose warm
    # walls the top mirrors) to 0.73 (sunset) of the coloured pixels, luminance 0.02-0.04, mirror 0.50-0.66.
    "labradorite": Look("a dark polished stone with a blue schiller", hues=((180.0, 270.0),), hue_share=0.25,
                        reflects=0.4, luminance=(0.0, 0.08)),
    # A clear lens shows what lies behind it: no hue or saturation of its own to hold; its look is to reflect
    # less than bare glass (tests/test_stack_looks.py compares their highlights under a sun).
    "coated_lens": Look("clear glass that reflects less than bare glass"),
}
LOOKS.update(STACK_LOOKS)


def _hsv(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rgb = np.maximum(np.asarray(rgb, dtype=float), 0.0)
    mx, mn = rgb.max(-1), rgb.min(-1)
    sat = np.where(mx > 0.0, (mx - mn) / np.where(mx > 0.0, mx, 1.0), 0.0)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = np.degrees(np.arctan2(np.sqrt(3.0) * (g - b), 2.0 * r - g - b)) % 360.0
    return hue, sat, mx


def luminance(rgb: np.ndarray) -> np.ndarray:
    return np.asarray(rgb, dtype=float)[..., :3] @ np.array([0.2126, 0.7152, 0.0722])


def _in_ranges(hue: np.ndarray, ranges) -> np.ndarray:
    inside = np.zeros(hue.shape, bool)
    for lo, hi in ranges:
        inside |= ((hue - lo) % 360.0) <= ((hi - lo) % 360.0)
    return inside


@dataclass
class LookStats:
    """What :func:`measure` found on a render's object pixels."""

    hue_share: float  # of the colourful pixels, the share within the look's hue ranges
    saturation: float  # median HSV saturation of the object's pixels
    sectors: int  # hue sectors holding at least 5% of the colourful pixels
    reflects: float  # correlation of luminance with the mirrored environment's luminance
    luminance: float  # median luminance
    dominant_hue: float  # the chroma-weighted circular mean hue, degrees
    sector_shares: list = field(default_factory=list)


def _high_pass(image: np.ndarray, mask: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` (H, W) minus its Gaussian blur within ``mask`` (a normalised convolution, so
    the background does not leak in): the detail finer than ``sigma`` pixels."""
    from scipy.ndimage import gaussian_filter

    m = mask.astype(float)
    blur = gaussian_filter(image * m, sigma) / np.maximum(gaussian_filter(m, sigma), 1e-6)
    return image - blur


def measure(rgb: np.ndarray, mirrored_env: np.ndarray, mask: np.ndarray, look: Look | None = None,
            sigma: float = REFLECTION_SIGMA_PX) -> LookStats:
    """Statistics of a render's object pixels: ``rgb`` (H, W, 3, linear), ``mirrored_env`` the
    environment radiance each pixel's mirror direction sees (H, W, 3), ``mask`` (H, W) the
    object's pixels.  The mirror correlation compares the detail of the two (finer than
    ``sigma`` pixels): light diffused from the sky and ground follows the environment too, but
    only a mirror copies its detail."""
    rgb = np.asarray(rgb, dtype=float)[..., :3]
    mask = np.asarray(mask, bool)
    px = rgb[mask]
    hue, sat, _ = _hsv(px)
    coloured = sat > COLOURFUL
    weights = sat * luminance(px)
    h = hue[coloured]
    share = float(_in_ranges(h, look.hues).mean()) if (look is not None and look.hues and h.size) else 0.0
    sector = ((h + 180.0 / HUE_SECTORS) % 360.0 // (360.0 / HUE_SECTORS)).astype(int)
    shares = np.bincount(sector, minlength=HUE_SECTORS) / max(h.size, 1)
    ang = np.radians(hue)
    mean = np.degrees(np.arctan2((weights * np.sin(ang)).sum(), (weights * np.cos(ang)).sum())) % 360.0
    inner = mask.copy()  # the outline's pixels mix object and background: left out
    inner[1:, :] &= mask[:-1, :]
    inner[:-1, :] &= mask[1:, :]
    inner[:, 1:] &= mask[:, :-1]
    inner[:, :-1] &= mask[:, 1:]
    lum = _high_pass(np.log(luminance(rgb) + 1e-3), mask, sigma)[inner]
    env = _high_pass(np.log(luminance(mirrored_env) + 1e-3), mask, sigma)[inner]
    reflects = float(np.corrcoef(lum, env)[0, 1]) if lum.std() > 0 and env.std() > 0 else 0.0
    return LookStats(share, float(np.median(sat)), int((shares >= 0.05).sum()), reflects,
                     float(np.median(luminance(px))), float(mean), [round(float(s), 3) for s in shares])


def failures(name: str, stats: LookStats) -> list[str]:
    """How ``stats`` break preset ``name``'s look (empty: the look holds)."""
    look = LOOKS[name]
    out = []
    if look.hues and stats.hue_share < look.hue_share:
        out.append(f"{stats.hue_share:.0%} of its colourful pixels in hues {look.hues}, wanted >= {look.hue_share:.0%} "
                   f"(dominant hue {stats.dominant_hue:.0f} deg)")
    lo, hi = look.saturation
    if not lo <= stats.saturation <= hi:
        out.append(f"median saturation {stats.saturation:.2f}, wanted {lo}-{hi}")
    if stats.sectors < look.sectors:
        out.append(f"{stats.sectors} hue sectors of 5%, wanted >= {look.sectors} ({stats.sector_shares})")
    if look.reflects is not None and stats.reflects < look.reflects:
        out.append(f"mirror correlation {stats.reflects:.2f}, wanted >= {look.reflects}")
    lo, hi = look.luminance
    if not lo <= stats.luminance <= hi:
        out.append(f"median luminance {stats.luminance:.3f}, wanted {lo}-{hi}")
    return out


def mirror_directions(normals: np.ndarray, view: np.ndarray) -> np.ndarray:
    """``view`` (towards the viewer) mirrored about ``normals`` (..., 3)."""
    v = np.asarray(view, dtype=float)
    n = np.asarray(normals, dtype=float)
    return 2.0 * (n @ v)[..., None] * n - v


def equirect_lookup(image: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Radiance of an equirectangular environment ``image`` (H, W, C, bottom row first as Blender
    stores it) in world ``directions`` (..., 3), as Blender's Environment Texture maps it
    (nearest texel)."""
    u, v = direction_to_uv(np.asarray(directions, dtype=float))
    h, w = image.shape[:2]
    x = np.clip((u * w).astype(int), 0, w - 1)
    y = np.clip((v * h).astype(int), 0, h - 1)
    return image[y, x, :3]
