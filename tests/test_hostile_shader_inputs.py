"""Hostile values reaching the shader's sockets: both backends treat every socket the same way.

A texture or a driver may feed any float: NaN (a driver's ``(1e30*1e30) - (1e30*1e30)``,
or a texture computing it per pixel), +inf or -inf.  Every material input is clamped to
its parameter's range with NaN going to the lower bound; a linked Thickness of NaN or below 0 is
0 nm (no jump to Thickness Min where a texture crosses zero); Base Color is an albedo, each
channel within [0, 1] (NaN to 0); a Normal input keeps the direction of a huge finite
vector and falls back to the shading normal when NaN or zero.  Each hostile sphere is
compared with a sphere whose socket holds the value it must be treated as, in the same
render.
"""
import math

import numpy as np
import pytest

from layered_brdf_addon.model.params import iter_sockets
from layered_brdf_addon.model.presets import preset

from constants import SUN_40

pytestmark = pytest.mark.slow

BACKENDS = ["nodes", "osl"]
PX = 16
NAN, INF = float("nan"), float("inf")
# Every effect on: noise thickness and correlated normals (bump_strength, noise inputs);
# tilted normals for the tilt inputs, computed (the shader's own clamping of its sockets: baked
# tables hold the values the add-on baked them for, test_tables_blend.py).
CORRELATED = preset("fig5_correlated").replace(kd=0.5, d_min=150.0, d_max=450.0, noise_scale=2.0)
TILTED = preset("fig6_medium").replace(tilt=14.0, tilt_azimuth=30.0, evaluation="arithmetic")
TILT_SOCKETS = {"tilt", "tilt_azimuth"}


def cases():
    """(label, base params, socket, hostile value or 'linked-nan', value it must equal)."""
    out = []
    for spec in iter_sockets():
        if spec.component is not None:
            continue  # a channel of the Base Color socket: the colour's cases below
        base = TILTED if spec.name in TILT_SOCKETS else CORRELATED
        lo, hi = spec.min, spec.max
        out += [(f"{spec.name}=nan", base, spec.name, NAN, lo),
                (f"{spec.name}=texture nan", base, spec.name, "linked-nan", lo),
                (f"{spec.name}=+inf", base, spec.name, INF, hi),
                (f"{spec.name}=-inf", base, spec.name, -INF, lo)]
    out += [("Base Color=nan", CORRELATED, "Base Color", (NAN, 0.5, 0.8, 1.0), (0.0, 0.5, 0.8, 1.0)),
            ("Base Color<0", CORRELATED, "Base Color", (-1.0, 0.5, -1e30, 1.0), (0.0, 0.5, 0.0, 1.0)),
            ("Base Color=1e30", CORRELATED, "Base Color", (1e30, 1e30, 2.0, 1.0), (1.0, 1.0, 1.0, 1.0)),
            ("Base Color=texture nan", CORRELATED, "Base Color", "linked-nan", (0.0, 0.0, 0.0, 1.0)),
            ("Thickness=texture nan", CORRELATED, "Thickness", "linked-nan", ("linked", 0.0)),
            ("Thickness<0 linked", CORRELATED, "Thickness", ("linked", -50.0), ("linked", 0.0)),
            ("Normal=huge", CORRELATED, "Normal", (0.0, -1e30, 4e29), (0.0, -1.0, 0.4)),
            ("Normal=nan", CORRELATED, "Normal", (NAN, -1.0, 0.0), None)]
    return out


# Cases whose shading is chaotic in the position (a 10^6 nm layer, noise at 10^4 per unit):
# spheres at other places differ by rounding, so their totals are compared (docs/hard-cases.md).
TOTALS_ONLY = {"d_min=+inf", "d_max=+inf", "noise_scale=+inf"}


CASES = cases()


def _socket(node, name):
    """A parameter's socket, or the Normal or Base Color socket (the node group's or the OSL name)."""
    from layered_brdf_addon.blender.material import param_socket
    from layered_brdf_addon.blender.sockets import find_socket

    if name in {spec.name for spec in iter_sockets()}:
        return param_socket(node, name)[0]
    return find_socket(node.inputs, name)


def _linked_nan(tree, socket):
    """A NaN computed per pixel (Cycles cannot fold it away): 1e30^2 - 1e30^2."""
    geo = tree.nodes.new("ShaderNodeNewGeometry")
    sep = tree.nodes.new("ShaderNodeSeparateXYZ")
    tree.links.new(geo.outputs["Position"], sep.inputs[0])

    def math(op, a, b):
        n = tree.nodes.new("ShaderNodeMath")
        n.operation = op
        for i, v in enumerate((a, b)):
            if isinstance(v, float):
                n.inputs[i].default_value = v
            else:
                tree.links.new(v, n.inputs[i])
        return n.outputs[0]

    big = math("MULTIPLY", math("ADD", math("MULTIPLY", sep.outputs[0], 1e-6), 1.0), 1e30)
    inf = math("MULTIPLY", big, big)
    tree.links.new(math("SUBTRACT", inf, inf), socket)


@pytest.fixture(scope="module", params=BACKENDS)
def rendered(request):
    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                                  row_of_spheres)
    from layered_brdf_addon.blender.material import apply_layered_material, shader_node

    backend = request.param
    reset_blender()
    n = 2 * len(CASES)
    cam = camera_for(n, PX)
    spheres = build_scene(SceneSpec(camera=cam, sun=SUN_40, centers=row_of_spheres(n), samples=1,
                                        osl=(backend == "osl")))
    for k, (label, base, name, bad, good) in enumerate(CASES):
        for j, value in enumerate((bad, good)):
            mat = apply_layered_material(spheres[2 * k + j], base, backend, name=f"{label} {j}")
            if value is None:
                continue  # the unconnected socket: the shading normal
            node = shader_node(mat)
            sock = _socket(node, name)
            if value == "linked-nan":
                _linked_nan(mat.node_tree, sock)
            elif isinstance(value, tuple) and value[0] == "linked":  # a Value node's number
                number = mat.node_tree.nodes.new("ShaderNodeValue")
                number.outputs[0].default_value = value[1]
                mat.node_tree.links.new(number.outputs[0], sock)
            elif name == "Normal":  # a vector from nodes (an OSL shader's unlinked Normal is N)
                comb = mat.node_tree.nodes.new("ShaderNodeCombineXYZ")
                for i, c in enumerate(value):
                    comb.inputs[i].default_value = c
                mat.node_tree.links.new(comb.outputs[0], sock)
            else:
                sock.default_value = value
    passes = render_passes()
    return backend, passes.beauty


@pytest.mark.parametrize("case", range(len(CASES)), ids=[c[0] for c in CASES])
def test_hostile_socket_value_renders_as_its_bound(rendered, case):
    backend, img = rendered
    bad = img[:, 2 * case * PX:(2 * case + 1) * PX]
    good = img[:, (2 * case + 1) * PX:(2 * case + 2) * PX]
    assert np.all(np.isfinite(bad)) and np.all(bad >= 0.0)
    assert good.max() > 0.0
    assert math.isclose(bad.sum(), good.sum(), rel_tol=0.01, abs_tol=1e-6), (bad.sum(), good.sum())
    if CASES[case][0] in TOTALS_ONLY:
        return
    err = np.abs(bad - good)
    fail = np.any(err > 0.02 * np.abs(good) + 0.02 * 0.01 * good.max(), axis=-1)
    assert fail.mean() <= 0.01, f"{backend} {CASES[case][0]}: {fail.mean():.3f} of pixels differ, " \
                                f"max {err.max():.3g} (totals {bad.sum():.4g} vs {good.sum():.4g})"
