"""OSL backend of the shading program: running the program writes OSL source.

Values are :class:`Val` (an OSL expression and its kind, ``"float"``, ``"vector"`` or
``"int"`` for comparisons) or Python floats (constants, written as literals).  Every
:func:`~..model.program.shader_function` step and every ``ops.call`` sub-program becomes
one OSL function of the same name, emitted once and called wherever the program calls
it.  Temporaries take the names of the Python locals that hold them; a temporary used
once and not named is written inline; one never used is dropped.  bpy-free.
"""
from __future__ import annotations

import contextlib
import inspect
import math

from .osl_text import (DECLARATION, PREC_ADD, PREC_ATOM, PREC_CMP, PREC_MUL, PREC_TERNARY, RENAMES, RESERVED, TOKEN,
                       FunctionBody, Statement, Val, doc_comment, literal, run_capturing_locals, vector_literal)
from .symbolic import kind_of

Number = (int, float)

# Identifiers a temporary may not take: OSL keywords, globals and the functions we call.
class OslOps:
    """Writes OSL: functions (in the order they are first needed) and one body at a time."""

    def __init__(self):
        self.functions: dict[tuple, tuple[str, str, list]] = {}  # key -> (name, source, output kinds)
        self.order: list[tuple] = []  # keys, in the order the functions were first needed
        self._names: dict[str, set] = {}
        self._bodies: list[FunctionBody] = []
        self._count = 0
        self._return_kind: dict = {}
        self._output_keys: dict = {}

    # ------------------------------------------------------------------ statements
    @property
    def body(self) -> FunctionBody:
        return self._bodies[-1]

    def _new_token(self) -> int:
        self._count += 1
        return self._count

    def emit(self, kind: str, expr: str | None, prec: int = PREC_ATOM, raw: bool = False) -> Val:
        self.body.note_frame()
        st = Statement(self._new_token(), kind, expr, prec, raw=raw)
        self.body.statements.append(st)
        self.body.by_token[st.token] = st
        return Val(self, "", kind, st.token)

    def stage(self, title):
        """A stage of the program (the node backend frames its nodes); the OSL source is already
        one named function per step."""
        return contextlib.nullcontext()

    def raw(self, text: str) -> None:
        """A statement of the body that is not a value (a closure sum, say)."""
        self.body.note_frame()
        st = Statement(self._new_token(), "void", text, raw=True)
        self.body.statements.append(st)

    def use(self, x, min_prec: int = 0) -> str:
        """The text of value ``x`` inside an expression that needs precedence ``min_prec``."""
        if isinstance(x, Val):
            if x.token is None:
                return x.ref  # an atom: an identifier or a call
            return f"\x01{x.token}|{min_prec}\x02"
        if isinstance(x, Number):
            s = literal(x)
            return f"({s})" if s.startswith("-") and min_prec > PREC_ADD else s
        return vector_literal(x)

    def atom(self, text: str, kind: str) -> Val:
        return Val(self, text, kind)

    def call_expr(self, fname: str, args, kind: str) -> Val:
        return self.emit(kind, f"{fname}({', '.join(self.use(a) for a in args)})")

    # ------------------------------------------------------------------ arithmetic
    def binary(self, op, a, b):
        ka, kb = kind_of(a), kind_of(b)
        if isinstance(a, Number) and isinstance(b, Number):
            return {"+": a + b, "-": a - b, "*": a * b, "/": a / b if b != 0 else 0.0}[op]
        if op == "*" and ((isinstance(a, Number) and a == 0.0) or (isinstance(b, Number) and b == 0.0)):
            return 0.0 if "vector" not in (ka, kb) else (0.0, 0.0, 0.0)
        if op == "*" and isinstance(a, Number) and a == 1.0:
            return b
        if op in "*/" and isinstance(b, Number) and b == 1.0:
            return a
        if op == "+" and isinstance(a, Number) and a == 0.0:
            return b
        if op in "+-" and isinstance(b, Number) and b == 0.0:
            return a
        kind = "vector" if "vector" in (ka, kb) else ("int" if ka == kb == "int" else "float")
        prec = PREC_MUL if op in "*/" else PREC_ADD
        return self.emit(kind, f"{self.use(a, prec)} {op} {self.use(b, prec + 1)}", prec)

    def is_vector(self, x):
        return kind_of(x) == "vector"

    def _triple(self, x, vector: bool):
        """``x`` as an argument of a per-component function: a scalar widened when needed."""
        if vector and kind_of(x) != "vector":
            return self.atom(f"vector({self.use(x)})", "vector") if not isinstance(x, Number) else \
                self.atom(f"vector({literal(x)})", "vector")
        return x

    def _unary(self, name, x, fn):
        if isinstance(x, Number):
            return fn(x)
        return self.call_expr(name, (x,), kind_of(x))

    def clamp(self, x, lo, hi):
        if isinstance(x, Number):
            return min(max(x, lo), hi)
        v = kind_of(x) == "vector"
        return self.call_expr("clamp", (x, self._triple(lo, v), self._triple(hi, v)), kind_of(x))

    def sqrt(self, x):
        return self._unary("safe_sqrt", x, lambda a: math.sqrt(max(a, 0.0)))

    def exp(self, x):
        return self._unary("safe_exp", x, lambda a: math.exp(min(a, 80.0)))

    def cos(self, x):
        return self._unary("cos", x, math.cos)

    def sin(self, x):
        return self._unary("sin", x, math.sin)

    def atan2(self, y, x):
        return self.call_expr("atan2", (y, x), "float")

    def acos(self, x):
        if isinstance(x, Number):
            return math.acos(min(max(x, -1.0), 1.0))
        return self.call_expr("acos", (self.clamp(x, -1.0, 1.0),), "float")

    def _extremum(self, name, a, b, fn):
        if isinstance(a, Number) and isinstance(b, Number):
            return fn(a, b)
        v = "vector" in (kind_of(a), kind_of(b))
        return self.call_expr(name, (self._triple(a, v), self._triple(b, v)), "vector" if v else "float")

    def maximum(self, a, b):
        return self._extremum("max", a, b, max)

    def minimum(self, a, b):
        return self._extremum("min", a, b, min)

    def _compare(self, op, a, b):
        if "vector" in (kind_of(a), kind_of(b)):  # per component, 1 or 0
            name = "greater_than" if op == ">" else "less_than"
            return self.call_expr(name, (self._triple(a, True), self._triple(b, True)), "vector")
        return self.emit("int", f"{self.use(a, PREC_CMP + 1)} {op} {self.use(b, PREC_CMP + 1)}", PREC_CMP)

    def lt(self, a, b):
        return self._compare("<", a, b)

    def gt(self, a, b):
        return self._compare(">", a, b)

    def _select(self, c, a, b, kind):
        if isinstance(c, Number):
            return a if c > 0.5 else b
        if "vector" in (kind_of(a), kind_of(b)):
            kind = "vector"
        if kind_of(c) == "vector":  # per component
            return self.call_expr("mix", (self._triple(b, True), self._triple(a, True), c), "vector")
        cond = self.use(c, PREC_TERNARY + 1) if kind_of(c) == "int" else f"{self.use(c, PREC_CMP + 1)} > 0.5"
        return self.emit(kind, f"{cond} ? {self.use(a, PREC_TERNARY + 1)} : {self.use(b, PREC_TERNARY + 1)}",
                         PREC_TERNARY)

    def select(self, c, a, b):
        if isinstance(a, Number) and isinstance(b, Number) and a == b:
            return a
        return self._select(c, a, b, "float")

    def mix(self, a, b, t):
        if all(isinstance(x, Number) for x in (a, b, t)):
            return a + (b - a) * t
        vector = "vector" in (kind_of(a), kind_of(b))
        return self.call_expr("mix", (self._triple(a, vector), self._triple(b, vector), t),
                              "vector" if vector else "float")

    def select_vec(self, c, a, b):
        return self._select(c, a, b, "vector")

    def dot(self, a, b):
        for x, y in ((a, b), (b, a)):
            if isinstance(y, tuple) and sorted(y) == [0.0, 0.0, 1.0]:
                return self.emit("float", f"{self.use(x, PREC_ATOM)}[{y.index(1.0)}]")
        return self.call_expr("dot", (a, b), "float")

    def length(self, a):
        return self.call_expr("length", (a,), "float")

    def cross(self, a, b):
        return self.call_expr("cross", (a, b), "vector")

    def combine(self, x, y, z):
        if all(isinstance(c, Number) for c in (x, y, z)):
            return (float(x), float(y), float(z))
        return self.call_expr("vector", (x, y, z), "vector")

    def normalize(self, v, fallback):
        """Unit ``v``; ``fallback`` for a zero-length or non-finite ``v``."""
        return self.call_expr("safe_normalize_or", (v, fallback), "vector")

    def unit(self, v):
        """``v`` over its length (OSL's normalize: the zero vector stays zero)."""
        return self.call_expr("normalize", (v,), "vector")

    def closure_normal(self, v, fallback):
        return self.normalize(v, fallback)

    def after(self, state, x):
        return x  # OSL runs statements in order: nothing to schedule

    def named(self, hint, x):
        """Give the temporary holding ``x`` the name ``hint``."""
        if isinstance(x, Val) and x.token in self.body.by_token:
            self.body.by_token[x.token].hint = hint
        return x

    def abs(self, x):
        return self._unary("abs", x, abs)

    def floor(self, x):
        return self._unary("floor", x, lambda a: float(math.floor(a)))

    def sign(self, x):
        return self._unary("sign", x, lambda a: float((a > 0) - (a < 0)))

    def nan_to_zero(self, x):
        return self.call_expr("nan_to_zero", (x,), "float")

    def triple(self, x, y, z):
        return self.atom(vector_literal((x, y, z)), "vector")

    def madd(self, a, b, c):
        return a * b + c

    def power(self, x, p):
        return self.call_expr("pow", (x, p), kind_of(x))

    def footprint(self, x):
        """How much ``x`` changes across the pixel: OSL's ``filterwidth`` (from its derivatives)."""
        return self.call_expr("filterwidth", (x,), kind_of(x))

    def components(self, v):
        return tuple(self.emit("float", f"{self.use(v, PREC_ATOM)}[{k}]") for k in range(3))

    def clamp_input(self, x, lo, hi):
        """An input clamped to its parameter's range; NaN gives ``lo``."""
        return self.call_expr("clamp_input", (x, max(lo, -3.0e38), min(hi, 3.0e38)), "float")

    # ------------------------------------------------------------------ functions
    def function(self, fn, values, settings):
        names = list(inspect.signature(fn).parameters)[1:1 + len(values)]
        return self._invoke(fn, dict(zip(names, values)), settings)

    def call(self, name, fn, inputs, **static):
        order = [p for p in inspect.signature(fn).parameters if p in inputs]  # the signature's order
        return self._invoke(fn, {p: inputs[p] for p in order}, static)

    def _invoke(self, fn, inputs: dict, settings: dict):
        kinds = tuple((k, kind_of(v)) for k, v in inputs.items())
        key = (fn.__qualname__, tuple(sorted(settings.items())), kinds)
        if key not in self.functions:
            self._define(fn, key, kinds, settings)
        fname, _, outputs = self.functions[key]
        args = list(inputs.values())
        if outputs is None:  # one value: returned
            return self.call_expr(fname, args, self._return_kind[key])
        outs = []
        for out_name, kind in outputs:
            v = self.emit(kind, None)
            st = self.body.by_token[v.token]
            st.hint = out_name
            st.key_hint = self._output_keys[key] is not None
            outs.append(v)
        self.raw(f"{fname}({', '.join(self.use(a) for a in args + outs)});")
        keys = self._output_keys[key]
        if keys is None:
            return tuple(outs)
        return dict(zip(keys, outs))

    def _function_name(self, fn, key, settings) -> str:
        """``fn``'s name; OSL overloads it by argument types, so only a variant of other
        settings with the same types takes a suffix."""
        name = fn.__name__
        kinds = key[2]
        while any(k != key and k[2] == kinds for k in self._names.get(name, ())):
            name = "_".join([name] + [str(v) for _, v in sorted(settings.items())]) if name == fn.__name__ \
                else name + "_"
        self._names.setdefault(name, set()).add(key)
        return name

    def _define(self, fn, key, kinds, settings):
        fname = self._function_name(fn, key, settings)
        body = FunctionBody(fname, code=fn.__code__)
        self._bodies.append(body)
        params = {}
        for pname, kind in kinds:
            tok = self._new_token()
            st = Statement(tok, kind, None, hint=pname)
            body.by_token[tok] = st
            body.params.append(st)
            params[pname] = Val(self, "", kind, tok)
        result, local_names = run_capturing_locals(fn, self, params, settings)
        self._bodies.pop()
        doc = inspect.getdoc(fn) or ""
        if isinstance(result, (Val, *Number)) or (isinstance(result, tuple) and len(result) == 3
                                                 and all(isinstance(c, Number) for c in result)):
            kind = kind_of(result)
            self._return_kind[key] = kind
            body.ret = (kind, result)
            self.functions[key] = (fname, self._write(body, doc, local_names), None)
        else:
            if isinstance(result, dict):
                out_names = list(result)
                values = list(result.values())
                self._output_keys[key] = out_names
            else:
                values = list(result)
                by_id = {id(v): n for n, v in local_names.items()}
                out_names = [by_id.get(id(v), f"out{i}") for i, v in enumerate(values)]
                self._output_keys[key] = None
            outputs = [(n, kind_of(v)) for n, v in zip(out_names, values)]
            body.ret = ("outputs", list(zip(out_names, values)))
            self.functions[key] = (fname, self._write(body, doc, local_names), outputs)
        self.order.append(key)

    # ------------------------------------------------------------------ writing
    def _write(self, body: FunctionBody, doc: str, local_names: dict) -> str:
        text = self.resolve(body, local_names)
        params = ", ".join(f"{DECLARATION[p.kind]} {p.name}" for p in body.params)
        if body.ret[0] == "outputs":
            outs = ", ".join(f"output {DECLARATION[kind_of(v)]} {n}" for n, v in body.ret[1])
            params = f"{params}, {outs}" if params else outs
            rtype = "void"
        else:
            rtype = DECLARATION[body.ret[0]]
        comment = doc_comment(doc)
        head = f"{rtype} {body.name}("
        if len(head) + len(params) > 99:
            params = (",\n" + " " * len(head)).join(params.split(", "))
        return f"{comment}{head}{params})\n{{\n{text}}}\n"

    def resolve(self, body: FunctionBody, local_names: dict | None = None, indent: str = "  ",
                reserved=frozenset()) -> str:
        """The statements of ``body`` as OSL text: named, inlined where used once, pruned."""
        local_names = local_names or {}
        tail = []  # (target, expression) of outputs / return
        if body.ret is not None and body.ret[0] == "outputs":
            tail = [(n, self.use(v)) for n, v in body.ret[1]]
        elif body.ret is not None:
            tail = [(None, self.use(body.ret[1]))]
        # Names of locals; a parameter whose name a local takes over becomes NAME_in.
        params = {p.token for p in body.params}
        named_here = set()  # a value bound to two locals keeps the first one's name
        for lname, v in local_names.items():
            if isinstance(v, Val) and v.token in body.by_token and v.token not in params \
                    and not body.by_token[v.token].key_hint and v.token not in named_here:
                body.by_token[v.token].hint = lname
                named_here.add(v.token)
        hints = {st.hint for st in body.statements}
        # An output that is a named statement of its own name is written to directly.
        out_targets = set()
        for i, (target, expr) in enumerate(tail):
            m = TOKEN.fullmatch(expr)
            if target is None or m is None:
                continue
            st = body.by_token.get(int(m.group(1)))
            if st is not None and st not in body.params and st.expr is not None and st.output is None \
                    and not st.raw and st.hint in (None, target):
                st.output = target
                out_targets.add(i)
        # Use counts, dead statements removed (from the end backwards).
        texts = [st.expr or "" for st in body.statements] + [e for _, e in tail]
        uses: dict[int, int] = {}
        for t in texts:
            for m in TOKEN.finditer(t):
                uses[int(m.group(1))] = uses.get(int(m.group(1)), 0) + 1
        live = []
        for st in reversed(body.statements):
            if not st.raw and st.output is None and uses.get(st.token, 0) == 0:
                for m in TOKEN.finditer(st.expr or ""):
                    uses[int(m.group(1))] -= 1
                continue
            live.append(st)
        live.reverse()
        inline = {st.token for st in live if not st.raw and st.expr is not None and st.output is None
                  and st.hint is None and uses.get(st.token, 0) == 1}
        # Names: parameters first, then named statements, then the rest.
        taken = set(reserved)

        def unique(base):
            base = RENAMES.get(base, base)
            if base in RESERVED:
                base += "_"
            name, k = base, 2
            while name in taken:
                name, k = f"{base}_{k}", k + 1
            taken.add(name)
            return name

        outputs_named = {t for t, _ in tail if t}
        taken |= outputs_named
        for p in body.params:
            p.name = unique(p.hint + "_in" if p.hint in hints else p.hint)
        counter = 0
        for st in live:
            if st.raw and st.kind == "void":
                continue
            if st.output is not None:
                st.name = st.output
            elif st.token not in inline:
                if st.hint:
                    st.name = unique(st.hint)
                else:
                    counter += 1
                    st.name = unique(f"t{counter}")

        def render(text: str) -> str:
            def sub(m):
                tok, need = int(m.group(1)), int(m.group(2))
                st = body.by_token[tok]
                if tok in inline:
                    inner = render(st.expr)
                    return f"({inner})" if st.prec < need else inner
                return st.name

            return TOKEN.sub(sub, text)

        lines = []
        for st in live:
            if st.token in inline:
                continue
            if st.raw and st.kind == "void":
                lines.append(f"{indent}{render(st.expr)}")
            elif st.expr is None:
                lines.append(f"{indent}{DECLARATION[st.kind]} {st.name};")
            elif st.output is not None:
                lines.append(f"{indent}{st.name} = {render(st.expr)};")
            else:
                lines.append(f"{indent}{DECLARATION[st.kind]} {st.name} = {render(st.expr)};")
        for i, (target, expr) in enumerate(tail):
            if i in out_targets:
                continue
            if target is None:
                lines.append(f"{indent}return {render(expr)};")
            else:
                lines.append(f"{indent}{target} = {render(expr)};")
        return "".join(line + "\n" for line in lines)

    def source_of_functions(self) -> str:
        return "\n".join(self.functions[key][1] for key in self.order)
