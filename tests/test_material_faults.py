"""Objects, files and arguments the add-on cannot use are refused by name, with nothing changed;
a damaged material is handled on its own (docs/guarantees.md, "Artist data in a .blend").

Grease Pencil objects, Empties, lights and cameras take no layered material; linked objects and
linked object data are refused (an edit there is not saved); a layered material whose node lost a
socket is reported in the panel and repaired when applied again, and never stops the load-time
upgrade of the others; NaN and infinities in an older file's sockets read as the bounds the shader
uses; the Python API names a wrong argument.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import bpy
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender.material import (MATERIAL_KEY, apply_layered_material, input_value, param_socket,
                                                 read_inputs, remove_layered_material, shader_node)
from layered_brdf_addon.blender import properties, ui
from layered_brdf_addon.blender.freshness import after_edit
from layered_brdf_addon.blender.stored_keys import ENUMS_KEY
from layered_brdf_addon.blender.sync import material_problem, sync_material, upgrade_all
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.params import LayeredParams, ParameterError, iter_sockets

from blender_helpers import activate, add_sphere, addon, draw_panels, labels, load_preset

LEGACY = Path(__file__).parent / "data" / "legacy_sockets.blend"
STAMP = node_group_builder.STAMP_KEY


def plain_object(name="Small"):
    """A coarse sphere added to the current file (several per test)."""
    return add_sphere(name, u_segments=8, v_segments=4)


def slot_names(obj):
    return [s.material.name if s.material is not None else None for s in obj.material_slots]


def grease_pencil_object():
    """A Grease Pencil object with its default materials (Black, White, ...), made active."""
    bpy.ops.object.grease_pencil_add(type="STROKE")
    obj = bpy.context.object
    assert obj.type in ("GREASEPENCIL", "GPENCIL") and obj.material_slots, slot_names(obj)
    return obj


def non_surface_objects():
    """An Empty, an Armature, a Sun and a Camera in the current scene."""
    made = [bpy.data.objects.new("Empty", None),
            bpy.data.objects.new("Armature", bpy.data.armatures.new("Armature")),
            bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN")),
            bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))]
    for obj in made:
        bpy.context.scene.collection.objects.link(obj)
    return made


def panel_labels(obj, alert=None):
    """The labels the material panel and its parameter panels draw for ``obj``."""
    return labels(draw_panels(obj), alert)


def socket_values_of(params):
    return [getattr(params, s.name) for s in iter_sockets()]


def socket_values(mat):
    return socket_values_of(read_inputs(shader_node(mat)))


def remove_group_input(group, name):
    item = next(i for i in group.interface.items_tree
                if i.item_type == "SOCKET" and i.in_out == "INPUT" and i.name == name)
    group.interface.remove(item)


def save_and_reopen(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))


# --- objects that take no shader node material ---------------------------------------------
def test_a_grease_pencil_object_is_refused_by_name_and_keeps_its_materials():
    gp = grease_pencil_object()
    before = slot_names(gp)
    materials = len(bpy.data.materials)
    with pytest.raises(ParameterError) as e:
        apply_layered_material(gp, preset("fig4_parallel"))
    message = str(e.value)
    assert f"object '{gp.name}' ({gp.type})" in message and "Grease Pencil materials" in message, message
    assert "mesh" in message and "'target'" not in message, message
    assert e.value.name == "object" and e.value.value == gp.name
    assert slot_names(gp) == before and len(bpy.data.materials) == materials
    assert remove_layered_material(gp) is False and slot_names(gp) == before
    # The panel and its buttons are not offered for it.
    activate(gp)
    assert not ui.LAYERED_BRDF_PT_material.poll(bpy.context)
    assert not bpy.ops.layered_brdf.apply.poll()
    assert not bpy.ops.layered_brdf.load_preset.poll()


def test_objects_without_material_slots_are_refused_naming_the_object_and_its_type():
    materials = len(bpy.data.materials)
    for obj in non_surface_objects():
        for target in (obj, obj.name):
            with pytest.raises(ParameterError) as e:
                apply_layered_material(target)
            message = str(e.value)
            assert message.startswith(f"object '{obj.name}' ({obj.type}) has no material slots: choose a mesh"), \
                message
            assert "'target'" not in message and e.value.name == "object", message
    assert len(bpy.data.materials) == materials


def test_render_of_an_empty_or_a_grease_pencil_object_exits_2_naming_the_object(tmp_path):
    """The command line passes ``--object`` to the Blender layer: its message names the object."""
    bpy.ops.wm.read_factory_settings(use_empty=False)  # a cube, a camera and a light
    non_surface_objects()
    gp = grease_pencil_object()
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = tmp_path / "out"
    out.mkdir()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    for name, kind in (("Empty", "EMPTY"), (gp.name, gp.type)):
        res = subprocess.run([sys.executable, "-m", "layered_brdf_addon", "render", "--blend", str(blend),
                              f"--object={name}", "--samples", "1", "--output", str(out / "x")],
                             cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
        assert res.returncode == 2, res.stderr
        assert f"object '{name}' ({kind})" in res.stderr and "'target'" not in res.stderr, res.stderr
        assert res.stderr.rstrip().endswith("(option --object)"), res.stderr
        assert "Traceback" not in res.stderr, res.stderr
    assert list(out.iterdir()) == []


# --- linked objects and library overrides --------------------------------------------------
def _library(path):
    """A library file: 'Bare' (no slot) in the scene; 'ByData' (a slot of the mesh, holding Red),
    'ByObject' (a slot of the object, holding Red) and 'NoSlot' in the collection 'Props'."""
    red = bpy.data.materials.new("Red")
    coll = bpy.data.collections.new("Props")
    bpy.context.scene.collection.children.link(coll)
    for name, slots, collection in (("Bare", None, bpy.context.scene.collection), ("ByData", "DATA", coll),
                                    ("ByObject", "OBJECT", coll), ("NoSlot", None, coll)):
        obj = bpy.data.objects.new(name, bpy.data.meshes.new(name))
        if slots is not None:
            obj.data.materials.append(red)
            obj.material_slots[0].link = slots
            obj.material_slots[0].material = red
        collection.objects.link(obj)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_factory_settings(use_empty=True)


def test_a_linked_object_is_refused_and_its_slots_stay_as_saved(tmp_path):
    lib = tmp_path / "lib.blend"
    _library(lib)
    with bpy.data.libraries.load(str(lib), link=True) as (_, data_to):
        data_to.objects = ["Bare", "ByData"]
    for obj in data_to.objects:
        bpy.context.scene.collection.objects.link(obj)
    bare, by_data = data_to.objects
    materials = len(bpy.data.materials)
    for obj in (bare, by_data, "Bare"):
        with pytest.raises(ParameterError) as e:
            apply_layered_material(obj, preset("fig4_parallel"))
        assert "is linked from" in str(e.value) and "make it local first" in str(e.value), str(e.value)
        assert e.value.name == "object"
    with pytest.raises(ParameterError, match="make it local first"):
        remove_layered_material(by_data)
    assert len(bpy.data.materials) == materials
    assert (slot_names(bare), slot_names(by_data)) == ([], ["Red"])
    assert "make it local first" in " ".join(panel_labels(bare, alert=True))
    save_and_reopen(tmp_path / "user.blend")
    assert (slot_names(bpy.data.objects["Bare"]), slot_names(bpy.data.objects["ByData"])) == ([], ["Red"])
    assert not [m for m in bpy.data.materials if m.get(MATERIAL_KEY)]


def test_a_library_override_takes_the_material_in_its_own_slot_only(tmp_path):
    """An override's slot linked to the Object keeps the material (saved as an override); a slot of
    its linked mesh, or a new slot, would not be saved: refused."""
    lib = tmp_path / "lib.blend"
    _library(lib)
    with bpy.data.libraries.load(str(lib), link=True) as (_, data_to):
        data_to.collections = ["Props"]
    coll = data_to.collections[0]
    instance = bpy.data.objects.new("Props instance", None)
    instance.instance_type = "COLLECTION"
    instance.instance_collection = coll
    bpy.context.scene.collection.objects.link(instance)
    coll.override_hierarchy_create(bpy.context.scene, bpy.context.view_layer, do_fully_editable=True)
    local = {o.name: o for o in bpy.data.objects if o.library is None and o.override_library is not None}
    for name in ("ByData", "NoSlot"):
        with pytest.raises(ParameterError, match="linked from|library override") as e:
            apply_layered_material(local[name], preset("fig4_parallel"))
        assert f"object '{name}'" in str(e.value), str(e.value)
    name = apply_layered_material(local["ByObject"], preset("fig4_parallel")).name
    assert slot_names(local["ByObject"]) == [name]
    save_and_reopen(tmp_path / "user.blend")
    local = {o.name: o for o in bpy.data.objects if o.library is None and o.override_library is not None}
    assert (slot_names(local["ByData"]), slot_names(local["NoSlot"])) == (["Red"], [])
    assert slot_names(local["ByObject"]) == [name]
    assert remove_layered_material(local["ByObject"]) is True
    assert slot_names(local["ByObject"]) == ["Red"]


# --- a damaged material, in an older file and in a current one ------------------------------
def _saved_legacy(tmp_path, damage):
    """The file saved by an older version, with ``damage(materials by name)`` done to it, saved to
    ``tmp_path`` without the add-on (so that nothing upgrades it yet)."""
    layered_brdf_addon.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(LEGACY))
        damage({m.name: m for m in bpy.data.materials})
        path = tmp_path / "legacy.blend"
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
    finally:
        layered_brdf_addon.register()
    return path


def _open_upgraded(path, capfd):
    """Open ``path`` with the add-on (load_post upgrades it); the materials by name, and stderr."""
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return {m.name: m for m in bpy.data.materials}, capfd.readouterr().err


def _current(mat) -> bool:
    return shader_node(mat).node_tree.get(STAMP) == node_group_builder.build_stamp()


def _remove_base_green(mats):
    remove_group_input(shader_node(mats["Linked and keyed"]).node_tree, "base_g")


def _junk_enum_record(mats):
    mats["Linked and keyed"][ENUMS_KEY] = 0.5


@pytest.mark.parametrize("damage", [_remove_base_green, _junk_enum_record])
def test_one_damaged_material_in_an_older_file_leaves_the_others_upgraded(tmp_path, capfd, damage):
    mats, err = _open_upgraded(_saved_legacy(tmp_path, damage), capfd)
    assert "Traceback" not in err, err
    assert _current(mats["Shared A"]) and _current(mats["Shared B"])
    # The two shared one group when saved; upgraded, each gets its plan's: A's tilted film fits its
    # tables' budget and reads tables baked for its values, B's thicker one (79-140 nm) computes.
    keys = [shader_node(mats[n]).node_tree[node_group_builder.PLAN_KEY] for n in ("Shared A", "Shared B")]
    assert keys == ["SDNTXBTb", "SDNTXB"], keys
    damaged = mats["Linked and keyed"]
    if damage is _junk_enum_record:  # an unreadable record reads as absent: the material upgrades
        assert _current(damaged) and material_problem(damaged) is None
        return
    assert not _current(damaged)  # left as saved, and the panel says why
    problem = material_problem(damaged)
    assert problem is not None and "'base_g'" in problem and "Rebuild or load a preset" in problem, problem
    obj = next(o for o in bpy.data.objects if o.active_material == damaged)
    assert problem in panel_labels(obj, alert=True)
    assert upgrade_all() == []
    value = read_inputs(shader_node(damaged)).r1_r
    activate(obj)
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}  # Rebuild repairs it, from its own sockets
    assert _current(damaged) and material_problem(damaged) is None
    assert read_inputs(shader_node(damaged)).r1_r == pytest.approx(value)


def test_nan_and_infinities_in_an_older_file_read_as_the_bounds_and_upgrade(tmp_path, capfd):
    def hostile(mats):
        node = shader_node(mats["Linked and keyed"])
        node.inputs["r1_r"].default_value = math.nan
        node.inputs["e1"].default_value = math.inf
        node.inputs["tilt"].default_value = -math.inf

    mats, err = _open_upgraded(_saved_legacy(tmp_path, hostile), capfd)
    assert "Traceback" not in err, err
    mat = mats["Linked and keyed"]
    assert material_problem(mat) is None
    assert all(_current(m) for m in mats.values())
    values = read_inputs(shader_node(mat))
    specs = {name: LayeredParams.spec(name) for name in ("r1_r", "e1", "tilt")}
    assert (values.r1_r, values.e1, values.tilt) == \
        pytest.approx((specs["r1_r"].min, specs["e1"].max, specs["tilt"].min))


def test_a_deleted_group_input_is_reported_and_reapplying_the_same_preset_repairs_it(capfd):
    a, b = plain_object("A"), plain_object("B")
    mat_a, mat_b = load_preset(a, "fig4_parallel"), load_preset(b, "fig4_parallel")
    param_socket(shader_node(mat_b), "r0")[0].default_value = 1.25
    group = shader_node(mat_a).node_tree
    assert shader_node(mat_b).node_tree == group
    remove_group_input(group, "IOR Red")
    for mat in (mat_a, mat_b):
        problem = material_problem(mat)
        assert problem is not None and "'r1_r' (IOR Red)" in problem, problem
        with pytest.raises(ParameterError, match="r1_r"):
            sync_material(mat)
    assert upgrade_all() == []
    capfd.readouterr()
    updates = SimpleNamespace(mode="VIEWPORT", updates=[SimpleNamespace(id=mat_a), SimpleNamespace(id=mat_b)])
    after_edit(bpy.context.scene, updates)
    assert "Traceback" not in capfd.readouterr().err
    labels = panel_labels(a)
    assert material_problem(mat_a) in labels
    assert f"{properties.param_label(LayeredParams.spec('r1_r'))}: not on the node (Rebuild adds it)" in labels
    # The same preset rebuilds the node (a node whose group lacks an input is not current).
    assert load_preset(a, "fig4_parallel") == mat_a
    assert material_problem(mat_a) is None
    assert socket_values(mat_a) == pytest.approx(socket_values_of(preset("fig4_parallel")))
    # The other material keeps the damaged group, and says so, until it is applied again; then
    # the damaged group, unused, is gone.
    assert shader_node(mat_b).node_tree != shader_node(mat_a).node_tree
    assert material_problem(mat_b) is not None
    activate(b)
    assert bpy.ops.layered_brdf.apply() == {"FINISHED"}
    assert material_problem(mat_b) is None
    assert input_value(shader_node(mat_b), "r0") == pytest.approx(1.25)
    # Its own values: tables of its own (materials of equal values share a group).
    groups = {shader_node(mat_a).node_tree, shader_node(mat_b).node_tree}
    assert len(groups) == 2 and material_problem(mat_a) is None
    assert set(g for g in bpy.data.node_groups if g.get(STAMP) is not None) == groups


# --- the Python API's arguments --------------------------------------------------------------
def test_the_python_api_names_a_wrong_argument_and_takes_names_and_dicts():
    obj = plain_object("Cube")
    red = bpy.data.materials.new("Red")
    obj.data.materials.append(red)
    for call, argument in ((lambda: apply_layered_material(None), "target"),
                           (lambda: apply_layered_material(obj.data), "target"),
                           (lambda: apply_layered_material(obj, 42), "params"),
                           (lambda: apply_layered_material(obj, plan="SDN"), "plan"),
                           (lambda: remove_layered_material(None), "obj"),
                           (lambda: remove_layered_material("Nope"), "obj")):
        with pytest.raises(ParameterError) as e:
            call()
        assert e.value.name == argument and f"parameter '{argument}'" in str(e.value), str(e.value)
    assert "an object (bpy.types.Object) or its name" in str(pytest.raises(
        ParameterError, remove_layered_material, 3).value)
    with pytest.raises(ParameterError, match="'no_such'"):
        apply_layered_material(obj, {"no_such": 1.0})
    with pytest.raises(ParameterError, match="'d_min'"):
        apply_layered_material(obj, {"d_min": 500.0, "d_max": 100.0})
    assert slot_names(obj) == ["Red"]
    mat = apply_layered_material("Cube", {"d_min": 120.0, "d_max": 340.0, "lobe": "beckmann"})
    assert (input_value(shader_node(mat), "d_min"), input_value(shader_node(mat), "d_max")) == \
        (pytest.approx(120.0), pytest.approx(340.0))
    assert slot_names(obj) == [mat.name]
    assert remove_layered_material("Cube") is True
    assert slot_names(obj) == ["Red"]
