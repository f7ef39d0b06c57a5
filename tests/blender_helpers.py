"""Small Blender set-ups shared by the tests that drive the add-on without rendering."""
from __future__ import annotations

from types import SimpleNamespace

import bpy
import pytest

from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender.material import input_value, shader_node
from layered_brdf_addon.model.params import iter_sockets


@pytest.fixture(scope="module", autouse=True)
def addon():
    """The add-on registered for the module that imports this fixture, from an empty file."""
    import layered_brdf_addon
    from layered_brdf_addon.blender.scene import reset_blender

    reset_blender()
    layered_brdf_addon.register()
    yield
    layered_brdf_addon.unregister()
    reset_blender()


@pytest.fixture
def user_dir(tmp_path, monkeypatch):
    """User presets in a temporary folder."""
    from layered_brdf_addon.blender import user_presets

    path = tmp_path / "presets"
    path.mkdir()
    monkeypatch.setattr(user_presets, "presets_dir", lambda: path)
    return path


def add_sphere(name: str = "Small", u_segments: int = 16, v_segments: int = 8):
    """A UV sphere of radius 1 added to the current scene (rendered with Cycles), made active."""
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=u_segments, v_segments=v_segments, radius=1.0)
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.render.engine = "CYCLES"
    return activate(obj)


def activate(obj):
    bpy.context.view_layer.objects.active = obj
    return obj


def load_preset(obj, name):
    """Load a preset onto ``obj`` through the panel's operator; the material it made."""
    activate(obj)
    assert bpy.ops.layered_brdf.load_preset(preset=name) == {"FINISHED"}
    return obj.active_material


class Layout:
    """Records what a panel draws (stands in for UILayout, which needs a window)."""

    def __init__(self, log):
        self.log = log
        self.alert = False
        self.enabled = True
        self.active = True
        self.use_property_split = False
        self.use_property_decorate = False

    def row(self, **_):
        return Layout(self.log)

    column = box = row

    def label(self, text="", icon="NONE", **_):
        self.log.append(("label", text, self.alert))

    def prop(self, data, prop, text=None, **_):
        assert prop in data.bl_rna.properties, f"{data!r} has no property {prop}"
        self.log.append(("prop", data, prop, text))

    def template_list(self, list_type, list_id, data, prop, active_data, active_prop, **_):
        assert getattr(bpy.types, list_type, None) is not None, f"list {list_type} is not registered"
        assert prop in data.bl_rna.properties and active_prop in active_data.bl_rna.properties
        self.log.append(("list", list_type, data, prop))

    def operator(self, idname, text=None, **_):
        props = SimpleNamespace()
        self.log.append(("operator", idname, text, props))
        return props

    def menu(self, menu, text="", **_):
        assert getattr(bpy.types, menu, None) is not None, f"menu {menu} is not registered"
        self.log.append(("menu", menu, text))

    def separator(self, **_):
        pass


def draw_panels(obj):
    """What the material panel and its parameter panels draw for ``obj``: the log of a :class:`Layout`."""
    from layered_brdf_addon.blender import ui

    log = []
    ctx = SimpleNamespace(object=obj, scene=bpy.context.scene)
    ui.LAYERED_BRDF_PT_material.draw(SimpleNamespace(layout=Layout(log)), ctx)
    for panel in ui.PARAM_PANELS:
        if panel.poll(ctx):
            panel.draw(SimpleNamespace(layout=Layout(log), group=panel.group), ctx)
    return log


def labels(log, alert=None):
    """The labels of a panel log (only the alerts, or only the others, when ``alert`` is given)."""
    return [e[1] for e in log if e[0] == "label" and (alert is None or e[2] == alert)]


def built_plan(mat):
    """Key of the effect plan the material's node group was built for."""
    node = shader_node(mat)
    assert node.bl_idname == "ShaderNodeGroup"
    return node.node_tree[node_group_builder.PLAN_KEY]


def socket_values(mat):
    """The parameter values in the material's shader node sockets."""
    node = shader_node(mat)
    return {s.name: input_value(node, s.name) for s in iter_sockets()}
