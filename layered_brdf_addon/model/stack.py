"""A stack of films: the layer as many films (Bragg mirrors, nacre, beetle cuticle, coatings).

A :class:`FilmStack` is either **periodic** (a period of films repeated ``periods`` times: a
Bragg mirror, a beetle's cuticle) or a **list** (each film given once: a coating).  Each
:class:`Film` has a thickness (nm) and an index: a named medium of the measured table
(:mod:`.media`, n and k over 380-780 nm) or an IOR and a Dispersion (the Cauchy law of
:mod:`.dispersion`) with a constant extinction ``k``.  The stack lies between the outside
medium (``r0``) and the material's lower medium (``r2``, ``k2`` or a named one).

``disorder`` is the spread of the films' thicknesses across periods (the standard deviation over
the mean): a beetle's or a shell's layers are never all alike.  The optics average the
reflectance over stacks drawn with that spread (:mod:`.stack_optics`).

``domains``: tilted lamellae in a crystal (labradorite) keep their order over a domain of the stack's
films, and a stone holds many domains one under the other, apart by more than light's coherence: their
light adds as power, not as waves (:mod:`.incoherent`).  1: the stack is one coherent domain.

The material's thickness (its Thickness Min / Max, its pattern or its Thickness input) is the
stack's total thickness: it scales every film alike, so a beetle's colour still flows over the
surface.  :attr:`FilmStack.total_nm` is the stack's own total, at scale 1.

Plain Python (no numpy, no bpy): a stack is a value of the material's parameters
(``LayeredParams.stack``), read from and written to JSON (:meth:`FilmStack.from_dict`,
:meth:`FilmStack.to_dict`), every bad value refused naming the film and its field.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from typing import Any, Mapping

from .errors import ParameterError, checked_number
from .media import media_names

MAX_FILMS = 64  # films in a stack, at most (periods x films per period)
MAX_K = 10.0  # a film's extinction coefficient, at most
MAX_FILM_NM = 1.0e5  # a film's thickness, at most (100 um: far beyond coherence)
MAX_IOR = 5.0
MAX_DISPERSION = 10.0
MAX_DISORDER = 0.5
MAX_DOMAINS = 4096  # coherent domains one under the other, at most
STACK_KINDS = ("periodic", "list")
FILM_KEYS = ("medium", "thickness_nm", "ior", "dispersion", "k")
STACK_KEYS = ("kind", "films", "periods", "disorder", "domains")


def _single(x: float) -> float:
    """``x`` as a 32-bit float holds it (a Blender property's), so that a stack read back equals the one
    written."""
    return struct.unpack("f", struct.pack("f", x))[0]


def _number(name: str, value: Any, low: float, high: float, unit: str = "") -> float:
    return _single(checked_number(name, value, low, high, unit))


@dataclass(frozen=True)
class Film:
    """One film of a stack: its thickness (nm) and its index, a named ``medium`` or, where
    ``medium`` is empty, ``ior`` and ``dispersion`` (:func:`.dispersion.abbe_index`) with a
    constant extinction ``k``."""

    thickness_nm: float
    medium: str = ""
    ior: float = 1.5
    dispersion: float = 0.0
    k: float = 0.0

    def to_dict(self) -> dict:
        if self.medium:
            return {"medium": self.medium, "thickness_nm": self.thickness_nm}
        out = {"ior": self.ior, "thickness_nm": self.thickness_nm}
        if self.dispersion:
            out["dispersion"] = self.dispersion
        if self.k:
            out["k"] = self.k
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str) -> "Film":
        """The film of ``data``; ``where`` names it in errors ("stack.films[2]")."""
        if not isinstance(data, Mapping):
            raise ParameterError(where, data, "a film: {'thickness_nm': ..., 'medium': ...} or "
                                 "{'thickness_nm': ..., 'ior': ..., 'dispersion': ..., 'k': ...}")
        unknown = sorted(set(data) - set(FILM_KEYS))
        if unknown:
            raise ParameterError(f"{where}.{unknown[0]}", data[unknown[0]], "a film's field: " + ", ".join(FILM_KEYS))
        if "thickness_nm" not in data:
            raise ParameterError(f"{where}.thickness_nm", None, f"a number in [0, {MAX_FILM_NM:g}] nm (required)")
        thickness = _number(f"{where}.thickness_nm", data["thickness_nm"], 0.0, MAX_FILM_NM, " nm")
        medium = data.get("medium", "")
        if medium:
            if not isinstance(medium, str) or medium not in media_names():
                raise ParameterError(f"{where}.medium", medium, "one of " + ", ".join(media_names()))
            given = sorted(set(data) & {"ior", "dispersion", "k"})
            if given:
                raise ParameterError(f"{where}.{given[0]}", data[given[0]],
                                     "nothing: a named medium gives the film's n and k (give 'ior' without 'medium')")
            return cls(thickness, medium)
        if "ior" not in data:
            raise ParameterError(f"{where}.medium", None, "a named medium or an 'ior' (one of them is required)")
        return cls(thickness, "", _number(f"{where}.ior", data["ior"], 1.0, MAX_IOR),
                   _number(f"{where}.dispersion", data.get("dispersion", 0.0), 0.0, MAX_DISPERSION),
                   _number(f"{where}.k", data.get("k", 0.0), 0.0, MAX_K))

    @property
    def label(self) -> str:
        """The film for people: "chitin 90 nm", "IOR 1.56 90 nm"."""
        what = self.medium or f"IOR {self.ior:g}" + (f" k {self.k:g}" if self.k else "")
        return f"{what} {self.thickness_nm:g} nm"


@dataclass(frozen=True)
class FilmStack:
    """The layer as a stack of films, from the outside down (:mod:`this module's docs <.stack>`)."""

    films: tuple[Film, ...]
    periods: int = 1
    disorder: float = 0.0
    kind: str = "periodic"
    domains: int = 1
    layers: tuple[Film, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "layers", tuple(self.films) * self.periods)

    @property
    def total_nm(self) -> float:
        """The stack's thickness at scale 1 (every film once per period)."""
        return sum(f.thickness_nm for f in self.layers)

    @property
    def count(self) -> int:
        return len(self.layers)

    @property
    def size_label(self) -> str:
        """The stack's size for people: "1 film", "16 films", "64 films x 16 domains"."""
        films = f"{self.count} film{'s' if self.count != 1 else ''}"
        return films + (f" x {self.domains} domains" if self.domains > 1 else "")

    def to_dict(self) -> dict:
        out = {"kind": self.kind, "films": [f.to_dict() for f in self.films]}
        if self.kind == "periodic":
            out["periods"] = self.periods
        if self.disorder:
            out["disorder"] = self.disorder
        if self.domains > 1:
            out["domains"] = self.domains
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "stack") -> "FilmStack":
        """The stack of ``data`` (JSON), every value checked; :class:`ParameterError` names the film
        and its field ("stack.films[3].thickness_nm") and what is allowed."""
        if isinstance(data, FilmStack):
            return data
        if not isinstance(data, Mapping):
            raise ParameterError(where, data, "a stack: {'kind': 'periodic' or 'list', 'films': [...], ...}")
        unknown = sorted(set(data) - set(STACK_KEYS))
        if unknown:
            raise ParameterError(f"{where}.{unknown[0]}", data[unknown[0]], "a stack's field: " + ", ".join(STACK_KEYS))
        kind = data.get("kind", "periodic")
        if kind not in STACK_KINDS:
            raise ParameterError(f"{where}.kind", kind, "one of " + ", ".join(repr(k) for k in STACK_KINDS))
        films = data.get("films")
        if not isinstance(films, (list, tuple)) or not films:
            raise ParameterError(f"{where}.films", films, f"a list of 1 to {MAX_FILMS} films")
        if len(films) > MAX_FILMS:
            raise ParameterError(f"{where}.films", f"{len(films)} films", f"a list of 1 to {MAX_FILMS} films")
        parsed = tuple(Film.from_dict(f, f"{where}.films[{i}]") for i, f in enumerate(films))
        periods = data.get("periods", 1)
        if kind == "list" and "periods" in data and periods != 1:
            raise ParameterError(f"{where}.periods", periods, "1 for a list (or kind 'periodic')")
        most = MAX_FILMS // len(parsed)
        if isinstance(periods, bool) or not isinstance(periods, (int, float)) or periods != int(periods) or \
                not 1 <= periods <= most:
            raise ParameterError(f"{where}.periods", periods,
                                 f"a whole number in [1, {most}] ({len(parsed)} films a period, at most "
                                 f"{MAX_FILMS} films in all)")
        if sum(f.thickness_nm for f in parsed) <= 0.0:
            raise ParameterError(f"{where}.films", "0 nm in all", "films whose thicknesses add up to more than 0 nm")
        disorder = _number(f"{where}.disorder", data.get("disorder", 0.0), 0.0, MAX_DISORDER)
        domains = data.get("domains", 1)
        if isinstance(domains, bool) or not isinstance(domains, (int, float)) or domains != int(domains) or \
                not 1 <= domains <= MAX_DOMAINS:
            raise ParameterError(f"{where}.domains", domains, f"a whole number in [1, {MAX_DOMAINS}]")
        return cls(parsed, int(periods), disorder, kind, int(domains))

    def describe(self) -> str:
        """One line for people: "8 x (chitin 90 nm, air 120 nm) over ..., 1.68 um, disorder 5%"."""
        films = ", ".join(f.label for f in self.films)
        head = f"{self.periods} x ({films})" if self.kind == "periodic" and self.periods > 1 else films
        tail = f", disorder {100 * self.disorder:g}%" if self.disorder else ""
        if self.domains > 1:
            tail += f"; {self.domains} domains adding their light"
        return f"{head}: {self.count} films, {self.total_nm:g} nm{tail}"


def stack_or_none(value: Any, where: str = "stack") -> FilmStack | None:
    """``value`` as a stack: a mapping, a stack, its JSON text, or None / an empty mapping or text (no
    stack)."""
    if isinstance(value, str):
        try:
            value = json.loads(value) if value.strip() else None
        except ValueError as e:
            raise ParameterError(where, value[:60], f"a film stack as JSON ({e})") from None
    if value is None or (isinstance(value, Mapping) and not value):
        return None
    return FilmStack.from_dict(value, where)
