"""The values an option may take, checked without Blender.

An option's value comes from the command line or from a file (a params file, a job's
entry); every one is first checked to be a plain value (:func:`check_plain`: a short text,
a number of few digits, a short flat list), then by its own validator (:func:`int_option`,
:func:`float_option`, :func:`parse_resolution`, :func:`parse_sun`, names and paths), which
raises :class:`ParameterError` naming the option (its value cut short by :func:`..io.messages.shown`).
Nothing here imports bpy.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any, Mapping, Sequence

from ..model.errors import checked_number
from ..model.params import PARAM_SPECS, ParameterError
from ..io.messages import MAX_INT_DIGITS, shown  # noqa: F401 (the command line's names for them)
from ..io.sidecar import MAX_RESOLUTION
from ..model.presets import PRESETS
from ..model.stack import stack_or_none

PARAM_NAMES = tuple(s.name for s in PARAM_SPECS)

# Limits on what each value, typed or read from a file, may be.
MAX_TEXT = 4096  # characters of a string value (a path, a name)
MAX_ITEMS = 16  # items of a list value (sun: 3, resolution: 2)
MAX_NAME = 200  # characters of a name
MAX_STEM_BYTES = 200  # bytes (UTF-8) of an output stem's file name

SUN_ALLOWED = ("three finite numbers X Y Z, the direction towards the sun, with a length of at least 1e-9 "
               "whose square is finite (|X|, |Y|, |Z| below about 1e154)")
NAME_ALLOWED = f"a name of 1-{MAX_NAME} characters without '/', '\\' or NUL, not starting with '.'"
RESOLUTION_ALLOWED = f"N or WxH with integers in [1, {MAX_RESOLUTION}]"
# What each option allows, for messages: joined from the option table (.option_table) when it is imported.
OPTION_ALLOWED: dict[str, str] = {}


# ---------------------------------------------------------------------------
# values too big for any option
def short_name(key: Any) -> str:
    """A key of a file as a parameter name in a message (long or odd keys cut)."""
    text = key if isinstance(key, str) else repr(shown(key))
    return text if len(text) <= 60 else text[:57] + "..."


def allowed_for(name: str) -> str:
    """What option or parameter ``name`` allows, for a message."""
    for s in PARAM_SPECS:
        if s.name == name:
            return s.allowed
    return OPTION_ALLOWED.get(name, "a plain value")


def _plain_scalar(value: Any) -> bool:
    """Whether ``value`` is a scalar any validator can take: not a list or table, a text of
    at most :data:`MAX_TEXT` characters, an integer of at most :data:`MAX_INT_DIGITS` digits."""
    if isinstance(value, (list, tuple, dict)):
        return False
    if isinstance(value, str):
        return len(value) <= MAX_TEXT
    return not isinstance(value, int) or abs(value) < 10 ** MAX_INT_DIGITS


# Parameters whose value is a table of its own (a film stack: a mapping or its JSON text), with the check that
# bounds it (at most 64 films of known fields).
STRUCTURED = {"stack": stack_or_none}


def check_plain(name: str, value: Any) -> Any:
    """``value`` if it is a plain value an option may take (a short text, a number that is not
    absurdly long, a flat list of at most :data:`MAX_ITEMS` of those); else
    :class:`ParameterError` naming ``name``.  Checked before the option's own validator,
    so that none has to cope with a megabyte of text, nested lists or a 400-digit integer.  A film stack
    (:data:`STRUCTURED`) is checked whole instead."""
    if name in STRUCTURED and isinstance(value, (Mapping, str)):
        STRUCTURED[name](value)  # checked as a whole (a stack's films and fields), its errors naming the field
        return value
    items = value if isinstance(value, (list, tuple)) else [value]
    if len(items) > MAX_ITEMS or not all(map(_plain_scalar, items)):
        raise ParameterError(short_name(name), shown(value), allowed_for(name))
    return value


PRESETS_ALLOWED = "preset names among " + ", ".join(PRESETS)


def check_preset_names(names: Sequence[Any]) -> tuple[str, ...]:
    """The presets of ``--presets`` (``gallery``, ``lookdev``): distinct known names; else
    :class:`ParameterError` naming ``presets``, the option as typed."""
    names = list(names)
    if not names or not all(isinstance(n, str) for n in names):
        raise ParameterError("presets", shown(names), PRESETS_ALLOWED)
    if len(set(names)) != len(names):
        raise ParameterError("presets", shown(names), "distinct preset names")
    for name in names:
        if name not in PRESETS:
            raise ParameterError("presets", shown(name), PRESETS_ALLOWED)
    return tuple(names)


def check_name(value: Any, name: str = "name") -> str:
    """A job or render name: used as a file name, so it is a name and not a path."""
    allowed = NAME_ALLOWED
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_NAME:
        raise ParameterError(name, shown(value), allowed)
    if any(c in value for c in "/\\\x00") or value.startswith(".") or os.path.isabs(value):
        raise ParameterError(name, shown(value), allowed + " (a name, not a path)")
    return value


def option_flag(name: str) -> str:
    """The command-line flag of an option or parameter: ``d_min`` -> ``--d-min``."""
    return "--" + name.replace("_", "-")


def int_option(name: str, value: Any, lo: int, hi: int) -> int:
    allowed = f"an integer in [{lo}, {hi}]"
    if isinstance(value, bool):
        raise ParameterError(name, value, allowed)
    try:
        x = None if isinstance(value, str) and "_" in value else \
            int(value) if not isinstance(value, float) else (int(value) if value.is_integer() else None)
    except (TypeError, ValueError):
        x = None
    if x is None or not lo <= x <= hi:
        raise ParameterError(name, value, allowed)
    return x


def float_option(name: str, value: Any, lo: float = -math.inf, hi: float = math.inf) -> float:
    return checked_number(name, value, lo, hi)


def parse_resolution(value: Any) -> tuple[int, int]:
    """``N`` (square), ``"WxH"`` or ``[W, H]`` as ``(width, height)``."""
    allowed = RESOLUTION_ALLOWED
    if isinstance(value, (list, tuple)):
        parts = list(value)
    elif isinstance(value, str) and "x" in value.lower():
        parts = value.lower().split("x")
    else:
        parts = [value, value]
    if len(parts) != 2:
        raise ParameterError("resolution", value, allowed)
    try:
        w, h = (int_option("resolution", p, 1, MAX_RESOLUTION) for p in parts)
    except ParameterError:
        raise ParameterError("resolution", value, allowed) from None
    return w, h


def parse_sun(value: Any) -> tuple[float, float, float]:
    """Three finite numbers whose direction can be taken: the direction from the scene
    towards the sun.  Refused: non-finite components, a length below 1e-9, and a squared
    length that overflows (the renderer would fall back to straight up)."""
    allowed = SUN_ALLOWED
    check_plain("sun", value)
    if isinstance(value, str):
        value = value.replace(",", " ").split()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ParameterError("sun", shown(value), allowed)
    try:
        xyz = tuple(float_option("sun", c) for c in value)
    except ParameterError:
        raise ParameterError("sun", shown(value), allowed) from None
    n2 = math.fsum(c * c for c in xyz)
    if not math.isfinite(n2) or n2 < 1e-18:
        raise ParameterError("sun", shown(value), allowed)
    return xyz  # type: ignore[return-value]


def path_option(name: str, value: Any, allowed: str) -> Path:
    """A path typed as option ``name``: a non-blank text of at most :data:`MAX_TEXT` characters
    without NUL, ``~`` expanded; else :class:`ParameterError` naming ``name`` (with ``allowed``)."""
    if not isinstance(value, str) or not value.strip() or "\x00" in value or len(value) > MAX_TEXT:
        raise ParameterError(name, shown(value), allowed)
    return Path(value).expanduser()


# Thicknesses a person is unlikely to mean in nm: thinner than a molecule (micrometres typed), or
# thicker than a tenth of a millimetre (picometres typed).
MICROMETRES_BELOW_NM = 1.0
PICOMETRES_FROM_NM = 1.0e5


def unit_notes(values: dict) -> list[str]:
    """Notes on typed values of nm parameters that look like another unit (``values``: by parameter name):
    ``--d-max 0.6`` is 0.6 nm, where 600 nm was probably meant."""
    notes = []
    for name, value in values.items():
        spec = next((s for s in PARAM_SPECS if s.name == name), None)
        if spec is None or spec.unit != "nm" or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        flag = "--" + name.replace("_", "-")
        if 0.0 < value < MICROMETRES_BELOW_NM:
            notes.append(f"{flag} {value:g} is {value:g} nm (thinner than a molecule): thickness is in nm, "
                         f"so {value * 1000:g} nm is {flag} {value * 1000:g}")
        elif value >= PICOMETRES_FROM_NM:
            notes.append(f"{flag} {value:g} is {value / 1000:g} micrometres: thickness is in nm; if you meant "
                         f"picometres, that is {flag} {value / 1000:g}")
    return notes

