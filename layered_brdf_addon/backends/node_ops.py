"""Blender shader-node backend of the shading program.

Values are :class:`Expr` (an output socket and its kind, ``"float"`` or
``"vector"``) or Python floats (constants, folded into node inputs).  Every
operation adds one node; Blender's Math nodes are already guarded (division by
zero gives 0, square roots of negatives 0), which matches ``ops_numpy``.
"""
from __future__ import annotations

import contextlib
import math
from typing import Any

from .symbolic import Arithmetic, kind_of

Number = (int, float)


class Expr(Arithmetic):
    """An output socket of the tree being built, and its kind."""

    __slots__ = ("ops", "socket", "kind", "depth")
    OPERATORS = {"+": "ADD", "-": "SUBTRACT", "*": "MULTIPLY", "/": "DIVIDE"}

    def __init__(self, ops: "NodeOps", socket, kind: str, depth: int = 0):
        self.ops, self.socket, self.kind, self.depth = ops, socket, kind, depth


_kind = kind_of


def _place(node, xy) -> None:
    """Put ``node`` at ``xy`` in the tree's space (inside a frame too: Blender 4.4+ keeps
    ``location`` relative to the frame)."""
    if hasattr(node, "location_absolute"):
        node.location_absolute = xy
    else:
        node.location = xy


def _location(node) -> tuple[float, float]:
    return tuple(node.location_absolute if hasattr(node, "location_absolute") else node.location)


class NodeOps:
    """Adds nodes to ``tree``; lays them out in columns by dependency depth."""

    COLUMN = 170
    ROW = 60  # the nodes are collapsed

    def __init__(self, tree, x0: float = 0.0, y0: float = 0.0, subgroup_name=None, stamp=""):
        self.tree = tree
        self.stamp = stamp
        self.subgroup_name = subgroup_name or (lambda key: f"{tree.name} {key}")
        self.x0, self.y0 = x0, y0
        self._rows: dict[int, int] = {}
        self._memo: dict = {}
        self.count = 0
        self._stage = None  # the stage being built: (its frame, its rows per depth)
        self._stages: list = []  # every stage, in build order

    # node plumbing ---------------------------------------------------------
    @staticmethod
    def _key_of(value):
        if isinstance(value, Expr):
            return ("s", value.socket.as_pointer())
        if isinstance(value, Number):
            return ("c", float(value))
        return ("v", tuple(float(c) for c in value))

    def node(self, idname: str, inputs: dict[Any, Any] = (), depth: int | None = None, **props):
        """Add a node, or reuse an identical one (same type, settings and inputs)."""
        inputs = dict(inputs)
        key = None
        if depth is None:
            key = (idname, tuple(sorted((k, str(v)) for k, v in props.items())),
                   tuple(sorted((str(k), self._key_of(v)) for k, v in inputs.items())))
            if key in self._memo:
                return self._memo[key]
        n = self.tree.nodes.new(idname)
        for k, v in props.items():
            setattr(n, k, v)
        dmax = 0
        for name, value in inputs.items():
            sock = self._input(n, name)
            if isinstance(value, Expr):
                self.tree.links.new(value.socket, sock)
                dmax = max(dmax, value.depth)
            elif isinstance(value, Number):
                sock.default_value = float(value)
            else:
                sock.default_value = tuple(float(c) for c in value)
        d = dmax + 1 if depth is None else depth
        row = self._rows.get(d, 0)
        self._rows[d] = row + 1
        if self._stage is not None:  # rows counted within the stage; stack_stages() moves the bands
            frame, rows = self._stage
            row = rows.get(d, 0)
            rows[d] = row + 1
            n.parent = frame
        _place(n, (self.x0 + d * self.COLUMN, self.y0 - row * self.ROW))
        n.hide = True
        self.count += 1
        if key is not None:
            self._memo[key] = (n, d)
        return n, d

    @contextlib.contextmanager
    def stage(self, title):
        """Nodes built inside are framed together under ``title``, a band of their own."""
        frame = self.tree.nodes.new("NodeFrame")
        frame.label = title
        frame.label_size = 28
        outer = self._stage
        self._stage = (frame, {})
        self._stages.append(self._stage)
        try:
            yield frame
        finally:
            self._stage = outer

    def stack_stages(self, gap: float = 120.0) -> None:
        """Move each stage's band of nodes below the previous one, so that the frames don't overlap."""
        top = self.y0
        for frame, rows in self._stages:
            if not rows:  # a stage the plan leaves out (parallel boundaries: no lower normal to build)
                self.tree.nodes.remove(frame)
                continue
            height = max(rows.values(), default=0) * self.ROW
            for n in self.tree.nodes:
                if n.parent == frame:
                    x, y = _location(n)
                    _place(n, (x, y - self.y0 + top))
            top -= height + gap

    @staticmethod
    def _input(node, key):
        if isinstance(key, int):
            return node.inputs[key]
        for s in node.inputs:
            if s.identifier == key and s.enabled:
                return s
        for s in node.inputs:
            if s.identifier == key:
                return s
        return node.inputs[key]

    def out(self, node, depth, key, kind) -> Expr:
        sock = node.outputs[key] if isinstance(key, int) else next(s for s in node.outputs if s.identifier == key)
        return Expr(self, sock, kind, depth)

    def math(self, op, a, b=0.0, c=None) -> Expr:
        ins = {0: a, 1: b}
        if c is not None:
            ins[2] = c
        n, d = self.node("ShaderNodeMath", ins, operation=op)
        return self.out(n, d, 0, "float")

    def vmath(self, op, a, b=(0.0, 0.0, 0.0), scale=None, result="vector") -> Expr:
        ins = {0: a, 1: b}
        if scale is not None:
            ins[3] = scale
        n, d = self.node("ShaderNodeVectorMath", ins, operation=op)
        return self.out(n, d, 1 if result == "float" else 0, result)

    # binary dispatch -----------------------------------------------------
    def binary(self, op, a, b):
        ka, kb = _kind(a), _kind(b)
        # Algebraic identities with constants add no node.
        if op == "MULTIPLY" and ((isinstance(a, Number) and a == 0.0) or (isinstance(b, Number) and b == 0.0)):
            return 0.0 if "vector" not in (ka, kb) else (0.0, 0.0, 0.0)
        if op == "MULTIPLY" and isinstance(a, Number) and a == 1.0:
            return b
        if op in ("MULTIPLY", "DIVIDE") and isinstance(b, Number) and b == 1.0:
            return a
        if op == "ADD" and isinstance(a, Number) and a == 0.0 and kb == "float":
            return b
        if op in ("ADD", "SUBTRACT") and isinstance(b, Number) and b == 0.0 and ka == "float":
            return a
        if ka == "float" and kb == "float":
            if isinstance(a, Number) and isinstance(b, Number):
                return {"ADD": a + b, "SUBTRACT": a - b, "MULTIPLY": a * b,
                        "DIVIDE": a / b if b != 0 else 0.0}[op]
            return self.math(op, a, b)
        if ka == "vector" and kb == "vector":
            return self.vmath(op, a, b)
        if ka == "vector" and kb == "float" and op in ("MULTIPLY", "DIVIDE"):
            s = b if op == "MULTIPLY" else (1.0 / b if isinstance(b, Number) else self.math("DIVIDE", 1.0, b))
            return self.vmath("SCALE", a, scale=s)
        if ka == "float" and kb == "vector" and op == "MULTIPLY":
            return self.vmath("SCALE", b, scale=a)
        # A scalar meeting a channel triple: the scalar on every component.
        return self.vmath(op, self.broadcast(a), self.broadcast(b))
        raise TypeError(f"unsupported {op} between {ka} and {kb}")

    def broadcast(self, x):
        """``x`` as a vector: a scalar on every component."""
        if _kind(x) == "vector":
            return x
        if isinstance(x, Number):
            return (float(x),) * 3
        return self.combine(x, x, x)

    def _vector_args(self, *xs):
        return any(_kind(x) == "vector" for x in xs)

    # the ops interface of the shading program ------------------------------
    def is_vector(self, x):
        return _kind(x) == "vector"

    def clamp(self, x, lo, hi):
        if isinstance(x, Number):
            return min(max(x, lo), hi)
        if _kind(x) == "vector":
            return self.vmath("MINIMUM", self.vmath("MAXIMUM", x, self.broadcast(lo)), self.broadcast(hi))
        n, d = self.node("ShaderNodeClamp", {"Value": x, "Min": lo, "Max": hi})
        return self.out(n, d, 0, "float")

    def sqrt(self, x):
        if isinstance(x, Number):
            return math.sqrt(max(x, 0.0))
        if _kind(x) == "vector":  # Power with exponent 0.5 of the non-negative part
            return self.vmath("POWER", self.vmath("MAXIMUM", x, (0.0, 0.0, 0.0)), (0.5, 0.5, 0.5))
        return self.math("SQRT", x)

    def exp(self, x):
        if isinstance(x, Number):
            return math.exp(min(x, 80.0))
        if _kind(x) == "vector":
            return self.vmath("POWER", (math.e,) * 3, self.vmath("MINIMUM", x, (80.0, 80.0, 80.0)))
        return self.math("EXPONENT", self.math("MINIMUM", x, 80.0))

    def cos(self, x):
        if isinstance(x, Number):
            return math.cos(x)
        return self.vmath("COSINE", x) if _kind(x) == "vector" else self.math("COSINE", x)

    def sin(self, x):
        if isinstance(x, Number):
            return math.sin(x)
        return self.vmath("SINE", x) if _kind(x) == "vector" else self.math("SINE", x)

    def atan2(self, y, x):
        return self.math("ARCTAN2", y, x)

    def acos(self, x):
        if isinstance(x, Number):
            return math.acos(min(max(x, -1.0), 1.0))
        return self.math("ARCCOSINE", x)  # Blender's guards: acos of the value clamped to [-1, 1]

    def maximum(self, a, b):
        if isinstance(a, Number) and isinstance(b, Number):
            return max(a, b)
        if self._vector_args(a, b):
            return self.vmath("MAXIMUM", self.broadcast(a), self.broadcast(b))
        return self.math("MAXIMUM", a, b)

    def minimum(self, a, b):
        if isinstance(a, Number) and isinstance(b, Number):
            return min(a, b)
        if self._vector_args(a, b):
            return self.vmath("MINIMUM", self.broadcast(a), self.broadcast(b))
        return self.math("MINIMUM", a, b)

    def _vector_greater(self, a, b):
        """Per component, 1 where ``a > b`` else 0: ``max(sign(a - b), 0)``."""
        diff = a if isinstance(b, Number) and b == 0.0 else self.vmath("SUBTRACT", self.broadcast(a),
                                                                        self.broadcast(b))
        return self.vmath("MAXIMUM", self.vmath("SIGN", diff), (0.0, 0.0, 0.0))

    def lt(self, a, b):
        if self._vector_args(a, b):
            return self._vector_greater(b, a)
        return self.math("LESS_THAN", a, b)

    def gt(self, a, b):
        if self._vector_args(a, b):
            return self._vector_greater(a, b)
        return self.math("GREATER_THAN", a, b)

    def _mix_node(self, factor, a, b, kind, clamp, factor_mode="UNIFORM"):
        """One Mix node, ``a + (b - a) factor`` of ``kind`` ("float" or "vector"), the factor clamped to [0, 1]
        with ``clamp``; a vector's factor is a scalar ("UNIFORM") or per component ("NON_UNIFORM")."""
        suffix = "Vector" if kind == "vector" else "Float"
        props = dict(data_type=suffix.upper(), clamp_factor=clamp)
        if kind == "vector":
            props["factor_mode"] = factor_mode
        fac = "Factor_Vector" if factor_mode == "NON_UNIFORM" else "Factor_Float"
        n, d = self.node("ShaderNodeMix", {fac: factor, f"A_{suffix}": a, f"B_{suffix}": b}, **props)
        return self.out(n, d, f"Result_{suffix}", kind)

    def select(self, c, a, b):
        if isinstance(a, Number) and isinstance(b, Number) and a == b:
            return a
        if self._vector_args(c, a, b):
            if _kind(c) != "vector":
                return self.select_vec(c, self.broadcast(a), self.broadcast(b))
            # Per component: a Mix node with a vector factor.
            return self._mix_node(c, self.broadcast(b), self.broadcast(a), "vector", True, "NON_UNIFORM")
        return self._mix_node(c, b, a, "float", True)

    def mix(self, a, b, t):
        """``a + (b - a) t``: one Mix node (unclamped), of vectors where ``a`` or ``b`` is one."""
        if all(isinstance(x, Number) for x in (a, b, t)):
            return a + (b - a) * t
        if self._vector_args(a, b):
            return self._mix_node(t, self.broadcast(a), self.broadcast(b), "vector", False)
        return self._mix_node(t, a, b, "float", False)

    def select_vec(self, c, a, b):
        return self._mix_node(c, b, a, "vector", True)

    def dot(self, a, b):
        return self.vmath("DOT_PRODUCT", a, b, result="float")

    def length(self, a):
        return self.vmath("LENGTH", a, result="float")

    def cross(self, a, b):
        return self.vmath("CROSS_PRODUCT", a, b)

    def combine(self, x, y, z):
        """A vector from three scalars (Combine XYZ)."""
        if all(isinstance(a, Number) for a in (x, y, z)):
            return (float(x), float(y), float(z))
        n, d = self.node("ShaderNodeCombineXYZ", {"X": x, "Y": y, "Z": z})
        return self.out(n, d, 0, "vector")

    def normalize(self, v, fallback):
        """Unit ``v``; ``fallback`` where ``|v|^2 <= 1e-20`` (and where it is NaN: comparisons fail)."""
        ok = self.gt(self.dot(v, v), 1e-20)
        return self.select_vec(ok, self.vmath("NORMALIZE", v), fallback)

    def unit(self, v):
        """``v`` over its length (Normalize: the zero vector stays zero)."""
        return self.vmath("NORMALIZE", v)

    def closure_normal(self, v, fallback):
        """A closure's Normal: ``v`` as it is, since the BSDF nodes normalise their Normal themselves (Cycles
        falls back to the shading normal where it is zero, EEVEE normalises it safely)."""
        return v

    def after(self, state, x):
        """``x``, made to wait for every value of ``state``: ``max(x, x - sum |s|)`` is ``x``, but
        Cycles cannot see it, so it evaluates what depends on ``x`` after the whole state and
        only the running state stays alive on SVM's stack (255 floats)."""
        size = 0.0
        for s in state:
            size = size + (self.length(s) if _kind(s) == "vector" else s)
        return self.maximum(x, x - size)

    def named(self, hint, x):
        return x

    def clamp_input(self, x, lo, hi):
        """An input clamped to its parameter's range; NaN gives ``lo``.

        ``Maximum(lo, x)`` first: Cycles' Maximum gives ``lo`` for a NaN ``x`` both when it
        runs (a linked texture) and when it folds a constant (a driver's value) with ``lo``
        as its first operand, where a Clamp node alone lets a folded NaN through.
        """
        return self.clamp(self.maximum(lo, x), lo, hi)

    def abs(self, x):
        if isinstance(x, Number):
            return abs(x)
        return self.vmath("ABSOLUTE", x) if _kind(x) == "vector" else self.math("ABSOLUTE", x)

    def floor(self, x):
        if isinstance(x, Number):
            return float(math.floor(x))
        return self.math("FLOOR", x)

    def sign(self, x):
        if isinstance(x, Number):
            return float((x > 0) - (x < 0))
        return self.math("SIGN", x)

    def nan_to_zero(self, x):
        """``x``, or 0 where it is NaN: ``Maximum(0, x) + Minimum(0, x)`` (see clamp_input)."""
        return self.maximum(0.0, x) + self.minimum(0.0, x)

    def madd(self, a, b, c):
        """``a * b + c`` as one Multiply Add node (Math or Vector Math)."""
        if all(isinstance(v, Number) for v in (a, b, c)):
            return a * b + c
        if self._vector_args(a, b, c):
            n, d = self.node("ShaderNodeVectorMath", {0: self.broadcast(a), 1: self.broadcast(b),
                                                      2: self.broadcast(c)}, operation="MULTIPLY_ADD")
            return self.out(n, d, 0, "vector")
        n, d = self.node("ShaderNodeMath", {0: a, 1: b, 2: c}, operation="MULTIPLY_ADD")
        return self.out(n, d, 0, "float")

    def power(self, x, p):
        """``x ** p`` for ``x > 0`` (one Power node)."""
        if isinstance(x, Number):
            return x ** p
        return self.vmath("POWER", x, self.broadcast(p)) if _kind(x) == "vector" else self.math("POWER", x, p)

    def footprint(self, x):
        """How much ``x`` changes across the pixel: unknown (SVM has no derivatives of
        arbitrary values), ``None``."""
        return None

    def triple(self, x, y, z):
        """A constant channel triple (a Combine XYZ node, which Cycles folds)."""
        n, d = self.node("ShaderNodeCombineXYZ", {"X": float(x), "Y": float(y), "Z": float(z)})
        return self.out(n, d, 0, "vector")

    def components(self, v):
        """The three scalars of a vector (Separate XYZ)."""
        n, d = self.node("ShaderNodeSeparateXYZ", {"Vector": v})
        return tuple(self.out(n, d, k, "float") for k in range(3))

    # sub-programs -----------------------------------------------------------
    def function(self, fn, values, settings):
        """A named step of the program: inlined (a sub-group per small step costs more nodes)."""
        return fn(self, *values, **settings)

    def call(self, name, fn, inputs, **static):
        """Instance of a sub-group running ``fn`` (built once per name and static settings)."""
        key = name + "".join(f" {k}={v}" for k, v in sorted(static.items()))
        group = self._subgroup(key, fn, inputs, static)
        n, d = self.node("ShaderNodeGroup", {k: v for k, v in inputs.items()}, node_tree=group)
        return {s.name: Expr(self, s, "vector" if s.type == "VECTOR" else "float", d) for s in n.outputs}

    def _subgroup(self, key, fn, inputs, static):
        import bpy

        name = self.subgroup_name(key)
        group = bpy.data.node_groups.get(name)
        if group is not None and group.library is None and group.get("layered_brdf_stamp") == self.stamp:
            return group  # current: shared by every group that uses it
        if group is None or group.library is not None:
            group = bpy.data.node_groups.new(name, "ShaderNodeTree")
        # Rebuilding in place keeps the instances in other groups pointing at it, but their
        # links to the old sockets are lost: callers rebuild those groups (stamps differ too).
        group.nodes.clear()
        group.interface.clear()
        for k, v in inputs.items():
            kind = _kind(v)
            group.interface.new_socket(k, in_out="INPUT",
                                       socket_type="NodeSocketVector" if kind == "vector" else "NodeSocketFloat")
        sub = NodeOps(group, x0=200.0, subgroup_name=self.subgroup_name, stamp=self.stamp)
        gin = group.nodes.new("NodeGroupInput")
        gin.location = (-200.0, 0.0)
        args = {k: Expr(sub, gin.outputs[k], _kind(v), 0) for k, v in inputs.items()}
        outs = fn(sub, **args, **static)
        gout = group.nodes.new("NodeGroupOutput")
        for k, v in outs.items():
            kind = _kind(v)
            group.interface.new_socket(k, in_out="OUTPUT",
                                       socket_type="NodeSocketVector" if kind == "vector" else "NodeSocketFloat")
        for k, v in outs.items():
            if isinstance(v, Expr):
                group.links.new(v.socket, gout.inputs[k])
            else:
                gout.inputs[k].default_value = v
        gout.location = (sub.x0 + (max(sub._rows, default=0) + 2) * sub.COLUMN, 0.0)
        group["layered_brdf_node_count"] = sub.count
        group["layered_brdf_stamp"] = self.stamp
        self.count += sub.count
        return group
