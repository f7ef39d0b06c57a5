"""The surface prelude (thickness and lower normal) is the shading program's, in every backend.

Two cases the backends once disagreed on, rendered by the node group and by OSL and
compared per pixel with numpy running the same program:

* correlated lower normals on a rotated, non-uniformly scaled object: a gradient is a
  covector, so it goes to world space by the inverse transpose;
* ``d_min > d_max`` arriving through linked sockets (texture- or driver-fed values skip
  validation): ``d = d_min + (d_max - d_min) n`` still holds, the pattern runs backwards.
"""
import dataclasses

import numpy as np
import pytest

from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_reference.closures import closure_shading
from layered_brdf_reference.compare import agreement, lit_mask

from render_helpers import SUN_40

pytestmark = pytest.mark.slow

BACKENDS = ["nodes", "osl"]
HEIGHT = 64
# Object 0: rotated and non-uniformly scaled; its mesh is pre-scaled by the inverse so the
# world shape stays the unit sphere the numpy reference intersects.
ROTATION_DEG = (30.0, -20.0, 45.0)
SCALE = (2.5, 1.0, 0.4)
CORRELATED = preset("fig5_correlated").replace(thickness_mode="height", d_min=100.0, d_max=700.0,
                                              bump_strength=2.0e-3, kd=0.0)
# What the sockets receive through links: thickest at the top, thinnest at the bottom.
SWAPPED_MIN, SWAPPED_MAX = 650.0, 150.0
SWAPPED_BASE = preset("fig3_thin_film").replace(thickness_mode="height", d_min=SWAPPED_MAX, d_max=SWAPPED_MIN)


def object_matrix():
    from mathutils import Euler, Matrix

    rot = Euler([np.radians(a) for a in ROTATION_DEG], "XYZ").to_matrix()
    return rot @ Matrix.Diagonal(SCALE)


def swapped_params():
    """The parameters the swapped sockets stand for (validation would refuse them)."""
    return dataclasses.replace(SWAPPED_BASE, d_min=SWAPPED_MIN, d_max=SWAPPED_MAX)


@pytest.fixture(scope="module", params=BACKENDS)
def rendered(request):
    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes,
                                                  render_passes_osl, reset_blender, row_of_spheres)
    from layered_brdf_addon.blender.material import apply_layered_material, param_socket, shader_node

    backend = request.param
    reset_blender()
    cam = camera_for(2, HEIGHT)
    centers = row_of_spheres(2)
    spheres = build_scene(SceneSpec(camera=cam, sun=SUN_40, centers=centers, samples=1,
                                        osl=(backend == "osl")))
    m = object_matrix()
    obj = spheres[0]
    obj.data = obj.data.copy()
    obj.data.transform(m.inverted().to_4x4())
    obj.data.shade_smooth()
    obj.matrix_world = m.to_4x4()
    obj.location = centers[0]
    apply_layered_material(obj, CORRELATED, backend, name="Correlated")
    mat = apply_layered_material(spheres[1], SWAPPED_BASE, backend, name="Swapped")
    tree = mat.node_tree
    node = shader_node(mat)
    for socket, value in (("d_min", SWAPPED_MIN), ("d_max", SWAPPED_MAX)):
        v = tree.nodes.new("ShaderNodeValue")
        v.outputs[0].default_value = value
        tree.links.new(v.outputs[0], param_socket(node, socket)[0])
    # The linked sockets count as animated: re-applying keeps the thickness pattern.
    apply_layered_material(spheres[1], SWAPPED_BASE, backend, name="Swapped")
    passes = render_passes_osl() if backend == "osl" else render_passes()
    matrices = [np.array(m), None]
    expected, geo = render_spheres([CORRELATED, swapped_params()], cam, SUN_40, centers, prefer_analytic=True,
                                   shading=closure_shading, matrices=matrices)
    return dict(backend=backend, passes=passes, expected=expected, geo=geo, centers=centers, matrix=np.array(m))


def test_correlated_normals_on_a_non_uniformly_scaled_object_match_numpy(rendered):
    geo, passes = rendered["geo"], rendered["passes"]
    mask = lit_mask(geo, SUN_40.l) & (geo.sphere == 0)
    ag = agreement(passes.beauty, rendered["expected"], mask, rel_tol=0.02)
    assert ag.failing_fraction <= 0.01, f"{rendered['backend']}: {ag}"
    # The lower normal itself is the inverse-transpose one.
    sel = mask & (np.linalg.norm(passes.lower_normal, axis=-1) > 0.5)
    want = geo.extra["n1"][sel]
    got = passes.lower_normal[sel] / np.linalg.norm(passes.lower_normal[sel], axis=-1, keepdims=True)
    err = np.degrees(np.arccos(np.clip(np.sum(got * want, -1), -1.0, 1.0)))
    assert np.percentile(err, 99) < 1.0, np.percentile(err, 99)
    # ... and the scale matters: the rotation-only transform of the gradient is far off.
    n0 = geo.n0[sel]
    p_world = geo.p_world[sel] - np.asarray(rendered["centers"][0])
    m = rendered["matrix"]
    s2 = np.sum(m[:, 0] ** 2)
    naive = _naive_lower_normal(n0, p_world, m, s2)
    naive_err = np.degrees(np.arccos(np.clip(np.sum(naive * want, -1), -1.0, 1.0)))
    assert np.percentile(naive_err, 90) > 3.0 * max(np.percentile(err, 90), 0.1)


def _naive_lower_normal(n0, p_world, m, s2):
    """n1 from the gradient taken to world space as ``M g / s^2`` (right for uniform scale only)."""
    p_obj = p_world @ np.linalg.inv(m).T
    h = 1e-3
    d_of = CORRELATED.d_min + (CORRELATED.d_max - CORRELATED.d_min) * np.clip(0.5 - 0.5 * p_obj[:, 2], 0, 1)
    g_obj = np.zeros_like(p_obj)
    for k in range(3):
        q = p_obj.copy()
        q[:, k] += h
        g_obj[:, k] = (CORRELATED.d_min + (CORRELATED.d_max - CORRELATED.d_min)
                       * np.clip(0.5 - 0.5 * q[:, 2], 0, 1) - d_of) / h
    g = g_obj @ m.T / s2
    return _bend(n0, g)


def _bend(n0, g):
    g_t = g - np.sum(g * n0, -1, keepdims=True) * n0
    v = n0 + CORRELATED.bump_strength * g_t
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_swapped_thickness_range_from_sockets_runs_backwards_in_every_backend(rendered):
    geo, passes = rendered["geo"], rendered["passes"]
    sphere = geo.sphere == 1
    d = passes.thickness[sphere]
    assert d.min() >= SWAPPED_MAX - 5.0 and d.max() <= SWAPPED_MIN + 5.0
    z = geo.p_object[sphere][:, 2]
    # Thickest at the top (factor 0 gives d_min = 650), thinnest at the bottom.
    assert np.corrcoef(z, d)[0, 1] > 0.95
    np.testing.assert_allclose(d, geo.extra["d"][sphere], atol=2.0)
    mask = lit_mask(geo, SUN_40.l) & sphere
    ag = agreement(passes.beauty, rendered["expected"], mask, rel_tol=0.02)
    assert ag.failing_fraction <= 0.01, f"{rendered['backend']}: {ag}"
