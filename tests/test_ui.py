"""The add-on inside Blender without rendering: registration, the panel and its settings, edits
and effect plans, animation, files holding older or linked data, user presets.

Renders of the add-on's materials are in test_ui_renders.py.
"""
from __future__ import annotations

import json
import math
from types import SimpleNamespace

import bpy
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender import osl, properties, registration, sync, ui, user_presets
from layered_brdf_addon.blender.material import SUBGROUP_KEY, animated_parameters, input_value, param_socket, shader_node
from layered_brdf_addon.blender.material_values import params_of, settings
from layered_brdf_addon.blender.scene import reset_blender
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_addon.blender.freshness import after_edit
from layered_brdf_addon.blender.sync import desired, material_problem, on_load_post
from layered_brdf_addon.model import LayeredParams, preset
from layered_brdf_addon.model.params import PARAM_SPECS
from layered_brdf_addon.model.policy import plan_effects

from blender_helpers import (Layout, activate, add_sphere, addon, built_plan, draw_panels, labels, load_preset,
                             socket_values, user_dir)


def plain_object():
    """A new file holding one small sphere in a Cycles scene (for tests that do not render)."""
    reset_blender()
    return add_sphere("Small", u_segments=16, v_segments=8)



def osl_built_for(mat, plan):
    node = shader_node(mat)
    return node.bl_idname == "ShaderNodeScript" and osl.text_current(node.script, params_of(mat), plan)



# --- registration --------------------------------------------------------------------------
def _leftovers():
    out = []
    if hasattr(bpy.types.Material, SETTINGS):
        out.append("Material property")
    out += [cls.__name__ for cls in registration.CLASSES if registration._registered_versions(cls)]
    for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.load_post):
        out += [f.__qualname__ for f in handlers if getattr(f, "__module__", "").startswith("layered_brdf_addon")]
    return out


def test_register_twice_then_unregister_leaves_nothing():
    layered_brdf_addon.register()  # already registered by the fixture
    assert sum(f is after_edit for f in bpy.app.handlers.depsgraph_update_post) == 1
    assert sum(f is on_load_post for f in bpy.app.handlers.load_post) == 1
    assert all(cls.is_registered for cls in registration.CLASSES)
    layered_brdf_addon.unregister()
    try:
        assert _leftovers() == []
        assert not hasattr(bpy.types, "LAYERED_BRDF_OT_apply")
        assert not hasattr(bpy.types, ui.MAIN_PANEL)
        layered_brdf_addon.unregister()  # unregistering twice is harmless
    finally:
        layered_brdf_addon.register()
    assert registration.is_registered()


def test_settings_and_panel_come_from_param_specs():
    rna = properties.LayeredBRDFSettings.bl_rna.properties
    for spec in PARAM_SPECS:
        if spec.socket:
            continue
        if spec.kind == "stack":  # the stack editor: a switch, the films' list, periods and disorder
            assert {"use_stack", "stack_films", "stack_periods", "stack_disorder", "stack_kind"} <= set(rna.keys())
            continue
        assert rna[spec.name].description == spec.description
        assert [i.identifier for i in rna[spec.name].enum_items] == list(spec.options)
        assert rna[spec.name].default == spec.default
    obj = plain_object()
    mat = load_preset(obj, "beetle_shell")
    log = draw_panels(obj)
    drawn = {e[3]: e for e in log if e[0] == "prop"}
    node = shader_node(mat)
    assert any(e[0] == "list" and e[3] == "stack_films" for e in log)
    for spec in PARAM_SPECS:
        if spec.kind == "stack":
            assert any(e[0] == "prop" and e[1] == settings(mat) and e[2] == "use_stack" for e in log)
            continue
        sock, channel = param_socket(node, spec.name) if spec.socket else (None, None)
        text = sock.name if channel is not None else properties.param_label(spec)  # a colour: drawn once
        assert text in drawn, f"{spec.name} not drawn"
        data, prop = drawn[text][1], drawn[text][2]
        if spec.socket:  # floats are the shader's own sockets: keyframes on them animate renders
            assert data == sock and prop == "default_value"
        else:
            assert data == settings(mat) and prop == spec.name
    assert "Thickness min (nm)" in drawn and "Tilt (\u00b0)" in drawn and "Base Color" in drawn

    infos = [e[3].param for e in log if e[0] == "operator" and e[1] == "layered_brdf.param_info"]
    assert sorted(infos) == sorted(s.name for s in PARAM_SPECS if s.component in (None, 0))
    tip = properties.param_tooltip("d_min")
    assert LayeredParams.spec("d_min").description in tip and "nm" in tip and "2000" in tip
    assert any(e[0] == "menu" and e[1] == "LAYERED_BRDF_MT_presets" for e in log)
    assert labels(log, alert=True) == []


def test_osl_backend_warns_when_the_scene_cannot_run_it():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    values = socket_values(mat)
    settings(mat).backend = "osl"  # the update callback rebuilds the material
    assert osl_built_for(mat, desired(mat)[2])
    assert socket_values(mat) == pytest.approx(values)
    warnings = labels(draw_panels(obj), alert=True)
    assert any("OSL will not run" in w and "Open Shading Language option is off" in w for w in warnings), warnings
    assert bpy.ops.layered_brdf.enable_osl() == {"FINISHED"}
    assert bpy.context.scene.cycles.shading_system
    assert labels(draw_panels(obj), alert=True) == []
    # Phong lobes exist only in OSL: back on the node backend the material stays as it is and says why.
    settings(mat).lobe = "phong"
    plan = desired(mat)[2]
    assert plan.lobe == "phong" and osl_built_for(mat, plan)
    settings(mat).backend = "nodes"
    assert shader_node(mat).bl_idname == "ShaderNodeScript"
    assert "lobe" in material_problem(mat)
    assert any("'beckmann' with the nodes backend" in w for w in labels(draw_panels(obj), alert=True))
    with pytest.raises(RuntimeError, match="lobe"):
        bpy.ops.layered_brdf.apply()
    settings(mat).lobe = "beckmann"
    assert shader_node(mat).bl_idname == "ShaderNodeGroup"


# --- edits, effect plans, animation ------------------------------------------------------------
def test_socket_and_setting_edits_update_the_shader_without_new_groups(monkeypatch):
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    node = shader_node(mat)
    pointer, key, groups = node.as_pointer(), built_plan(mat), len(bpy.data.node_groups)
    param_socket(node, "d_max")[0].default_value = 90.0
    bpy.context.view_layer.update()
    node = shader_node(mat)
    assert node.as_pointer() == pointer and built_plan(mat) == key
    assert len(bpy.data.node_groups) == groups
    assert params_of(mat).d_max == 90.0
    # An enum edit that leaves the plan alone (a tilt of 0 is no tilt) only records the setting.
    settings(mat).normal_mode = "tilted"
    assert shader_node(mat).as_pointer() == pointer and built_plan(mat) == key
    assert mat["layered_brdf_enums"]["normal_mode"] == "tilted"
    assert len(bpy.data.node_groups) == groups
    # Settled: further depsgraph updates apply nothing (the handler's own writes don't feed back).
    calls = []
    apply = sync.apply_layered_material
    monkeypatch.setattr(sync, "apply_layered_material", lambda *a, **k: calls.append(a) or apply(*a, **k))
    for _ in range(3):
        bpy.context.view_layer.update()
    assert calls == []


def test_toggling_an_effect_rebuilds_the_tree():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    assert built_plan(mat) == "SDNPXBTb"  # Tb: baked tables (constant values, parallel boundaries)
    param_socket(shader_node(mat), "ks")[0].default_value = 0.0
    bpy.context.view_layer.update()
    assert built_plan(mat) == "sDNPXBTb"
    assert shader_node(mat).node_tree.name == node_group_builder.group_name(desired(mat)[2])
    settings(mat).normal_mode = "tilted"
    param_socket(shader_node(mat), "tilt")[0].default_value = math.radians(12.0)  # an angle socket: radians
    bpy.context.view_layer.update()
    assert built_plan(mat) == "sDNTXBTb"  # a tilted boundary's tables (a thin film: within their budget)
    node = shader_node(mat)
    param_socket(node, "d_min")[0].default_value = input_value(node, "d_max")
    bpy.context.view_layer.update()
    assert built_plan(mat) == "sDCTXBTb"
    bpy.context.view_layer.update()  # settled: a further update changes nothing
    assert built_plan(mat) == "sDCTXBTb"
    assert input_value(shader_node(mat), "tilt") == pytest.approx(12.0)


def test_helper_groups_are_hidden_from_the_add_menu():
    """The sub-groups the node group uses start with "." (Blender hides those from the Add menu
    and the group selector); the material's own group does not."""
    obj = plain_object()
    mat = load_preset(obj, "fig5_correlated")  # a group that computes its closures (tables have no helpers)
    helpers = [g for g in bpy.data.node_groups if g.get(SUBGROUP_KEY) is not None]
    assert helpers and all(g.name.startswith(".") for g in helpers)
    assert not shader_node(mat).node_tree.name.startswith(".")


def test_menus_show_labels_written_for_people():
    obj = plain_object()
    mat = load_preset(obj, "oil_slick")
    items = settings(mat).bl_rna.properties["accuracy"].enum_items
    assert items["rgb"].name == "RGB (the paper's 3 wavelengths)" and items["analytic"].name == "Analytic spectral"
    assert ui.preset_title("fig6_medium") == "Fig. 6 medium layer"


def test_a_material_built_before_the_analytic_default_keeps_its_colour_model(tmp_path):
    """'rgb' was the default accuracy: a material built then never wrote it (Blender stores a
    setting once written).  Saved, reopened and edited, it stays RGB; new materials get the
    analytic mode, and keep it whatever the default becomes."""
    obj = plain_object()
    mat = load_preset(obj, "oil_slick")
    assert settings(mat).accuracy == "analytic" and "A" in built_plan(mat)[6:]
    assert settings(mat).is_property_set("accuracy")
    assert mat["layered_brdf_enums"]["accuracy"] == "analytic"
    # What a file saved before the change holds: an RGB build, no accuracy written anywhere.
    settings(mat).accuracy = "rgb"
    bpy.context.view_layer.update()
    rgb_plan = built_plan(mat)
    assert not rgb_plan.endswith("A")
    settings(mat).property_unset("accuracy")
    enums = mat["layered_brdf_enums"].to_dict()
    del enums["accuracy"]
    mat["layered_brdf_enums"] = enums
    path, name = tmp_path / "legacy.blend", mat.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    mat = bpy.data.materials[name]
    assert params_of(mat).accuracy == "rgb"
    param_socket(shader_node(mat), "d_max")[0].default_value = 650.0  # an edit: the material is rebuilt if needed
    bpy.context.view_layer.update()
    assert built_plan(mat) == rgb_plan and settings(mat).accuracy == "rgb"
    assert settings(mat).is_property_set("accuracy")


def test_animated_driven_or_linked_sockets_keep_their_effects():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    node = shader_node(mat)
    ks = param_socket(node, "ks")[0]
    ks.default_value = 0.0
    ks.keyframe_insert("default_value", frame=1)
    ks.default_value = 1.0
    ks.keyframe_insert("default_value", frame=10)
    param_socket(node, "bump_strength")[0].driver_add("default_value")
    value = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(value.outputs[0], param_socket(node, "kd")[0])
    bpy.context.view_layer.update()  # what follows each edit in Blender's UI: the handler re-plans
    assert animated_parameters(mat) == {"ks", "bump_strength", "kd"}
    p = preset("fig4_parallel").replace(ks=0.0, kd=0.0, tilt=0.0, normal_mode="tilted")
    assert plan_effects(p, set()).key == "sdNPXBTb"
    assert plan_effects(p, {"ks", "kd"}).key == "SDNPXB"
    assert plan_effects(p, {"tilt"}).normals == "tilted"
    flat = p.replace(d_min=70.0, d_max=70.0, r1_r=1.5, r1_g=1.5, r1_b=1.5, normal_mode="correlated")
    assert plan_effects(flat, set()).key == "sdCPxBTb"
    assert plan_effects(flat, {"d_max", "r1_g"}).key == "sdNCXB"
    bpy.context.scene.frame_set(1)
    bpy.context.view_layer.update()
    assert built_plan(mat) == "SDNPXB"  # ks is 0 at frame 1, yet the specular part stays


# --- files holding older or linked data --------------------------------------------------------
def test_an_older_node_group_in_a_file_is_replaced(tmp_path):
    obj = plain_object()
    mat = load_preset(obj, "glazed_clay")
    group = shader_node(mat).node_tree
    name = group.name
    group[node_group_builder.STAMP_KEY] = "1:old"
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    group = bpy.data.node_groups[name]
    assert group[node_group_builder.STAMP_KEY] == node_group_builder.build_stamp()
    assert shader_node(mat).node_tree == group
    assert [g.name for g in bpy.data.node_groups if g.name.startswith(name + ".")] == []
    # Opening a saved file with a stale group updates it too (load_post).
    group[node_group_builder.STAMP_KEY] = "1:old"
    path = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert bpy.data.node_groups[name][node_group_builder.STAMP_KEY] == node_group_builder.build_stamp()


def test_a_linked_material_is_left_untouched_and_the_panel_says_why(tmp_path):
    obj = plain_object()
    name = load_preset(obj, "soap_bubble").name
    lib = tmp_path / "library.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(lib))
    obj = plain_object()
    with bpy.data.libraries.load(str(lib), link=True) as (_src, dst):
        dst.materials = [name]
    linked = dst.materials[0]
    assert linked.library is not None
    obj.data.materials.append(linked)
    activate(obj)
    before = socket_values(linked), linked["layered_brdf_build"]
    with pytest.raises(RuntimeError, match="linked from"):
        bpy.ops.layered_brdf.apply()
    with pytest.raises(RuntimeError, match="linked from"):
        bpy.ops.layered_brdf.load_preset(preset="oil_slick")
    bpy.context.view_layer.update()
    assert (socket_values(linked), linked["layered_brdf_build"]) == before
    assert obj.active_material == linked
    warnings = labels(draw_panels(obj), alert=True)
    assert any("linked from" in w and "make it local" in w for w in warnings), warnings


# --- user presets and assets -----------------------------------------------------------------
def test_user_presets_save_reuse_in_another_file_and_delete(user_dir):
    obj = plain_object()
    mat = load_preset(obj, "anodised_titanium")
    param_socket(shader_node(mat), "d_max")[0].default_value = 95.0
    bpy.ops.layered_brdf.save_preset(name="Blue titanium")
    path = user_dir / "Blue titanium.json"
    data = json.loads(path.read_text())
    assert data["params"]["d_max"] == pytest.approx(95.0) and data["name"] == "Blue titanium"
    assert settings(mat).preset == "user:Blue titanium"
    saved = socket_values(mat)
    obj = plain_object()  # another file
    mat = load_preset(obj, "user:Blue titanium")
    assert socket_values(mat) == pytest.approx(saved)
    assert "Blue titanium" in user_presets.user_preset_names()
    # An invalid preset file: the operator reports the parameter and range, nothing changes.
    bad = dict(data, params=dict(data["params"], tilt=400.0))
    (user_dir / "Broken.json").write_text(json.dumps(bad))
    before = socket_values(mat), mat["layered_brdf_build"]
    with pytest.raises(RuntimeError, match=r"'tilt' = 400.0 is invalid: allowed a number in \[0, 180\] deg"):
        bpy.ops.layered_brdf.load_preset(preset="user:Broken")
    (user_dir / "Garbled.json").write_text("{not json")
    with pytest.raises(RuntimeError, match="readable preset file"):
        bpy.ops.layered_brdf.load_preset(preset="user:Garbled")
    assert (socket_values(mat), mat["layered_brdf_build"]) == before
    with pytest.raises(RuntimeError, match="'name'"):
        bpy.ops.layered_brdf.save_preset(name="../escape")
    with pytest.raises(RuntimeError, match="built-in"):
        bpy.ops.layered_brdf.save_preset(name="soap_bubble")
    assert bpy.ops.layered_brdf.delete_preset(preset="Blue titanium") == {"FINISHED"}
    assert not path.exists()
    with pytest.raises(RuntimeError, match="one of the saved presets"):
        bpy.ops.layered_brdf.load_preset(preset="user:Blue titanium")
    assert user_presets.extension_package() is None  # a checkout: presets live in Blender's config


def test_a_redraw_of_the_material_panel_reads_the_animation_once(monkeypatch):
    """The panel shows the material's problem and its effects from one look at its keyframes,
    drivers and links (a walk over every animation curve of the material)."""
    obj = plain_object()
    load_preset(obj, "beetle_shell")
    walks = []
    real = sync.animated_parameters
    monkeypatch.setattr(sync, "animated_parameters", lambda mat: walks.append(mat) or real(mat))
    log = []
    ui.LAYERED_BRDF_PT_material.draw(SimpleNamespace(layout=Layout(log)), SimpleNamespace(object=obj,
                                                                                          scene=bpy.context.scene))
    assert len(walks) == 1
    assert any(line.startswith("Effects (") for line in labels(log))


def test_the_panel_says_why_a_material_computes_where_it_asked_for_tables():
    obj = plain_object()
    tir = preset("fig4_parallel").replace(optics="physical", r0=5.0, layer_index="channels", r1_r=1.0, r1_g=1.0,
                                          r1_b=1.0)
    sync.apply_to_object(obj, tir, "nodes", preview=False)
    said = [line for line in labels(draw_panels(obj)) if "computed per point" in line]
    assert len(said) == 1 and said[0].startswith("Baked tables would be") and "base" in said[0]
    sync.apply_to_object(obj, preset("fig4_parallel"), "nodes", preview=False)
    assert not [line for line in labels(draw_panels(obj)) if "computed per point" in line]
