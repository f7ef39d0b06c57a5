"""The add-on never loses an artist's work: links, nodes, material slots, materials, animation,
and it leaves no piles of unused data behind (docs/guarantees.md, "Artist data in a .blend")."""
from __future__ import annotations

import importlib
import shutil
import sys
from pathlib import Path
from types import SimpleNamespace

import bpy
import pytest

import layered_brdf_addon
from layered_brdf_addon.blender import assets, registration
from layered_brdf_addon.blender.material_values import is_layered, settings
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_addon.blender.sync import apply_to_object
from layered_brdf_addon.blender.animation import animated_paths
from layered_brdf_addon.blender.material import (NAME_KEY, ROLE_KEY, animated_parameters, apply_layered_material,
                                                 displaced_material, input_value, param_socket, shader_node)
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.model import preset

from blender_helpers import activate, add_sphere, addon, load_preset

ROOT = Path(__file__).resolve().parents[1]
STAMP = node_group_builder.STAMP_KEY


def plain_object(name="Small"):
    """A coarse sphere added to the current file (several per test)."""
    return add_sphere(name, u_segments=8, v_segments=4)


def output_node(mat):
    return next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")


def surface_source(mat):
    links = output_node(mat).inputs["Surface"].links
    return links[0].from_node if links else None


def layered_nodes(mat):
    """Every node running a layered node group (the add-on's and the artist's copies)."""
    return [n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeGroup" and n.node_tree is not None
            and n.node_tree.get(STAMP) is not None]


def unused_own_groups():
    return sorted(g.name for g in bpy.data.node_groups
                  if g.get(STAMP) is not None and g.users - int(g.use_fake_user) == 0)


def save_and_reopen(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))


# --- 1: the artist's links around the layered node ---------------------------------------------
def test_a_rebuild_keeps_the_mix_shader_the_artist_put_before_the_output():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    tree = mat.node_tree
    node, out = shader_node(mat), output_node(mat)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.name = "Artist mix"
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    tree.links.new(node.outputs["BSDF"], mix.inputs[1])
    tree.links.new(glossy.outputs[0], mix.inputs[2])
    tree.links.new(mix.outputs[0], out.inputs["Surface"])
    build = mat["layered_brdf_build"]
    load_preset(obj, "beetle_shell")  # another effect plan: the tree is rebuilt
    assert mat["layered_brdf_build"] != build
    assert surface_source(mat) == tree.nodes["Artist mix"]
    new = shader_node(mat)
    assert [l.to_node.name for l in new.outputs["BSDF"].links] == ["Artist mix"]
    assert [l.to_socket.identifier for l in new.outputs["BSDF"].links] == [mix.inputs[1].identifier]
    assert tree.nodes["Artist mix"].inputs[2].links[0].from_node == glossy


# --- 2: the add-on's nodes are known by a stamp, never by name ---------------------------------
def test_a_rebuild_keeps_the_artists_nodes_named_layered_brdf_and_finds_a_renamed_node():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    tree = mat.node_tree
    node = shader_node(mat)
    copy = tree.nodes.new("ShaderNodeGroup")  # what Shift+D makes: the same group and custom properties
    copy.node_tree = node.node_tree
    for key in node.keys():
        copy[key] = node[key]
    copy.name = "Layered BRDF.001"
    copy.location = (node.location[0], node.location[1] + 400)
    frame = tree.nodes.new("NodeFrame")
    frame.name = "Layered BRDF notes"
    assert shader_node(mat) == node
    load_preset(obj, "beetle_shell")  # a rebuild
    assert "Layered BRDF.001" in tree.nodes and "Layered BRDF notes" in tree.nodes
    assert shader_node(mat) != tree.nodes["Layered BRDF.001"]
    assert tree.nodes["Layered BRDF.001"].get(ROLE_KEY) is None  # the copy is the artist's node now
    # Renamed by the artist: still the add-on's node; applying makes no second one.
    shader_node(mat).name = "My film"
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert shader_node(mat).name == "My film"
    assert sorted(n.name for n in layered_nodes(mat)) == ["Layered BRDF.001", "My film"]
    load_preset(obj, "fig4_parallel")  # a rebuild keeps the artist's name
    assert shader_node(mat).name == "My film"
    assert sorted(n.name for n in layered_nodes(mat)) == ["Layered BRDF.001", "My film"]
    assert shader_node(mat)[ROLE_KEY] == "shader"


def test_a_node_made_before_stamps_is_recognised_by_its_group_and_stamped():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    for n in mat.node_tree.nodes:
        for key in (ROLE_KEY, NAME_KEY):
            if key in n:
                del n[key]
    node = shader_node(mat)
    node.name = "Renamed long ago"
    nodes_before = len(mat.node_tree.nodes)
    assert shader_node(mat) == node
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert shader_node(mat).name == "Renamed long ago" and shader_node(mat)[ROLE_KEY] == "shader"
    assert len(mat.node_tree.nodes) == nodes_before and len(layered_nodes(mat)) == 1
    load_preset(obj, "beetle_shell")  # a rebuild replaces the old AOV outputs, adds none beside them
    assert len(layered_nodes(mat)) == 1
    aovs = [n.aov_name for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeOutputAOV"]
    assert sorted(aovs) == sorted(set(aovs))


# --- 3: the slot the object renders --------------------------------------------------------------
def test_apply_writes_the_slot_linked_to_the_object_and_remove_restores_it():
    obj = plain_object()
    mesh_mat = bpy.data.materials.new("Mesh material")
    obj.data.materials.append(mesh_mat)
    obj.material_slots[0].link = "OBJECT"
    obj_mat = bpy.data.materials.new("Object material")
    obj.material_slots[0].material = obj_mat
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert is_layered(obj.active_material)
    assert is_layered(obj.material_slots[0].material)
    assert obj.data.materials[0] == mesh_mat  # the mesh (maybe shared) is left alone
    assert bpy.ops.layered_brdf.remove() == {"FINISHED"}
    assert obj.material_slots[0].material == obj_mat and obj.material_slots[0].link == "OBJECT"
    assert list(obj.data.materials) == [mesh_mat]


# --- 4: the material the layered one replaced ----------------------------------------------------
def test_the_replaced_material_survives_save_and_remove_puts_it_back(tmp_path):
    obj = plain_object()
    artist = bpy.data.materials.new("Artist red")
    obj.data.materials.append(artist)
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    mat = obj.active_material
    assert mat != artist and displaced_material(mat) == artist
    assert artist.users >= 1
    save_and_reopen(tmp_path / "displaced.blend")
    assert "Artist red" in bpy.data.materials
    obj = activate(bpy.data.objects["Small"])
    assert bpy.ops.layered_brdf.remove() == {"FINISHED"}
    assert [s.material.name for s in obj.material_slots] == ["Artist red"]
    # A slot the add-on added is removed again.
    empty = plain_object("Empty")
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert bpy.ops.layered_brdf.remove() == {"FINISHED"}
    assert len(empty.material_slots) == 0


# --- 5: no piles of unused groups or texts ---------------------------------------------------
def test_effect_changes_leave_no_unused_groups_and_never_remove_the_artists(tmp_path):
    mine = bpy.data.node_groups.new("Layered BRDF [mine]", "ShaderNodeTree")  # unstamped: the artist's
    mine.use_fake_user = True
    other = plain_object("Other")
    kept = load_preset(other, "soap_bubble")  # a group another material still uses
    kept_group = shader_node(kept).node_tree.name
    obj = plain_object()
    names = ["fig4_parallel", "fig4_tilted", "fig5_correlated", "fig3_clay", "oil_slick", "beetle_shell"]
    for name in names:
        load_preset(obj, name)
    assert unused_own_groups() == []
    save_and_reopen(tmp_path / "piles.blend")
    assert unused_own_groups() == []
    assert "Layered BRDF [mine]" in bpy.data.node_groups and kept_group in bpy.data.node_groups
    used = {shader_node(m).node_tree.name for m in bpy.data.materials if is_layered(m)}
    assert {g.name for g in bpy.data.node_groups if g.get(STAMP) is not None} == used


def test_switching_from_osl_to_nodes_removes_the_osl_text_only():
    notes = bpy.data.texts.new("layered_brdf_notes.osl")  # the artist's, unstamped
    notes.from_string("// my notes")
    obj = plain_object()
    apply_to_object(obj, preset("fig4_parallel"), backend="osl")
    mat = obj.active_material
    assert shader_node(mat).bl_idname == "ShaderNodeScript"
    settings(mat).backend = "nodes"  # the panel's switch rebuilds the material
    assert shader_node(mat).bl_idname == "ShaderNodeGroup"
    assert [t.name for t in bpy.data.texts] == ["layered_brdf_notes.osl"]


# --- 6: re-applying repairs a damaged tree ---------------------------------------------------------
def test_reapply_adds_a_deleted_material_output_and_relinks_the_shader():
    obj = plain_object()
    mat = load_preset(obj, "fig4_parallel")
    tree = mat.node_tree
    principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
    principled.name = "Artist principled"
    tree.nodes.remove(output_node(mat))
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert surface_source(mat) == shader_node(mat)
    assert not any(s.is_linked for s in tree.nodes["Artist principled"].outputs)
    tree.links.remove(shader_node(mat).outputs["BSDF"].links[0])
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert surface_source(mat) == shader_node(mat)
    # Output deleted behind the artist's Mix Shader: the new output is fed by the mix.
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(shader_node(mat).outputs["BSDF"], mix.inputs[1])
    tree.nodes.remove(output_node(mat))
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert surface_source(mat) == mix
    # The artist's own choice of what feeds the Surface is left alone.
    tree.links.new(principled.outputs[0], output_node(mat).inputs["Surface"])
    tree.links.remove(shader_node(mat).outputs["BSDF"].links[0])
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert surface_source(mat) == principled


# --- animation across a rebuild --------------------------------------------------------------
def test_keyframes_keep_driving_a_node_rebuilt_without_a_depsgraph_update():
    obj = plain_object()
    params = preset("fig4_parallel")
    mat = apply_layered_material(obj, params)
    node = shader_node(mat)
    node.name = "My film"
    sock = param_socket(node, "ks")[0]
    sock.default_value = 0.25
    sock.keyframe_insert("default_value", frame=1)
    sock.default_value = 0.75
    sock.keyframe_insert("default_value", frame=10)
    build = mat["layered_brdf_build"]
    apply_layered_material(obj, params.replace(normal_mode="tilted", tilt=10.0))  # no update in between
    assert mat["layered_brdf_build"] != build
    node = shader_node(mat)
    assert node.name == "My film"
    paths = list(animated_paths(mat.node_tree))
    assert len(paths) == 1 and mat.node_tree.path_resolve(paths[0].rsplit(".", 1)[0]) == param_socket(node, "ks")[0]
    assert "ks" in animated_parameters(mat)
    for frame, value in ((1, 0.25), (10, 0.75)):
        bpy.context.scene.frame_set(frame)
        assert input_value(shader_node(mat), "ks") == pytest.approx(value)


# --- 7: registration ------------------------------------------------------------------------
def test_unregister_cancels_a_preview_timer_queued_before_a_reload(monkeypatch):
    obj = plain_object()
    group = assets.group_of(load_preset(obj, "fig4_parallel"))
    queued = assets._render_queued
    interactive = SimpleNamespace(app=SimpleNamespace(background=False, timers=bpy.app.timers,
                                                      is_job_running=bpy.app.is_job_running), data=bpy.data)
    monkeypatch.setattr(assets, "bpy", interactive)
    assets.queue_preview(group)
    assert bpy.app.timers.is_registered(queued)
    monkeypatch.undo()
    importlib.reload(assets)
    assert assets._render_queued is not queued
    layered_brdf_addon.unregister()
    try:
        assert not bpy.app.timers.is_registered(queued)
    finally:
        if bpy.app.timers.is_registered(queued):
            bpy.app.timers.unregister(queued)
        layered_brdf_addon.register()


def _own_handlers(package):
    return [f.__qualname__ for handlers in (bpy.app.handlers.depsgraph_update_post, bpy.app.handlers.load_post)
            for f in handlers if (getattr(f, "__module__", None) or "").startswith(package + ".")]


@pytest.fixture
def second_copy(tmp_path):
    """Another copy of the add-on, imported under another package (as the extension is)."""
    root = tmp_path / "lbcopy"
    shutil.copytree(ROOT / "layered_brdf_addon", root / "layered_brdf_addon",
                    ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "__init__.py", root / "__init__.py")
    shutil.copytree(ROOT / "osl", root / "osl")
    sys.path.insert(0, str(tmp_path))
    try:
        yield importlib.import_module("lbcopy")
    finally:
        sys.path.remove(str(tmp_path))
        for name in [m for m in sys.modules if m == "lbcopy" or m.startswith("lbcopy.")]:
            del sys.modules[name]


def test_two_copies_never_register_side_by_side_and_each_removes_only_its_own(second_copy):
    copy = second_copy
    first = "layered_brdf_addon"
    second = "lbcopy.layered_brdf_addon"
    try:
        with pytest.raises(RuntimeError, match=r"already enabled from 'layered_brdf_addon'"):
            copy.register()
        copy.unregister()  # what Blender may call after a failed register: leaves the first copy alone
        assert hasattr(bpy.types.Material, SETTINGS)
        assert sorted(_own_handlers(first)) == ["after_edit", "on_load_post"]
        assert _own_handlers(second) == []
        assert all(registration._registered_versions(cls) for cls in registration.CLASSES)
        obj = plain_object()  # the survivor works
        mat = load_preset(obj, "oil_slick")
        assert settings(mat).preset == "oil_slick"
        # The other way round.
        layered_brdf_addon.unregister()
        copy.register()
        with pytest.raises(RuntimeError, match=r"already enabled from 'lbcopy.layered_brdf_addon'"):
            layered_brdf_addon.register()
        layered_brdf_addon.unregister()
        assert hasattr(bpy.types.Material, SETTINGS)
        assert sorted(_own_handlers(second)) == ["after_edit", "on_load_post"]
        assert _own_handlers(first) == []
        copy.unregister()
        assert not hasattr(bpy.types.Material, SETTINGS)
        assert _own_handlers(first) == [] and _own_handlers(second) == []
        assert not hasattr(bpy.types, "LAYERED_BRDF_OT_apply")
    finally:
        copy_registration = sys.modules.get(second + ".blender.registration")
        if copy_registration is not None:
            copy_registration.unregister()
        layered_brdf_addon.register()
    assert registration.is_registered()
