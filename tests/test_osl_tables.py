"""The OSL shader reading a material's baked tables (blender/osl.py, backends/osl_shader.py): the
tables written into a text of the material's values, stamped as the add-on's and shared by the
materials of the same values; a change of a value gives a new text and the old one goes once unused;
a text edited by hand is written again; renders agree with the shader computing its closures and
with the node group reading the same tables; and the analytic mode still averages over the pixel's
footprint (tests/test_osl_tables_render.py renders them)."""
from __future__ import annotations

import re
from dataclasses import replace

import bpy
import numpy as np
import pytest

from layered_brdf_addon.backends import osl_shader
from layered_brdf_addon.blender import osl, sync
from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_addon.blender.stored_keys import TEXT_KEY
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.table_bake import table_layout

from blender_helpers import add_sphere, addon  # noqa: F401 (addon: the add-on registered for this module)

OIL = preset("oil_slick")


def _text(mat):
    return shader_node(mat).script


def _own_texts() -> set:
    return {t.name for t in bpy.data.texts if t.get(TEXT_KEY) is not None}


def test_the_osl_text_holds_the_material_s_tables():
    mat = apply_layered_material(add_sphere(), OIL, "osl")
    plan = plan_effects(OIL, backend="osl")
    text = _text(mat)
    assert plan.tables and text[osl.TABLES_KEY] == osl.tables_digest(OIL, plan) and text[TEXT_KEY]
    assert osl.text_intact(text) and osl.text_current(text, OIL, plan)
    layout = table_layout(OIL, plan)
    size = int(re.search(r"float baked_tables\[(\d+)\]", text.as_string()).group(1))
    assert size == layout.images * (layout.height + 1) * layout.width * 4
    assert shader_node(mat).bytecode  # compiled
    # Evaluation 'arithmetic': the plan's one shared text, computing its closures.
    computed = OIL.replace(evaluation="arithmetic")
    apply_layered_material(mat, computed, "osl")
    assert osl.TABLES_KEY not in _text(mat) and _text(mat).as_string() == osl.source(plan_effects(computed))
    assert "baked_table(" not in _text(mat).as_string()


def test_same_values_share_a_text_and_a_change_gets_its_own():
    a = apply_layered_material(add_sphere("A"), OIL, "osl", name="A")
    b = apply_layered_material(add_sphere("B"), OIL, "osl", name="B")
    shared = _text(a)
    assert _text(b) == shared
    apply_layered_material(b, OIL.replace(e0=OIL.e0 * 1.5), "osl")
    assert _text(b) != shared and _text(a) == shared and osl.text_intact(shared)
    assert _text(b)[osl.TABLES_KEY] != shared[osl.TABLES_KEY]
    # A's own change: its old text is used by nothing and goes with the add-on's other unused data.
    old = shared.name
    apply_layered_material(a, OIL.replace(e0=OIL.e0 * 2.0), "osl")
    assert old not in _own_texts() and _own_texts() == {_text(a).name, _text(b).name}


def test_a_text_edited_by_hand_is_written_again():
    mat = apply_layered_material(add_sphere(), OIL, "osl")
    text = _text(mat)
    text.from_string(text.as_string().replace("baked_table(baked_tables, 64", "baked_table(baked_tables, 32", 1))
    assert not osl.text_intact(text)
    assert sync.sync_material(mat, check_sources=True)
    assert osl.text_intact(_text(mat)) and "baked_table(baked_tables, 64" in _text(mat).as_string()


def test_tables_source_needs_a_plan_with_tables_and_texels_of_its_layout():
    plan = plan_effects(OIL)
    layout = table_layout(OIL, plan)
    with pytest.raises(ValueError, match="computes its closures"):
        osl_shader.tabulated_shader_source(replace(plan, tables=False), layout, np.zeros(1))
    with pytest.raises(ValueError, match="texels of shape"):
        osl_shader.tabulated_shader_source(plan, layout, np.zeros((1, 2, 3, 4)))


def test_running_sums_hold_every_texel():
    texels = np.random.default_rng(0).random((3, 5, 4, 4)).astype(np.float32)
    sums = osl_shader.running_sums(texels)
    assert sums.shape == (3, 6, 4, 4) and not sums[:, 0].any()
    assert np.allclose(np.diff(sums, axis=1), texels, atol=1e-6)
