"""An option of the command line (:class:`OptionSpec`) and the readers its values go through.  The options
themselves are declared in :mod:`.option_table` (and ``fit``'s in :mod:`.fit_options`).

Nothing here imports bpy.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

from ..model import policy
from ..model.params import ParameterError
from ..model.presets import PRESETS
from .option_values import OPTION_ALLOWED, check_plain, float_option, int_option, shown

HDRI_ALLOWED = "the name of one of Blender's bundled HDRIs (forest, courtyard, ...)"


@dataclass(frozen=True)
class OptionSpec:
    """An option: its name (the key in a job file, ``--name-with-dashes`` on the command line), what it sets,
    the values it allows (shown in ``--help`` and in every error), how a value is read (raising
    ParameterError naming it), the commands that take it and, per command, its default as ``--help`` says it.

    ``group``: the section of ``--help`` (and of docs/options.md) it is listed in.  ``reference_only``: the
    reference scene's (refused with a .blend, which has its own).  ``action``: ``"store_true"`` or
    ``"store_false"`` for a switch (``flag_name`` its flag where it is not the name's, ``--no-progress``).
    ``positional``: an argument without a flag.  ``field``: the request's attribute holding its value where
    it is not the name.  ``job``: a job file may hold it (the options of ``render``).  ``text``: the
    argument written ``--flag=VALUE`` (a name may start with '-').  ``as_argument``: the value as typed.
    ``goes_with``: the option it needs, refused without it (``fit --size`` goes with ``--principled``)."""

    name: str
    help: str
    allowed: str
    parse: Callable[[str, Any], Any]
    commands: tuple[str, ...]
    defaults: Mapping[str, str] = field(default_factory=dict)
    metavar: str | tuple[str, ...] = "N"
    nargs: int | str | None = None
    choices: tuple[str, ...] | None = None
    reference_only: bool = False
    group: str | None = None
    action: str | None = None
    flag_name: str | None = None
    positional: bool = False
    field: str | None = None
    job: bool = True
    text: bool = False
    as_argument: Callable[[Any], str] | None = None
    goes_with: str | None = None

    @property
    def flag(self) -> str:
        if self.positional:
            return str(self.metavar)
        return self.flag_name or "--" + self.name.replace("_", "-")

    def help_for(self, command: str) -> str:
        default = self.defaults.get(command)
        allowed = f"; {self.allowed}" if self.allowed else ""
        return f"{self.help}{allowed}" + (f" (default {default})" if default else "")

    def is_set(self, value: Any) -> bool:
        """Whether ``value`` says anything: given, and for a switch not its default."""
        return value is not None and (self.action is None or bool(value) == (self.action == "store_true"))

    def read(self, value: Any) -> Any:
        return self.parse(self.name, value)

    def to_argv(self, value: Any) -> list[str]:
        """The arguments that give this option ``value`` (read back as the same value)."""
        if self.action is not None:
            return [self.flag] if bool(value) == (self.action == "store_true") else []
        if isinstance(value, (tuple, list)) and self.as_argument is None:
            return [self.flag, *(repr(float(c)) if isinstance(c, float) else str(c) for c in value)]
        text = self.as_argument(value) if self.as_argument is not None else \
            repr(float(value)) if isinstance(value, float) else str(value)
        return [f"{self.flag}={text}"] if self.text else [self.flag, text]


# ---------------------------------------------------------------------------
# how values are read
def backend_name(name: str, value: Any) -> str:
    policy.check_backend(value)
    return value


def ints(lo: int, hi: int):
    return lambda name, value: int_option(name, value, lo, hi)


def floats(lo: float, hi: float):
    return lambda name, value: float_option(name, value, lo, hi)


def as_given(name: str, value: Any) -> Any:
    """A path or a name, checked by the command's request (relative to a job file, against the inputs)."""
    return value


def plain_text(name: str, value: Any) -> str:
    """A non-blank text of plain characters (an address, a name)."""
    if not isinstance(value, str) or not value.strip():
        raise ParameterError(name, shown(value), OPTION_ALLOWED.get(name, "a non-blank text"))
    return check_plain(name, value)


def preset_name(name: str, value: Any) -> str:
    if not isinstance(value, str) or value not in PRESETS:
        raise ParameterError(name, shown(value), "one of " + ", ".join(sorted(PRESETS)))
    return value


def hdri_name(name: str, value: Any) -> str:
    if not isinstance(value, str) or not value.strip() or "/" in value:
        raise ParameterError(name, value, HDRI_ALLOWED)
    return value


def switch(name: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ParameterError(name, shown(value), "true or false")
    return value
