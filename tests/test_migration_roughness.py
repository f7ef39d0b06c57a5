"""A file saved by the release before the node spoke Blender (node group version 5: "Upper
Exponent", "Tilt (°)" in degrees; the OSL shader's ``e0``) opens migrated and renders the same.

``data/node_group_v5.blend`` was written by ``tools/save_release_file.py`` from that release with
Blender 5.0: a node-group material with keyframes on Upper Exponent and an Average driver on
Tilt, one with a Value node linked into Lower Exponent, and an OSL material with keyframes on
``e0`` and ``tilt``; the scene at frame 4, between the keys.
"""
from __future__ import annotations

import shutil

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender.material import input_value, read_inputs, shader_node
from layered_brdf_addon.blender.scene import deterministic_cycles, ensure_passes, render_passes
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_reference.compare import agreement

from constants import MAX_FAILING, REL_TOL
from test_migration import LEGACY

RELEASE = LEGACY.parent / "node_group_v5.blend"
FRAMES = (1, 4, 6, 9)


def _render_setup(scene):
    deterministic_cycles(scene, (150, 50), 16, threads=2, seed=0)
    scene.cycles.shading_system = True  # the OSL material
    ensure_passes(scene)


def _values_by_frame():
    out = {}
    for frame in FRAMES:
        bpy.context.scene.frame_set(frame)
        out[frame] = {m.name: read_inputs(shader_node(m)) for m in bpy.data.materials if shader_node(m)}
    bpy.context.scene.frame_set(4)
    return out


@pytest.fixture
def release_file(tmp_path):
    registered = hasattr(bpy.types.Material, SETTINGS)
    layered_brdf_addon.unregister()  # so that opening it runs no upgrade
    path = tmp_path / "release.blend"
    shutil.copy(RELEASE, path)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert shader_node(bpy.data.materials["Keyed and driven"]).inputs.get("Upper Exponent") is not None
    _render_setup(bpy.context.scene)
    before_values = _values_by_frame()
    before = render_passes().beauty
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    layered_brdf_addon.register()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))  # load_post migrates every material
        yield before_values, before
    finally:
        layered_brdf_addon.unregister()
        if registered:  # left as found
            layered_brdf_addon.register()


@pytest.mark.slow
def test_the_previous_release_opens_with_roughness_and_angle_sockets_and_renders_the_same(release_file):
    before_values, before = release_file
    mats = {m.name: m for m in bpy.data.materials if shader_node(m) is not None}
    keyed, linked, osl = (shader_node(mats[n]) for n in ("Keyed and driven", "Linked exponent", "OSL keyed"))
    for node in (keyed, linked):
        assert node.node_tree.get(node_group_builder.STAMP_KEY) == node_group_builder.build_stamp()
        assert node.inputs.get("Upper Exponent") is None and node.inputs.get("Tilt (°)") is None
        assert node.inputs["Upper Roughness"].bl_subtype_label == "Factor"
        assert node.inputs["Tilt"].bl_subtype_label == "Angle"
    assert osl.inputs.get("e0") is None and osl.inputs.get("upper_roughness") is not None
    # Values, keyframes (between the keys too) and the driver give the parameters they gave.
    after_values = _values_by_frame()
    for frame in FRAMES:
        for name in mats:
            a, b = after_values[frame][name], before_values[frame][name]
            for p in ("e0", "e1", "tilt", "tilt_azimuth", "d_min", "r1_g"):
                if p == "e1" and name == "Linked exponent":
                    continue  # from the link: checked below
                assert getattr(a, p) == pytest.approx(getattr(b, p), rel=2e-4, abs=1e-4), (frame, name, p)
    tilt_driver = mats["Keyed and driven"].node_tree.animation_data.drivers[0]
    assert tilt_driver.driver.type == "SCRIPTED" and "radians" in tilt_driver.driver.expression
    assert tilt_driver.driver.is_simple_expression
    assert input_value(keyed, "tilt") == pytest.approx(12.0, rel=1e-5)
    # The Value node still feeds the lower boundary, through Math nodes that make its exponent a Roughness.
    link = linked.inputs["Lower Roughness"].links[0]
    assert link.from_node.bl_idname == "ShaderNodeMath" and "Value to roughness" in link.from_node.label
    tree = mats["Linked exponent"].node_tree
    assert tree.nodes["Artist exponent"].outputs[0].default_value == 250.0
    after = render_passes().beauty
    mask = np.any(before[..., :3] > 0.0, axis=-1)
    ag = agreement(after[..., :3], before[..., :3], mask, rel_tol=REL_TOL)
    print(f"migrated vs saved render: {ag}")
    assert ag.failing_fraction <= MAX_FAILING, ag
