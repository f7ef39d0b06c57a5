"""The command line's options shared by every command: the parameters' options (derived from
:data:`~layered_brdf_addon.model.params.PARAM_SPECS`), a parser that reads negative numbers
as values, the exit codes, and Blender's stdout kept quiet during a render.

Exit codes: 0 success; 1 a render or a batch job failed, or an output could not be
written; 2 invalid input (nothing written); 130 interrupted (no partial files left).
"""
from __future__ import annotations

import argparse
import contextlib
import re
import sys
from pathlib import Path
from typing import Any, Iterator

from ..model.errors import as_number
from ..model.params import PARAM_SPECS, ParamSpec

EXIT_OK, EXIT_FAILED, EXIT_INVALID, EXIT_INTERRUPTED = 0, 1, 2, 130


# A token that starts like a number ("-1e2", "-.5", "-3x2", "-inf") is a value, not an option:
# argparse's own rule misses scientific notation ("-1e2": "expected one argument").
NEGATIVE_NUMBER = re.compile(r"^-(\.?\d|inf(inity)?$|nan$)", re.IGNORECASE)


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser, reading every negative number (scientific notation too) as a value."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER


# ---------------------------------------------------------------------------
# options derived from the parameter specs
def _number(text: str) -> Any:
    """A float where the text is a number; the text itself otherwise (validation names it)."""
    try:
        return as_number(text)
    except ValueError:
        return text


def _range_text(spec: ParamSpec) -> str:
    parts = [f"allowed {spec.allowed}"]
    if spec.soft_min is not None and spec.soft_max is not None:
        parts.append(f"typical {spec.soft_min:g}-{spec.soft_max:g}")
    return "; ".join(parts)


def stack_argument(text: str) -> str:
    """A film stack's option: the text of a .json file holding the stack, or the JSON itself (the
    parameters check it, naming the film and field of a bad value)."""
    path = Path(text)
    if text.strip().startswith(("{", "[")) or path.suffix.lower() != ".json":
        return text
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise argparse.ArgumentTypeError(f"cannot read the stack file {text}: {e.strerror or e}") from None


def param_help(spec: ParamSpec) -> str:
    """Help text of a parameter's option: description, unit, range, default."""
    default = f"{spec.default:g}" if spec.kind == "float" else \
        "none" if spec.kind == "stack" else str(spec.default)
    unit = f" {spec.unit}" if spec.unit and spec.kind == "float" else ""
    text = f"{spec.description} ({_range_text(spec)}; default {default}{unit})"
    return text.replace("%", "%%")


def param_metavar(spec: ParamSpec) -> str | None:
    if spec.kind == "enum":
        return "{" + ",".join(spec.options) + "}"
    if spec.unit and spec.unit.replace("/", "").isalpha():
        return spec.unit.upper().replace("/", "_PER_") if "/" in spec.unit else spec.unit.upper()
    return "X"


def add_param_options(parser: argparse.ArgumentParser) -> None:
    """One option per parameter of PARAM_SPECS (``d_min`` -> ``--d-min NM``), grouped like the specs."""
    groups: dict[str, argparse._ArgumentGroup] = {}
    for spec in PARAM_SPECS:
        group = groups.get(spec.group)
        if group is None:
            group = groups[spec.group] = parser.add_argument_group(
                f"material parameters: {spec.group.lower()}",
                "override the preset / params file; unset ones keep their value")
        flag = "--" + spec.name.replace("_", "-")
        if spec.kind == "bool":
            group.add_argument(flag, dest=spec.name, action=argparse.BooleanOptionalAction, default=None,
                               help=param_help(spec))
        elif spec.kind == "enum":
            group.add_argument(flag, dest=spec.name, choices=spec.options, default=None,
                               metavar=param_metavar(spec), help=param_help(spec))
        elif spec.kind == "stack":
            group.add_argument(flag, dest=spec.name, type=stack_argument, default=None, metavar="FILE|JSON",
                               help=param_help(spec))
        else:
            group.add_argument(flag, dest=spec.name, type=_number, default=None, metavar=param_metavar(spec),
                               help=param_help(spec))


@contextlib.contextmanager
def blender_output(verbose: bool) -> Iterator[None]:
    """Send what Blender prints on stdout (render progress) to /dev/null unless ``verbose``."""
    if verbose:
        yield
        return
    import ctypes
    import os

    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    libc = ctypes.CDLL(None)
    try:
        os.dup2(devnull, 1)
        yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
