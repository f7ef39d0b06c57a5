"""The error every layer raises for a bad value: the parameter's name, the value and what is
allowed (the panel, the command line and the scripts all show it as one line).  A module of
its own so that the parameter table (:mod:`.params`) and the media it reads (:mod:`.media`)
both raise it without importing each other."""
from __future__ import annotations

from typing import Any


class ParameterError(ValueError):
    """A parameter is outside its allowed range or of the wrong kind."""

    def __init__(self, name: str, value: Any, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"parameter '{name}' = {value!r} is invalid: allowed {allowed}")
