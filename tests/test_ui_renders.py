"""The add-on's materials rendered: every preset with both backends against the numpy closure
form, keyframed values frame by frame, a saved file without the add-on, and EEVEE.

Renders are compared with the numpy closure form (what Cycles' closures evaluate to) at a
coarse tolerance: a pixel fails when a channel is off by more than 5% (plus a small floor),
and at most 2% of each sphere's lit pixels may fail.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.blender.material import param_socket, shader_node
from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, render_passes_osl,
                                              reset_blender, row_of_spheres, shader_failed)
from layered_brdf_addon.blender.sockets import find_socket
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_addon.blender.sync import apply_to_object
from layered_brdf_addon.model import preset, render_spheres
from layered_brdf_addon.model.base_layers import base_node
from layered_brdf_addon.model.params import iter_sockets
from layered_brdf_addon.model.presets import PRESETS
from layered_brdf_reference.closures import closure_shading
from layered_brdf_reference.compare import agreement, lit_mask

from blender_helpers import addon, built_plan, load_preset, socket_values
from constants import MAX_FAILING_COARSE as MAX_FAILING, REL_TOL_COARSE as REL_TOL, SUN_40 as SUN

ROOT = Path(__file__).resolve().parents[1]


def spheres(n=1, height=64, osl=False):
    reset_blender()
    cam = camera_for(n, height)
    centers = row_of_spheres(n)
    objs = build_scene(SceneSpec(camera=cam, sun=SUN, centers=centers, osl=osl))
    return objs, cam, centers



def expected_closure_form(params_list, cam, centers, passes):
    return render_spheres(params_list, cam, SUN, centers, thickness=passes.thickness,
                          lower_normals=passes.lower_normal, shading=closure_shading)


def assert_matches(beauty, expected, geo, k, label):
    mask = lit_mask(geo, SUN.l) & (geo.sphere == k)
    ag = agreement(beauty, expected, mask, rel_tol=REL_TOL)
    assert ag.failing_fraction <= MAX_FAILING, f"{label}: {ag}"


# --- every preset, both backends, against numpy ----------------------------------------------
@pytest.fixture(scope="module", params=["nodes", "osl"])
def preset_row(request):
    backend = request.param
    names = list(PRESETS)
    objs, cam, centers = spheres(len(names), osl=(backend == "osl"))
    for obj, name in zip(objs, names):
        if backend == "nodes":
            load_preset(obj, name)  # through the operator
        else:
            apply_to_object(obj, preset(name), backend="osl")
        base_layer = base_node(preset(name))
        if base_layer is not None:
            # The closure form holds the layer, not what the add-on puts under it (a transparent
            # film shows the sphere's far wall through it, a metal base its own reflection): the
            # layer is compared over an empty base.
            # A clear base is a Transparent BSDF tinted by the shader's Transmittance, added after it:
            # turned black, it adds nothing.
            shader = shader_node(obj.active_material)
            if base_layer.node_type == "ShaderNodeBsdfTransparent":
                (link,) = find_socket(shader.outputs, "Transmittance").links
                clear = link.to_node
                assert clear.bl_idname == base_layer.node_type
                obj.active_material.node_tree.links.remove(link)
                clear.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
                continue
            base = find_socket(shader.inputs, "Base Shader")  # group or OSL name
            assert [link.from_node.bl_idname for link in base.links] == [base_layer.node_type]
            obj.active_material.node_tree.links.remove(base.links[0])
    passes = render_passes_osl() if backend == "osl" else render_passes()
    return SimpleNamespace(backend=backend, names=names, objs=objs, cam=cam, centers=centers, passes=passes)


@pytest.mark.slow
@pytest.mark.keeps_scene
def test_every_preset_renders_like_the_closure_form(preset_row):
    r = preset_row
    params = [preset(n) for n in r.names]
    for obj, p in zip(r.objs, params):
        mat = obj.active_material
        assert shader_node(mat).bl_idname == ("ShaderNodeGroup" if r.backend == "nodes" else "ShaderNodeScript")
        assert socket_values(mat) == pytest.approx({s.name: getattr(p, s.name) for s in iter_sockets()}, rel=1e-6)
    beauty = r.passes.beauty
    assert np.all(np.isfinite(beauty))
    expected, geo = expected_closure_form(params, r.cam, r.centers, r.passes)
    for k, name in enumerate(r.names):
        assert_matches(beauty, expected, geo, k, f"{r.backend} {name}")


@pytest.mark.slow
def test_keyframed_thickness_renders_each_frame_like_the_closure_form():
    [obj], cam, centers = spheres()
    mat = load_preset(obj, "fig4_parallel")
    node = shader_node(mat)
    frames = {1: 120.0, 2: 260.0}
    for frame, d in frames.items():
        for name in ("d_min", "d_max"):
            sock = param_socket(node, name)[0]
            sock.default_value = d
            sock.keyframe_insert("default_value", frame=frame)
    bpy.context.view_layer.update()  # what follows each edit in Blender's UI: the handler re-plans
    scene = bpy.context.scene
    scene.frame_set(1)
    bpy.context.view_layer.update()
    key = built_plan(mat)
    assert key == "SDNPXB"  # animated thickness: the pattern stays although d_min == d_max now
    pointer = shader_node(mat).as_pointer()
    means = []
    for frame, d in frames.items():
        scene.frame_set(frame)
        bpy.context.view_layer.update()
        assert built_plan(mat) == key and shader_node(mat).as_pointer() == pointer
        passes = render_passes()
        params = preset("fig4_parallel").replace(d_min=d, d_max=d)
        expected, geo = render_spheres([params], cam, SUN, centers, shading=closure_shading)
        assert_matches(passes.beauty, expected, geo, 0, f"frame {frame}")
        mask = lit_mask(geo, SUN.l)
        means.append(passes.beauty[mask].mean(axis=0))
    hue = [m / m.sum() for m in means]
    assert np.abs(hue[0] - hue[1]).max() > 0.05, hue


@pytest.mark.slow
def test_saved_file_renders_the_same_without_the_addon(tmp_path):
    [obj], _, _ = spheres()
    load_preset(obj, "oil_slick")
    before = render_passes().beauty
    path = tmp_path / "layered.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    layered_brdf_addon.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        assert not hasattr(bpy.types.Material, SETTINGS)
        after = render_passes().beauty
    finally:
        layered_brdf_addon.register()
    assert np.all(np.isfinite(before)) and before.max() > 0.0
    np.testing.assert_array_equal(after, before)


# --- EEVEE -------------------------------------------------------------------------------------
def eevee_check(tmp_path, *args):
    """Cycles' and EEVEE's beauty passes of tests/eevee_check.py, and EEVEE's render time."""
    out = tmp_path / "eevee.npz"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(ROOT / "tests" / "eevee_check.py"), str(out), *args], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and out.exists(), (
        "EEVEE could not render (it needs EGL and Mesa's software GL: see .ci/run):\n" + proc.stderr[-3000:])
    r = np.load(out)
    return r["cycles"], r["eevee"], float(r["eevee_seconds"])


def assert_highlights_meet(cycles, eevee):
    """Both renders have finite light and their brightest pixel within 2 px of each other."""
    assert np.all(np.isfinite(eevee)) and eevee.max() > 0.0
    lum_c, lum_e = cycles.sum(-1), eevee.sum(-1)
    peak_c = np.array(np.unravel_index(lum_c.argmax(), lum_c.shape))
    peak_e = np.array(np.unravel_index(lum_e.argmax(), lum_e.shape))
    assert np.abs(peak_c - peak_e).max() <= 2, (peak_c, peak_e)
    return lum_c, lum_e, tuple(peak_e)


@pytest.mark.slow
def test_eevee_renders_the_node_group_with_the_highlight_where_cycles_has_it(tmp_path):
    cycles, eevee, seconds = eevee_check(tmp_path)
    print(f"EEVEE render: {seconds:.1f} s")
    lum_c, lum_e, peak_e = assert_highlights_meet(cycles, eevee)
    # The highlight stands out in both: its peak is several times the sphere's median.
    sphere = lum_c > 0.0
    assert lum_e[peak_e] > 4.0 * np.median(lum_e[sphere])


@pytest.mark.slow
def test_eevee_links_the_largest_accuracy_mode(tmp_path):
    """The spectral 32 group (the most nodes of any mode) compiles in EEVEE: no magenta
    "shader failed" pixels, finite light, and its highlight where Cycles has it."""
    cycles, eevee, seconds = eevee_check(tmp_path, "spectral32")
    print(f"EEVEE render, spectral 32: {seconds:.1f} s")
    assert not shader_failed(eevee).any()
    assert_highlights_meet(cycles, eevee)
