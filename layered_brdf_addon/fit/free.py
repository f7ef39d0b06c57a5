"""The parameters a fit varies: which, their bounds (from the parameter table) and the
scale the optimiser moves them on.

By default every continuous parameter that the start's modes use (the plan's effects):
the layer's indices and thickness range, the lobes' exponents, the specular and diffuse
weights and the base colour; the tilt where the lower boundary is tilted, the bump
strength where it follows the thickness, the lower medium's n and k for physical optics
over a custom medium.  Not by default: the outside medium's index ``r0`` (a fact of the
scene, and it trades off with the layer's), and the noise pattern's scale, detail,
roughness and phase (a render's noise is not reproduced pixel by pixel).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..model.params import PARAM_SPECS, LayeredParams, ParameterError

_SPECS = {s.name: s for s in PARAM_SPECS}
CONTINUOUS = tuple(s.name for s in PARAM_SPECS if s.kind == "float")

# Moved on a log scale: positive, over orders of magnitude.
LOG_SCALED = ("d_min", "d_max", "e0", "e1", "noise_scale")
# Where the optimiser may go, when not the parameter's soft range: oxides' indices up to 4,
# exponents up to a mirror, thicknesses from 1 nm, a metal's index below 1.
SEARCH_RANGE = {"layer_ior": (1.0, 4.0), "layer_dispersion": (0.0, 5.0), "r1_r": (1.0, 4.0), "r1_g": (1.0, 4.0), "r1_b": (1.0, 4.0), "e0": (1.0, 100_000.0), "e1": (1.0, 100_000.0), "d_min": (1.0, 5000.0), "d_max": (1.0, 5000.0),
                "r2_r": (0.01, 10.0), "r2_g": (0.01, 10.0), "r2_b": (0.01, 10.0),
                "k2_r": (0.0, 12.0), "k2_g": (0.0, 12.0), "k2_b": (0.0, 12.0)}


def default_vary(start: LayeredParams) -> tuple[str, ...]:
    """The continuous parameters the start's modes use (see the module's docstring)."""
    names = ["r1_r", "r1_g", "r1_b", "d_min", "d_max", "e0", "e1", "ks", "kd", "base_r", "base_g", "base_b"]
    if start.normal_mode == "tilted":
        names += ["tilt", "tilt_azimuth"]
    if start.normal_mode == "correlated":
        names += ["bump_strength"]
    if start.optics == "physical" and start.lower_medium == "custom":
        names += ["r2_r", "r2_g", "r2_b", "k2_r", "k2_g", "k2_b"]
    return tuple(names)


def film_vary(start: LayeredParams) -> tuple[str, ...]:
    """What a mirror reflectance tells: the layer's indices and thickness (a uniform film,
    ``d_min``; a film stack's thickness only, its films' media and proportions kept: its period), the
    lower medium's n and k for physical optics over a custom medium."""
    names = ["d_min"] if start.stack is not None else ["r1_r", "r1_g", "r1_b", "d_min"]
    if start.optics == "physical" and start.lower_medium == "custom":
        names += ["r2_r", "r2_g", "r2_b", "k2_r", "k2_g", "k2_b"]
    return tuple(names)


def vary_for(target, start: LayeredParams, vary: Sequence[str] | None = None) -> tuple[str, ...]:
    """The parameters a fit of ``start`` to ``target`` varies: ``vary`` (checked), else what the
    target shows (a mirror reflectance, ``film_only``: :func:`film_vary`; else :func:`default_vary`);
    never ``d_max`` for a film of one thickness (``uniform_film``: it is tied to ``d_min``)."""
    names = check_vary((film_vary if getattr(target, "film_only", False) else default_vary)(start)
                       if vary is None else vary)
    if getattr(target, "uniform_film", False) and "d_max" in names:
        if "d_min" not in names:
            raise ParameterError("vary", "d_max", "d_min for a film of one thickness (its d_max follows d_min)")
        names = tuple(n for n in names if n != "d_max")
    return names


def check_vary(names: Sequence[str]) -> tuple[str, ...]:
    """Distinct names of continuous parameters; else :class:`ParameterError` naming ``vary``."""
    out = []
    for name in names:
        if name not in CONTINUOUS:
            raise ParameterError("vary", name, "names of continuous parameters: " + ", ".join(CONTINUOUS))
        if name in out:
            raise ParameterError("vary", name, "each parameter once")
        out.append(name)
    if not out:
        raise ParameterError("vary", list(names), "at least one parameter name")
    return tuple(out)


def search_range(name: str) -> tuple[float, float]:
    """The interval a fit searches for ``name``: within its hard range, its soft range unless
    :data:`SEARCH_RANGE` says otherwise."""
    spec = _SPECS[name]
    lo, hi = SEARCH_RANGE.get(name, (spec.soft_min if spec.soft_min is not None else spec.min,
                                     spec.soft_max if spec.soft_max is not None else spec.max))
    return max(lo, spec.min), min(hi, spec.max)


@dataclass(frozen=True)
class FreeParameters:
    """A vector ``x`` for the optimiser and the parameters it stands for."""

    names: tuple[str, ...]
    base: LayeredParams
    uniform: bool = False  # a film of one thickness: d_max follows d_min

    def _log(self, name: str) -> bool:
        return name in LOG_SCALED

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = zip(*(self._scaled_range(n) for n in self.names))
        return np.array(lo), np.array(hi)

    def _scaled_range(self, name: str) -> tuple[float, float]:
        lo, hi = search_range(name)
        if self._log(name):
            return math.log(max(lo, 1e-3)), math.log(max(hi, 1e-3))
        return lo, hi

    def vector(self, params: LayeredParams, margin: float = 0.0) -> np.ndarray:
        """``x`` of ``params`` clipped into the bounds; a value on a bound moved ``margin`` of
        the bounds' width inside.

        At a bound the optimiser may see no slope at all (a diffuse weight of 0 hides the base
        colour's, a black base the weight's).
        """
        lo, hi = self.bounds()
        x = np.array([math.log(max(getattr(params, n), 1e-3)) if self._log(n) else float(getattr(params, n))
                      for n in self.names])
        x = np.clip(x, lo, hi)
        inset = margin * (hi - lo)
        x = np.where(x <= lo, lo + inset, x)
        return np.where(x >= hi, hi - inset, x)

    def params(self, x: Sequence[float]) -> LayeredParams:
        """The parameters at ``x`` (the base's others); a thickness range given upside down is
        put right (``d_min`` and ``d_max`` are free alike), a uniform film's ``d_max`` is its ``d_min``.
        A value on a bound of the log scale is kept inside the range (``exp(log(hi))`` may exceed ``hi``
        by a rounding)."""
        values = {n: (min(max(math.exp(v), search_range(n)[0]), search_range(n)[1]) if self._log(n) else float(v))
                  for n, v in zip(self.names, x)}
        if self.uniform:
            values["d_max"] = values.get("d_min", self.base.d_min)
        lo = values.get("d_min", self.base.d_min)
        hi = values.get("d_max", self.base.d_max)
        if lo > hi:
            if "d_min" in values and "d_max" in values:
                values["d_min"], values["d_max"] = hi, lo
            elif "d_min" in values:
                values["d_min"] = hi
            else:
                values["d_max"] = lo
        return self.base.replace(**values)
