"""Files saved before the node group's sockets were named for people open and render the same.

``data/legacy_sockets.blend`` was saved by the add-on when its node group had one float socket
per parameter named after it (``r1_r``, ``d_min``, ``base_r``...) and a ``Base Color`` tint
(stamp version 4), with Blender 5.0: three spheres, two materials sharing one group with
different values, one with a value node linked into ``d_min`` and a keyframe on ``e0``.
Opening it with the add-on rebuilds each material from its own sockets (load_post): values,
links and keyframes move to the new sockets; what was linked into the base colour or its
tint becomes the artist's own nodes feeding the one Base Color socket.
"""
from __future__ import annotations

import shutil
from pathlib import Path

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender.material import (animated_parameters, input_linked, input_value, read_inputs,
                                                 shader_node)
from layered_brdf_addon.blender.scene import render_passes
from layered_brdf_addon.model.params import iter_sockets
from layered_brdf_reference.compare import agreement

from constants import MAX_FAILING, REL_TOL

LEGACY = Path(__file__).parent / "data" / "legacy_sockets.blend"
TINT = (0.5, 1.0, 0.8, 1.0)  # an older node's Base Color multiplied its base colour


def _legacy_state(tmp_path):
    """The legacy file as the add-on's older version left it, edited the way an artist could have:
    a tint on one material, a texture on one base channel of another; saved to ``tmp_path``."""
    layered_brdf_addon.unregister()  # so that opening it runs no upgrade
    bpy.ops.wm.open_mainfile(filepath=str(LEGACY))
    mats = {m.name: m for m in bpy.data.materials}
    node_a = shader_node(mats["Shared A"])
    assert node_a.inputs.get("d_min") is not None and node_a.inputs.get("Thickness Min") is None
    node_a.inputs["Base Color"].default_value = TINT
    tree_b = mats["Shared B"].node_tree
    node_b = shader_node(mats["Shared B"])
    checker = tree_b.nodes.new("ShaderNodeTexChecker")
    checker.name = "Artist checker"
    checker.inputs["Scale"].default_value = 3.0
    tree_b.links.new(checker.outputs["Fac"], node_b.inputs["base_g"])
    values = {name: read_inputs(shader_node(m)) for name, m in mats.items()}
    beauty = render_passes().beauty
    path = tmp_path / "legacy.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path, values, beauty


@pytest.mark.slow
def test_a_file_with_the_older_sockets_opens_migrated_and_renders_the_same(tmp_path):
    path, values, before = _legacy_state(tmp_path)
    layered_brdf_addon.register()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))  # load_post rebuilds the stale materials
        mats = {m.name: m for m in bpy.data.materials}
        nodes = {name: shader_node(m) for name, m in mats.items()}
        for name, node in nodes.items():
            assert node.node_tree.get(node_group_builder.STAMP_KEY) == node_group_builder.build_stamp(), name
            assert node.inputs.get("Thickness Min") is not None and node.inputs.get("d_min") is None
            assert node.inputs.get("base_r") is None
            migrated = read_inputs(node)
            for spec in iter_sockets():
                if not input_linked(node, spec.name):
                    assert getattr(migrated, spec.name) == pytest.approx(getattr(values[name], spec.name)), \
                        (name, spec.name)
        # The two materials shared one group; migrated, each has its plan's: A's tilted film fits its tables'
        # budget and reads tables baked for its values, B's thicker one (79-140 nm) computes. The outdated
        # groups are gone.
        keys = [nodes[n].node_tree[node_group_builder.PLAN_KEY] for n in ("Shared A", "Shared B")]
        assert keys == ["SDNTXBTb", "SDNTXB"], keys
        assert not [g.name for g in bpy.data.node_groups if "outdated" in g.name]
        assert all(g.get(node_group_builder.STAMP_KEY) in (None, node_group_builder.build_stamp())
                   for g in bpy.data.node_groups if g.get(node_group_builder.STAMP_KEY) is not None)
        # The tint is folded into the base colour; the linked channel feeds it through the artist's nodes.
        assert input_value(nodes["Shared A"], "base_r") == pytest.approx(values["Shared A"].base_r)
        base_b = nodes["Shared B"].inputs["Base Color"]
        assert base_b.is_linked and base_b.links[0].from_node.bl_idname == "ShaderNodeCombineColor"
        combine = base_b.links[0].from_node
        assert combine.inputs[1].links[0].from_node.name == "Artist checker"
        assert combine.inputs[0].default_value == pytest.approx(values["Shared B"].base_r)
        # The artist's link into d_min now feeds Thickness Min; the keyframe on e0 animates Upper Roughness.
        tree = mats["Linked and keyed"].node_tree
        node = nodes["Linked and keyed"]
        assert node.inputs["Thickness Min"].links[0].from_node == tree.nodes["Artist value"]
        paths = [fc.data_path for fc in tree.animation_data.action.layers[0].strips[0].channelbags[0].fcurves]
        assert [tree.path_resolve(p.rsplit(".", 1)[0]) for p in paths] == [node.inputs["Upper Roughness"]]
        assert "e0" in animated_parameters(mats["Linked and keyed"])
        after = render_passes().beauty
        mask = np.any(before[..., :3] > 0.0, axis=-1)
        ag = agreement(after[..., :3], before[..., :3], mask, rel_tol=REL_TOL)
        assert ag.failing_fraction <= MAX_FAILING, ag
    finally:
        layered_brdf_addon.unregister()
