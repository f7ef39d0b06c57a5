"""The pieces of OSL text the OSL backend writes: literals, expressions (:class:`Val`), statements,
the bodies of functions being written and the comments made from the program's docstrings.
bpy-free.
"""
from __future__ import annotations

import math
import re
import sys
from dataclasses import dataclass, field

from .symbolic import Arithmetic

RESERVED = set("""
and break closure color continue do else emit float for if illuminance illuminate int matrix normal not or output
point public return string struct vector void while shader surface volume displacement true false
P I N Ng u v dPdu dPdv time dtime dPdtime Ps Ci
dot cross normalize length clamp max min sqrt exp cos sin mix noise transform radians microfacet diffuse
phong_ramp isnan isfinite abs floor select
""".split())
RENAMES = {"v": "V"}

PREC_ATOM, PREC_UNARY, PREC_MUL, PREC_ADD, PREC_CMP, PREC_TERNARY = 100, 14, 13, 12, 9, 3
TOKEN = re.compile(r"\x01(\d+)\|(\d+)\x02")


def literal(x) -> str:
    """An OSL float literal."""
    x = float(x)
    if not math.isfinite(x):
        x = math.copysign(3.0e38, x) if not math.isnan(x) else 0.0
    s = f"{x:.9g}"
    return s if any(c in s for c in ".en") else s + ".0"


def vector_literal(t) -> str:
    return f"vector({', '.join(literal(c) for c in t)})"




class Val(Arithmetic):
    """An OSL expression: a reference to a statement (a token) or an atom (a global, say)."""

    __slots__ = ("ops", "ref", "kind", "token")

    def __init__(self, ops, ref: str, kind: str, token: int | None = None):
        self.ops, self.ref, self.kind, self.token = ops, ref, kind, token

    def __neg__(self):
        return self.ops.emit(self.kind, f"-{self.ops.use(self, PREC_UNARY + 1)}", PREC_UNARY)


@dataclass
class Statement:
    token: int
    kind: str
    expr: str | None  # None: declared without a value (an output of a call)
    prec: int = PREC_ATOM
    hint: str | None = None  # the Python local that holds it
    output: str | None = None  # assigned straight to this output parameter
    raw: bool = False  # a statement of its own (a call with outputs, a closure sum): always kept
    name: str = ""
    key_hint: bool = False  # the hint is an output's key: locals do not rename it


@dataclass
class FunctionBody:
    """The statements of one OSL function (or of the shader) being written."""

    name: str
    params: list = field(default_factory=list)  # (token, kind, name, is_output)
    statements: list = field(default_factory=list)
    ret: tuple | None = None  # (kind, expression)
    by_token: dict = field(default_factory=dict)
    code: object = None  # the code of the Python function this body is written from
    frame: object = None  # that function's frame, once it has made a statement

    def note_frame(self) -> None:
        """Keep the frame of the function being written, found on the stack the first time it
        makes a statement: once the function returns, its frame still holds its locals, and
        the OSL names its variables after them."""
        if self.frame is not None or self.code is None:
            return
        frame = sys._getframe(2)
        while frame is not None and frame.f_code is not self.code:
            frame = frame.f_back
        self.frame = frame


DECLARATION = {"float": "float", "vector": "vector", "int": "int"}


def doc_comment(doc: str) -> str:
    if not doc:
        return ""
    text = doc.replace("``", "").replace("*/", "* /")
    lines = text.splitlines()
    out = ["/* " + lines[0]] + [(" * " + ln).rstrip() for ln in lines[1:]]
    return "\n".join(out) + " */\n"


def run_capturing_locals(fn, ops, params: dict, settings: dict):
    """Run ``fn(ops, **params, **settings)``; return its result and its locals at return (from
    the frame its first statement noted: :meth:`FunctionBody.note_frame`)."""
    result = fn(ops, **params, **settings)
    frame = ops.body.frame
    captured = dict(frame.f_locals) if frame is not None else {}
    return result, {k: v for k, v in captured.items() if k != "ops" and not (k in params and v is params[k])}
