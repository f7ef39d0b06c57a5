"""Small Blender set-ups shared by the tests that drive the add-on without rendering."""
from __future__ import annotations

import bpy
import pytest


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
