"""The Thickness input: a link replaces the thickness pattern, and where the lower boundary follows
the thickness, its gradient (Blender's Bump node on it in the node group, the height's derivatives
in OSL) bends the lower normal.

The spheres get a thickness that grows with object height, ``d = D0 + SLOPE z`` nm, built from
Blender's own nodes (Texture Coordinate, Separate XYZ, Math) and linked into the input: its
gradient is ``(0, 0, SLOPE)`` per object (= world) unit, so the expected thickness and lower normal
are known in closed form and the numpy reference shades them.
"""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, render_passes_osl,
                                              reset_blender, row_of_spheres)
from layered_brdf_addon.fit.cycles_closures import closure_shading
from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_addon.model.geometry import safe_normalize
from layered_brdf_addon.model.sphere import sphere_geometry
from layered_brdf_reference.compare import agreement, lit_mask

from constants import MAX_FAILING, REL_TOL, SUN_40

D0, SLOPE = 250.0, 150.0
CASES = [preset("fig4_parallel").replace(kd=0.3),
         preset("fig5_correlated").replace(bump_strength=1.5e-3, kd=0.3)]


def _link_thickness(mat):
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    xyz = tree.nodes.new("ShaderNodeSeparateXYZ")
    thickness = tree.nodes.new("ShaderNodeMath")
    thickness.operation = "MULTIPLY_ADD"
    thickness.inputs[1].default_value = SLOPE
    thickness.inputs[2].default_value = D0
    tree.links.new(coords.outputs["Object"], xyz.inputs[0])
    tree.links.new(xyz.outputs["Z"], thickness.inputs[0])
    tree.links.new(thickness.outputs[0], shader_node(mat).inputs["Thickness"])


def _render(backend):
    reset_blender()
    n = len(CASES)
    cam = camera_for(n, 96)
    centers = row_of_spheres(n)
    spheres = build_scene(SceneSpec(camera=cam, sun=SUN_40, centers=centers, samples=4, osl=backend == "osl"))
    plans = []
    for k, (obj, params) in enumerate(zip(spheres, CASES)):
        mat = apply_layered_material(obj, params, backend, name=f"Linked {k}")
        _link_thickness(mat)
        apply_layered_material(obj, params, backend, name=f"Linked {k}")  # the link changes the plan
        plans.append(shader_node(mat))
    passes = render_passes_osl() if backend == "osl" else render_passes()
    return cam, centers, passes


@pytest.fixture(scope="module", params=["nodes", "osl"])
def rendered(request):
    return request.param, *_render(request.param)


@pytest.mark.slow
def test_a_linked_thickness_replaces_the_pattern_and_its_gradient_bends_the_lower_normal(rendered):
    backend, cam, centers, passes = rendered
    geo = sphere_geometry(cam, centers)
    z = geo.p_object[..., 2]
    d = np.where(geo.mask, D0 + SLOPE * z, 0.0)
    grad = np.array([0.0, 0.0, SLOPE])
    n1 = geo.n0.copy()
    tangential = grad - geo.n0 * (geo.n0 @ grad)[..., None]
    correlated = geo.sphere == 1
    n1[correlated] = safe_normalize(geo.n0 + CASES[1].bump_strength * tangential)[correlated]
    inner = geo.mask & (np.abs(geo.n0[..., 1]) > 0.3)  # away from the silhouette, where differentials blur
    thickness_error = np.abs(passes.thickness - d)[inner]
    print(f"{backend}: thickness pass vs D0 + SLOPE z: max {thickness_error.max():.3f} nm")
    assert thickness_error.max() < 1.0
    tilt = np.degrees(np.arccos(np.clip(np.sum(safe_normalize(passes.lower_normal) * n1, -1), -1, 1)))
    bend = np.degrees(np.arccos(np.clip(np.sum(n1 * geo.n0, -1), -1, 1)))
    sel = inner & correlated
    print(f"{backend}: lower normal vs closed form: median {np.median(tilt[sel]):.3f} deg, 95% "
          f"{np.percentile(tilt[sel], 95):.3f} deg (the gradient bends it by up to {bend[sel].max():.1f} deg)")
    assert np.percentile(tilt[sel], 95) < 0.1 * bend[sel].max()
    # The shading, given the thickness and lower normal the render used (its passes, checked above).
    expected, _ = render_spheres(CASES, cam, SUN_40, centers, shading=closure_shading, thickness=passes.thickness,
                                 lower_normals=passes.lower_normal)
    mask = lit_mask(geo, SUN_40.l) & inner
    ag = agreement(passes.beauty[..., :3], expected, mask, rel_tol=REL_TOL)
    print(f"{backend}: render vs numpy {ag}")
    assert ag.failing_fraction <= MAX_FAILING, ag
