"""A film stack in Blender: the panel's stack editor builds the material's stack and its tables follow each
edit; a bad edit leaves the material as it was and the panel names the film and field; an animated value
bakes the tables again on each frame; saved and loaded, the stack is read back."""
from __future__ import annotations

import bpy
import pytest

from layered_brdf_addon.blender.material_values import params_of, settings
from layered_brdf_addon.blender.sync import material_problem
from layered_brdf_addon.blender.tables import DIGEST_KEY
from layered_brdf_addon.model import preset

from blender_helpers import add_sphere, addon, draw_panels, labels, load_preset  # noqa: F401 (the fixture)
from layered_brdf_addon.blender.material import shader_node


def _digest(mat) -> str:
    return shader_node(mat).node_tree[DIGEST_KEY]


def test_the_stack_editor_edits_the_material_and_its_tables_follow():
    mat = load_preset(add_sphere(), "jewel_beetle")
    st = settings(mat)
    assert st.use_stack and len(st.stack_films) == 2 and params_of(mat).stack == preset("jewel_beetle").stack
    before = _digest(mat)
    st.stack_periods = 6
    assert params_of(mat).stack.count == 12 and _digest(mat) != before
    st.stack_films[0].thickness_nm = 70.0
    assert params_of(mat).stack.films[0].thickness_nm == 70.0
    bpy.ops.layered_brdf.stack_film(action="ADD")
    assert len(params_of(mat).stack.films) == 3
    bpy.ops.layered_brdf.stack_film(action="REMOVE")
    assert len(params_of(mat).stack.films) == 2
    bpy.ops.layered_brdf.stack_thickness()
    total = params_of(mat).stack.total_nm
    assert params_of(mat).d_min == pytest.approx(0.95 * total, rel=1e-5)


def test_a_bad_edit_is_named_and_changes_nothing_built():
    mat = load_preset(add_sphere(), "morpho_blue")
    st = settings(mat)
    st.stack_films[0].thickness_nm = 0.0  # still a stack: 130 nm of air
    built = _digest(mat)
    st.stack_films[1].thickness_nm = 0.0  # none: every film 0 nm
    problem = material_problem(mat)
    assert problem is not None and "stack.films" in problem, problem
    assert _digest(mat) == built
    log = draw_panels(bpy.context.object)
    assert any("stack.films" in text for text in labels(log, alert=True))


def test_switching_the_stack_off_gives_one_film_back():
    mat = load_preset(add_sphere(), "coated_lens")
    settings(mat).use_stack = False
    p = params_of(mat)
    assert p.stack is None and not shader_node(mat).node_tree.name.endswith("M")


def test_an_animated_value_bakes_the_tables_again_on_each_frame():
    scene = bpy.context.scene
    mat = load_preset(add_sphere(), "jewel_beetle")
    sock = shader_node(mat).inputs["Upper Roughness"]
    sock.default_value = 0.1
    sock.keyframe_insert("default_value", frame=1)
    sock.default_value = 0.4
    sock.keyframe_insert("default_value", frame=10)
    scene.frame_set(1)
    first = _digest(mat)
    scene.frame_set(10)
    assert _digest(mat) != first


def test_a_saved_file_keeps_its_stack(tmp_path):
    mat = load_preset(add_sphere(), "nacre")
    settings(mat).stack_disorder = 0.08
    path = tmp_path / "stack.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    again = bpy.data.materials[mat.name if isinstance(mat, str) else "Layered BRDF"]
    assert params_of(again).stack.disorder == pytest.approx(0.08)
