"""The command line's options, declared once: name, value, range, help and the commands that take them.  The
argument parsers (``--help`` with each range), the options a job file may hold, their validation and the
arguments that reproduce a render are made from :data:`SCENE_OPTIONS` (the scene: backend, samples, sun...)
and :data:`SHEET_OPTIONS` (a sheet's tiles: size, columns, look-dev samples); the options that name a
material, a file or an output stay with their command.  An option whose range differs between commands
(a tile's size) is declared once per range.

Nothing here imports bpy.
"""
from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from ..model import policy
from .option_values import OPTION_ALLOWED, SUN_ALLOWED, float_option, int_option, parse_sun

MAX_SAMPLES = 1_000_000
MAX_SEED = 2**31 - 1
MAX_THREADS = 1024
MAX_SUN_STRENGTH = 1.0e6
MAX_COLUMNS = 64
GALLERY_SIZE, GALLERY_SIZES = 128, (16, 4096)  # pixels per tile: the default, the range
GALLERY_SAMPLES = 16
# The look-dev sheet, sized for about a minute on two cores (measured: docs/looks.md).
LOOKDEV_SIZE, LOOKDEV_SIZES = 192, (16, 2048)
LOOKDEV_SAMPLES, LOOKDEV_SAMPLING = 32, (1, 4096)


@dataclass(frozen=True)
class OptionSpec:
    """An option: its name (the key in a job file, ``--name-with-dashes`` on the command line), what it sets,
    the values it allows (shown in ``--help`` and in every error), how a value is read (raising
    ParameterError naming it), the commands that take it and, per command, its default as ``--help`` says it.
    ``reference_only``: the reference scene's (refused with a .blend, which has its own)."""

    name: str
    help: str
    allowed: str
    parse: Callable[[str, Any], Any]
    commands: tuple[str, ...]
    defaults: Mapping[str, str] = field(default_factory=dict)
    metavar: str | tuple[str, ...] = "N"
    nargs: int | None = None
    choices: tuple[str, ...] | None = None
    reference_only: bool = False

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    def help_for(self, command: str) -> str:
        default = self.defaults.get(command)
        return f"{self.help}; {self.allowed}" + (f" (default {default})" if default else "")

    def read(self, value: Any) -> Any:
        return self.parse(self.name, value)

    def to_argv(self, value: Any) -> list[str]:
        """The arguments that give this option ``value`` (read back as the same value)."""
        if isinstance(value, (tuple, list)):
            return [self.flag, *(repr(float(c)) if isinstance(c, float) else str(c) for c in value)]
        return [self.flag, repr(float(value)) if isinstance(value, float) else str(value)]


def _backend(name: str, value: Any) -> str:
    policy.check_backend(value)
    return value


def _ints(lo: int, hi: int):
    return lambda name, value: int_option(name, value, lo, hi)


SCENE_OPTIONS = (
    OptionSpec("backend", "shader backend: the generated node group or the OSL script",
               "one of " + ", ".join(policy.BACKENDS), _backend, ("render", "gallery"),
               defaults={"render": "nodes", "gallery": "nodes"}, metavar="NAME", choices=policy.BACKENDS),
    OptionSpec("samples", "samples per pixel", f"an integer in [1, {MAX_SAMPLES}]", _ints(1, MAX_SAMPLES),
               ("render", "gallery"),
               defaults={"render": "1 on the reference sphere, exact under a zero-angle sun; a .blend's own",
                         "gallery": f"{GALLERY_SAMPLES}; one is exact under the sun, more anti-alias"}),
    OptionSpec("sun", "direction from the scene towards the zero-angle sun", SUN_ALLOWED,
               lambda name, value: parse_sun(value),
               ("render", "gallery"), defaults={"render": "0.5 -1 0.6", "gallery": "0.5 -1 0.6"},
               metavar=("X", "Y", "Z"), nargs=3, reference_only=True),
    OptionSpec("sun_strength", "sun irradiance (W/m^2)", f"a number in [0, {MAX_SUN_STRENGTH:g}]",
               lambda name, value: float_option(name, value, 0.0, MAX_SUN_STRENGTH), ("render", "gallery"),
               defaults={"render": "3", "gallery": "3"}, metavar="W_PER_M2", reference_only=True),
    OptionSpec("seed", "Cycles' sampling seed", f"an integer in [0, {MAX_SEED}]", _ints(0, MAX_SEED),
               ("render", "gallery"), defaults={"render": "0", "gallery": "0"}),
    OptionSpec("threads", "Cycles render threads", f"an integer in [1, {MAX_THREADS}]", _ints(1, MAX_THREADS),
               ("render", "gallery"), defaults={"render": "2", "gallery": "2"}),
)


SHEET_OPTIONS = (
    OptionSpec("size", "pixels per tile", f"an integer in [{GALLERY_SIZES[0]}, {GALLERY_SIZES[1]}]",
               _ints(*GALLERY_SIZES), ("gallery",), defaults={"gallery": str(GALLERY_SIZE)}, metavar="PX"),
    OptionSpec("size", "pixels per tile", f"an integer in [{LOOKDEV_SIZES[0]}, {LOOKDEV_SIZES[1]}]",
               _ints(*LOOKDEV_SIZES), ("lookdev",), defaults={"lookdev": str(LOOKDEV_SIZE)}, metavar="PX"),
    OptionSpec("samples", "samples per pixel", f"an integer in [{LOOKDEV_SAMPLING[0]}, {LOOKDEV_SAMPLING[1]}]",
               _ints(*LOOKDEV_SAMPLING), ("lookdev",), defaults={"lookdev": str(LOOKDEV_SAMPLES)}),
    OptionSpec("columns", "tiles per row", f"an integer in [1, {MAX_COLUMNS}]", _ints(1, MAX_COLUMNS),
               ("gallery", "lookdev"), defaults={"gallery": "a square grid", "lookdev": "a square grid"}),
)
# Every message names what an option allows (an option declared for two ranges: each command's own validator
# names its range; a value no option takes, the first).
OPTION_ALLOWED.update({s.name: s.allowed for s in reversed(SCENE_OPTIONS + SHEET_OPTIONS)})


def options_of(command: str, table=None) -> tuple[OptionSpec, ...]:
    """The options that ``command`` takes (``table``: :data:`SCENE_OPTIONS` and :data:`SHEET_OPTIONS` by
    default)."""
    return tuple(s for s in (SCENE_OPTIONS + SHEET_OPTIONS if table is None else table) if command in s.commands)


def add_options(parser: argparse.ArgumentParser | argparse._ArgumentGroup, command: str) -> None:
    """``command``'s options of the table on ``parser``, each with its range (and default) in ``--help``."""
    for s in options_of(command):
        kwargs: dict[str, Any] = dict(dest=s.name, default=None, help=s.help_for(command))
        if s.choices is not None:
            kwargs["choices"] = s.choices
        else:
            kwargs["metavar"] = s.metavar
        if s.nargs is not None:
            kwargs["nargs"] = s.nargs
        parser.add_argument(s.flag, **kwargs)


def read_options(command: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """``command``'s table options present in ``options``, each read (validated); ParameterError naming the
    first that is not."""
    return {s.name: s.read(options[s.name]) for s in options_of(command) if options.get(s.name) is not None}
