"""Carrying what fed a socket into a socket of other units: an older node's "Upper Exponent" into
today's "Upper Roughness", an OSL node's Tilt in degrees into the node group's angle socket in
radians (:mod:`..model.socket_units`).

A value converts directly; a link gets a few Math nodes of the artist's own (labelled, as a
person would build them) between its source and the new socket; a keyframe's value and handles
convert point by point; a driver's expression is wrapped in the conversion (a Sum, Average,
Min or Max driver becomes the scripted expression of the same, wrapped).
"""
from __future__ import annotations

import math

from ..model import ops_numpy
from ..model.socket_units import RADIANS, ROUGHNESS, from_socket, to_socket

MAX_FRAMES = 20000  # frames of a converted curve checked (and keyed where it strays)
DRIVER_SAMPLES = 200  # values of a driver's mapping curve checked, between its first and last keys
CURVE_TOLERANCE = 1.0e-4  # how far a converted curve may stray from the old one, converted, on a frame
_LABELS = {"": "value", ROUGHNESS: "roughness", RADIANS: "radians"}


def convert_value(old: str, new: str, x: float) -> float:
    """``x``, held in units ``old``, in units ``new``."""
    if old == new:
        return x
    if old == ROUGHNESS:
        x = min(max(x, 0.0), 1.0)
    value = float(from_socket(ops_numpy, old, x))
    if new == ROUGHNESS:  # an exponent below 0 rendered as 0 (the shader clamps it): fully rough
        value = max(value, 0.0)
    return float(to_socket(new, value))


# Math node steps from a parameter's units to a socket's and back: (operation, second input, third).
_TO_PARAMETER = {ROUGHNESS: [("MAXIMUM", 1.0e-8, None), ("POWER", -4.0, None), ("MULTIPLY_ADD", 0.5, -0.5)],
                 RADIANS: [("DEGREES", None, None)]}
_FROM_PARAMETER = {ROUGHNESS: [("MAXIMUM", 0.0, None), ("MULTIPLY_ADD", 2.0, 1.0), ("POWER", -0.25, None)],
                   RADIANS: [("RADIANS", None, None)]}


def link_converted(tree, from_socket, to_socket_, old: str, new: str, *, location, parent=None) -> list:
    """Link ``from_socket`` (a value in units ``old``) to ``to_socket_`` (units ``new``) through Math
    nodes that convert it; returns the nodes made (the artist's own, labelled)."""
    steps = _TO_PARAMETER.get(old, []) + _FROM_PARAMETER.get(new, [])
    made = []
    source = from_socket
    x, y = location
    for k, (operation, b, c) in enumerate(steps):
        math_node = tree.nodes.new("ShaderNodeMath")
        math_node.operation = operation
        math_node.label = f"{_LABELS[old].capitalize()} to {_LABELS[new]} (from an older Layered BRDF)"
        math_node.location = (x + 160 * k, y)
        math_node.hide = True
        if parent is not None:
            math_node.parent = parent
        if b is not None:
            math_node.inputs[1].default_value = b
        if c is not None:
            math_node.inputs[2].default_value = c
        tree.links.new(source, math_node.inputs[0])
        source = math_node.outputs[0]
        made.append(math_node)
    tree.links.new(source, to_socket_)
    return made


_WRAP = {(ROUGHNESS, ""): "0.5 * (pow(max({x}, 1e-8), -4) - 1)", (RADIANS, ""): "degrees({x})",
         ("", ROUGHNESS): "pow(2 * max({x}, 0) + 1, -0.25)", ("", RADIANS): "radians({x})"}


def _expression(driver) -> str:
    """The driver's value as a scripted expression."""
    if driver.type == "SCRIPTED":
        return driver.expression or "0"
    names = [v.name for v in driver.variables] or ["0"]
    if driver.type == "SUM":
        return " + ".join(names)
    if driver.type == "AVERAGE":
        return f"({' + '.join(names)}) / {len(names)}"
    return f"{driver.type.lower()}({', '.join(names)})" if len(names) > 1 else names[0]


def _identity(fc) -> bool:
    """Whether a driver's curve passes its value through: no keys (Blender's older default, a
    Generator), or keys on y = x with linear extrapolation (its default since 4.x) and no modifier."""
    points = fc.keyframe_points
    if not points:
        return all(m.type == "GENERATOR" and m.mode == "POLYNOMIAL" and m.poly_order == 1
                   and tuple(m.coefficients) == (0.0, 1.0) for m in fc.modifiers)
    on_line = lambda co: abs(co[0] - co[1]) < 1e-6
    return not fc.modifiers and fc.extrapolation == "LINEAR" and all(
        on_line(p.co) and (p.interpolation == "LINEAR" or on_line(p.handle_left) and on_line(p.handle_right))
        for p in points)


def convert_fcurve(fc, old: str, new: str, is_driver: bool) -> None:
    """Make ``fc`` (keyframes or a driver of a socket that held units ``old``) give units ``new``."""
    if old == new:
        return
    if is_driver and _identity(fc):  # the driver's value is the socket's: its expression converted
        expression = _expression(fc.driver)
        if old:
            expression = _WRAP[(old, "")].format(x=expression)
        if new:
            expression = _WRAP[("", new)].format(x=expression)
        fc.driver.type = "SCRIPTED"
        fc.driver.expression = expression
        return
    if fc.keyframe_points:  # keyframes, or a driver's curve mapping its value: convert the values
        points = fc.keyframe_points
        if is_driver:  # the curve maps the driver's value: checked at fine steps of it
            first, last = points[0].co[0], points[-1].co[0]
            frames = [first + (last - first) * k / DRIVER_SAMPLES for k in range(DRIVER_SAMPLES + 1)]
        else:
            first, last = int(math.floor(points[0].co[0])), int(math.ceil(points[-1].co[0]))
            frames = range(first, min(last, first + MAX_FRAMES) + 1)
        wanted = {f: convert_value(old, new, fc.evaluate(f)) for f in frames}
        for point in points:
            for attr in ("co", "handle_left", "handle_right"):
                co = getattr(point, attr)
                setattr(point, attr, (co[0], convert_value(old, new, co[1])))
        fc.update()
        # A conversion that is not linear (an exponent into a Roughness) bends the curve between its
        # keys: keys added on the frames where it strays, until every frame renders what it did.
        for _ in range(4):
            off = [f for f, v in wanted.items() if abs(fc.evaluate(f) - v) > CURVE_TOLERANCE * (1.0 + abs(v))]
            if not off:
                break
            for f in off:
                points.insert(f, wanted[f], options={"FAST"})
            fc.update()
        return
    if is_driver:
            print(f"Layered BRDF: the driver of {fc.data_path} passes its value through modifiers that cannot be "
              f"converted from {_LABELS[old]} to {_LABELS[new]}: check it")
