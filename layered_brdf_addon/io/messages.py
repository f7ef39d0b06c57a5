"""Values in messages: an error names the value it refuses, cut short, since a file's value may be a
megabyte of text or lists nested thousands of levels deep.

Plain Python: the command line, the Blender layer and the readers of files use it.
"""
from __future__ import annotations

import reprlib
from typing import Any

MAX_INT_DIGITS = 18  # digits of an integer value any option takes


class _Shown:
    """A value's short form for an error message: ``repr`` gives it as is (unquoted)."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


class _ShortRepr(reprlib.Repr):
    """``reprlib`` cut to a message line: 2 levels, 8 items, 60 characters.  An integer of
    more digits than any option takes is named, not printed: a screen of digits says
    less, and Python refuses to print one of over 4300."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict, self.maxstring, self.maxother = 2, 8, 8, 8, 60, 60

    def repr_int(self, x: int, level: int) -> str:
        return repr(x) if abs(x) < 10 ** MAX_INT_DIGITS else f"<an integer of more than {MAX_INT_DIGITS} digits>"


_SHORT_REPR = _ShortRepr()


def shown(value: Any) -> Any:
    """``value`` as an error message shows it: its repr cut short, since a file's value
    may be a megabyte of text or lists nested thousands of levels deep."""
    return _Shown(_SHORT_REPR.repr(value))
