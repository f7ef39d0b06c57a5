"""Python arithmetic on a backend's symbolic values (node sockets, OSL expressions).

A value class mixes in :class:`Arithmetic`, names its backend in ``ops`` and lists the
backend's spelling of the four operations in ``OPERATORS``; ``a + b`` then calls
``ops.binary(OPERATORS["+"], a, b)``, with Python numbers on either side.
"""
from __future__ import annotations


class Arithmetic:
    __slots__ = ()
    OPERATORS = {"+": "+", "-": "-", "*": "*", "/": "/"}

    def _bin(self, other, op, reverse=False):
        a, b = (other, self) if reverse else (self, other)
        return self.ops.binary(self.OPERATORS[op], a, b)

    def __add__(self, o):
        return self._bin(o, "+")

    def __radd__(self, o):
        return self._bin(o, "+", True)

    def __sub__(self, o):
        return self._bin(o, "-")

    def __rsub__(self, o):
        return self._bin(o, "-", True)

    def __mul__(self, o):
        return self._bin(o, "*")

    def __rmul__(self, o):
        return self._bin(o, "*", True)

    def __truediv__(self, o):
        return self._bin(o, "/")

    def __rtruediv__(self, o):
        return self._bin(o, "/", True)

    def __neg__(self):
        return self * -1.0


def kind_of(x) -> str:
    """``"float"``, ``"vector"`` (or a backend's own kind) of a symbolic value or a constant."""
    if isinstance(x, Arithmetic):
        return x.kind
    if isinstance(x, (int, float)):
        return "float"
    if isinstance(x, (tuple, list)) and len(x) == 3:
        return "vector"
    raise TypeError(f"not a shader value: {x!r}")
