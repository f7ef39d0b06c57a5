"""The render shows the material, whoever edited it (blender/freshness.py): a material with baked tables
(fig6_medium's) edited to Thickness 150-300 nm by every path a script or an artist takes, with and without
the add-on registered, node group and OSL, renders as the material applied with those values does; a
Shift+D copy of the node and its group added by hand to another material render their own values; an
animation that goes gives the tables back; a script's backend and options are what the handlers keep, and
an OSL material where the scene would render it black says how to fix that."""
from __future__ import annotations

import warnings
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends.node_group import PLAN_KEY
from layered_brdf_addon.blender import freshness
from layered_brdf_addon.blender.osl import compile_script_node
from layered_brdf_addon.blender.material import OSLSceneWarning, apply_layered_material, shader_node
from layered_brdf_addon.blender.material_values import settings
from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, render_passes_osl,
                                              reset_blender)
from layered_brdf_addon.blender.stored_keys import BACKEND_KEY, CHOSEN_PLAN_KEY
from layered_brdf_addon.blender.sync import sync_material
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.plan import EffectPlan
from layered_brdf_addon.model.policy import plan_effects

pytestmark = pytest.mark.slow

FIG6 = preset("fig6_medium")  # baked tables by default; a tilted boundary
EDITED = {"Thickness Max": (FIG6.d_max, 300.0), "Thickness Min": (FIG6.d_min, 150.0)}  # max first: min <= max
HEIGHT = 40
OIL = preset("oil_slick").replace(e0=300.0, e1=400.0)  # parallel boundaries (tables in OSL too), a wide highlight
OIL_EDITED = {"Thickness Max": 700.0, "Thickness Min": 400.0}


def _scene(registered: bool, backend: str):
    reset_blender()
    if registered:
        layered_brdf_addon.register()
    (obj,) = build_scene(SceneSpec(camera=camera_for(1, HEIGHT), samples=1, osl=backend == "osl"))
    return obj


def _render(backend: str) -> np.ndarray:
    return (render_passes_osl() if backend == "osl" else render_passes()).beauty


def _off(img: np.ndarray, ref: np.ndarray) -> float:
    """The share of the lit pixels more than 2% off the reference."""
    peak = ref.max(axis=-1)
    rel = np.abs(img - ref).max(axis=-1) / np.maximum(peak, 0.02)
    return float(np.mean(rel[peak > 0.01] > 0.02))


@pytest.fixture(scope="module")
def references():
    """The materials applied with the edited values, per backend; the handlers off again afterwards."""
    out = {}
    for backend in ("nodes", "osl"):
        for name, params in (("", FIG6.replace(d_min=150.0, d_max=300.0)),
                             ("oil ", OIL.replace(d_min=OIL_EDITED["Thickness Min"], d_max=OIL_EDITED["Thickness Max"]))):
            obj = _scene(False, backend)
            apply_layered_material(obj, params, backend)
            out[name + backend] = _render(backend)
    freshness.uninstall()
    yield out
    reset_blender()


def _edit(path: str, mat) -> None:
    tree = mat.node_tree

    def sock(name):
        return shader_node(mat).inputs[name]  # looked up again: a rebuild replaces the node

    if path == "socket":
        for name, (_, value) in EDITED.items():
            sock(name).default_value = value
    elif path == "keyframes":
        for name, (before, after) in EDITED.items():
            data_path = sock(name).path_from_id("default_value")
            sock(name).default_value = before
            tree.keyframe_insert(data_path, frame=1)
            sock(name).default_value = after
            tree.keyframe_insert(data_path, frame=10)
        bpy.context.scene.frame_set(10)
    elif path == "link":
        for name, (_, value) in EDITED.items():
            node = tree.nodes.new("ShaderNodeValue")
            node.outputs[0].default_value = value
            tree.links.new(node.outputs[0], sock(name))
    elif path == "driver":
        for name, (_, value) in EDITED.items():
            tree.driver_add(sock(name).path_from_id("default_value")).driver.expression = repr(value)


@pytest.mark.parametrize("backend", ["nodes", "osl"])
@pytest.mark.parametrize("registered", [False, True], ids=["script", "registered"])
@pytest.mark.parametrize("path", ["socket", "keyframes", "link", "driver"])
def test_every_edit_path_renders_the_edited_material(references, path, registered, backend):
    obj = _scene(registered, backend)
    try:
        mat = apply_layered_material(obj, FIG6, backend)
        _edit(path, mat)
        assert _off(_render(backend), references[backend]) == 0.0
    finally:
        layered_brdf_addon.unregister() if registered else freshness.uninstall()


def _copy_of(node, tree):
    """What Shift+D makes: a node of the same group or script with its stamps and socket values."""
    copy = tree.nodes.new(node.bl_idname)
    if node.bl_idname == "ShaderNodeGroup":
        copy.node_tree = node.node_tree
    else:
        copy.mode = "INTERNAL"
        compile_script_node(copy, script=node.script)
    for key in node.keys():
        copy[key] = node[key]
    for sock in node.inputs:
        if hasattr(sock, "default_value") and not sock.is_linked:
            copy.inputs[sock.name].default_value = sock.default_value
    return copy


@pytest.mark.parametrize("backend, registered, where", [
    ("nodes", False, "same material"), ("nodes", True, "same material"), ("nodes", False, "another material"),
    ("nodes", True, "another material"), ("osl", False, "same material"), ("osl", True, "another material")])
def test_a_copy_of_the_node_renders_its_own_values(references, backend, registered, where):
    obj = _scene(registered, backend)
    try:
        mat = apply_layered_material(obj, OIL, backend)  # parallel boundaries: tables in both backends
        original = shader_node(mat)
        runs = original.node_tree if backend == "nodes" else original.script
        if where == "same material":
            tree = mat.node_tree
        else:
            artist = bpy.data.materials.new("Artist's")
            if artist.node_tree is None:  # Blender 5.0 makes a material without nodes
                artist.use_nodes = True
            obj.material_slots[0].material = artist
            tree = artist.node_tree
        copy = _copy_of(original, tree)
        for name, value in OIL_EDITED.items():
            copy.inputs[name].default_value = value
        out = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
        tree.links.new(copy.outputs[0], out.inputs[0])
        assert _off(_render(backend), references["oil " + backend]) == 0.0
        assert shader_node(mat) == original  # the original keeps its own
        assert (original.node_tree if backend == "nodes" else original.script) == runs
    finally:
        layered_brdf_addon.unregister() if registered else freshness.uninstall()


def test_tables_come_back_when_the_animation_goes():
    obj = _scene(False, "nodes")
    try:
        mat = apply_layered_material(obj, FIG6, "nodes")
        _edit("keyframes", mat)
        bpy.context.scene.frame_set(10)
        assert not _plan_key(mat).endswith("Tb")  # the keyed thickness computed per point
        mat.node_tree.animation_data_clear()
        for name, (before, _) in EDITED.items():  # 150-300 nm cannot be tabulated with a tilt: back to the look's
            shader_node(mat).inputs[name].default_value = before
        bpy.context.scene.frame_set(1)  # no animation left: nothing moves, so the frame handler skips it...
        freshness.before_render(bpy.context.scene)  # ...and the render's check bakes tables again
        assert _plan_key(mat).endswith("Tb")
    finally:
        freshness.uninstall()


def _plan_key(mat) -> str:
    return shader_node(mat).node_tree[PLAN_KEY]


def test_a_chosen_plan_is_kept_and_only_its_tables_follow_the_values():
    obj = _scene(False, "nodes")
    try:
        plan = plan_effects(FIG6.replace(d_min=150.0, d_max=300.0))
        plan = EffectPlan(**{**plan.to_dict(), "tables": False})  # a caller's choice: per point
        mat = apply_layered_material(obj, FIG6, "nodes", plan=plan)
        assert mat[CHOSEN_PLAN_KEY]
        shader_node(mat).inputs["Thickness Max"].default_value = 300.0
        freshness.before_render(bpy.context.scene)
        assert _plan_key(mat) == plan.key
    finally:
        freshness.uninstall()


def test_the_handlers_are_installed_once_and_register_takes_them_over():
    obj = _scene(False, "nodes")
    apply_layered_material(obj, FIG6, "nodes")
    apply_layered_material(obj, FIG6, "nodes")
    for name, fn in freshness.HANDLERS:
        assert sum(f is fn for f in getattr(bpy.app.handlers, name)) == 1
    layered_brdf_addon.register()
    for name, fn in freshness.HANDLERS:
        assert sum(f is fn for f in getattr(bpy.app.handlers, name)) == 1
    layered_brdf_addon.unregister()
    for name, fn in freshness.HANDLERS:
        assert not any(f is fn for f in getattr(bpy.app.handlers, name))


def test_a_script_s_backend_and_options_are_kept_by_the_handlers():
    obj = _scene(True, "osl")
    try:
        mat = apply_layered_material(obj, FIG6, "nodes")
        mat = apply_layered_material(obj, FIG6.replace(accuracy="spectral8"), "osl")
        freshness.after_edit(bpy.context.scene, SimpleNamespace(mode="VIEWPORT", updates=[SimpleNamespace(id=mat)]))
        freshness.before_render(bpy.context.scene)
        assert shader_node(mat).bl_idname == "ShaderNodeScript" and mat[BACKEND_KEY] == "osl"
        assert settings(mat).backend == "osl" and settings(mat).accuracy == "spectral8"
    finally:
        layered_brdf_addon.unregister()


def test_an_osl_material_in_a_scene_that_renders_it_black_says_how_to_fix_it():
    obj = _scene(False, "nodes")  # Cycles, Open Shading Language off (the default)
    try:
        with pytest.warns(OSLSceneWarning, match="shading_system = True"):
            apply_layered_material(obj, FIG6, "osl")
        bpy.context.scene.cycles.shading_system = True
        with warnings.catch_warnings():
            warnings.simplefilter("error", OSLSceneWarning)
            apply_layered_material(obj, FIG6, "osl")
    finally:
        freshness.uninstall()


def test_sync_material_works_where_the_add_on_is_not_registered():
    obj = _scene(False, "nodes")
    try:
        mat = apply_layered_material(obj, FIG6.replace(accuracy="analytic"), "nodes")
        shader_node(mat).inputs["Thickness Max"].default_value = 120.0
        assert sync_material(mat) is True  # rebaked for the new value, the build's settings kept
        assert settings(mat).accuracy == "analytic" and sync_material(mat) is False
    finally:
        freshness.uninstall()
