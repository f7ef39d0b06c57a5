"""The error every layer raises for a bad value: the parameter's name, the value and what is
allowed (the panel, the command line and the scripts all show it as one line).  A module of
its own so that the parameter table (:mod:`.params`) and the media it reads (:mod:`.media`)
both raise it without importing each other; :func:`checked_number`, the check of a number every layer
makes."""
from __future__ import annotations

import math
from typing import Any


class ParameterError(ValueError):
    """A parameter is outside its allowed range or of the wrong kind."""

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"parameter '{name}' = {value!r} is invalid: allowed {allowed}")


def as_number(value: Any) -> float:
    """``float(value)``, refusing text that Python reads as a number but a person does not write as one:
    digits grouped by underscores (``"1_5"`` is not 15)."""
    if isinstance(value, str) and "_" in value:
        raise ValueError(f"not a number: {value!r}")
    return float(value)


def checked_number(name: str, value: Any, low: float = -math.inf, high: float = math.inf, unit: str = "") -> float:
    """``value`` as a finite number in ``[low, high]`` (not a bool, :func:`as_number`'s text); else
    :class:`ParameterError` naming ``name`` and the range (``unit`` after it: " nm")."""
    allowed = f"a number in [{low:g}, {high:g}]{unit}"
    if isinstance(value, bool):
        raise ParameterError(name, value, allowed)
    try:
        x = as_number(value)
    except (TypeError, ValueError):
        raise ParameterError(name, value, allowed) from None
    if not math.isfinite(x) or not low <= x <= high:
        raise ParameterError(name, value, allowed)
    return x
