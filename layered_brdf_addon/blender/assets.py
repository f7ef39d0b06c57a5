"""The layered node groups as Asset Browser assets, with a rendered preview.

Blender renders no previews of node groups (``ID.asset_generate_preview`` does nothing
for them), so the preview is a small Cycles render of a sphere carrying the group in a
temporary scene, written into the group's preview image.
"""
from __future__ import annotations

import os
import tempfile

import bpy

from ..model.plan import EffectPlan
from . import material as M
from ..backends import node_group as node_group_builder
from .scene import render_to_file

CATALOG_ID = "4b0f3f52-5d0c-4c55-9d2e-6b8d1c1f7a21"  # "Layered BRDF"
CATALOG_PATH = "Layered BRDF"
AUTHOR = "layered-brdf"
BASE_TAGS = ("Layered BRDF", "iridescent", "thin film", "shader")
PREVIEW_KEY = "layered_brdf_preview"  # build stamp of the group the preview shows
PREVIEW_SIZE = 64

_queued: set[str] = set()
# The timer functions this module registered, kept across importlib.reload (which re-runs this
# file in the same module dict), so unregister() cancels a timer queued by an earlier import too.
_timers: list = globals().get("_timers", [])


def group_of(mat):
    """The node group behind ``mat``'s layered shader (None with the OSL backend)."""
    node = M.shader_node(mat)
    if node is None or node.bl_idname != "ShaderNodeGroup":
        return None
    return node.node_tree


def mark_group(group, plan: EffectPlan) -> None:
    """Mark ``group`` as an asset with description, tags, author and catalog (idempotent)."""
    if group.asset_data is None:
        group.asset_mark()
    data = group.asset_data
    data.description = "Layered BRDF (Granier & Heidrich 2003) for Cycles and EEVEE: " + "; ".join(plan.describe())
    data.author = AUTHOR
    data.catalog_id = CATALOG_ID
    names = {t.name for t in data.tags}
    for tag in (*BASE_TAGS, f"plan {plan.key}"):
        if tag not in names:
            data.tags.new(tag)


def preview_current(group) -> bool:
    return group.preview is not None and group.get(PREVIEW_KEY) == _preview_stamp(group)


def _preview_stamp(group) -> str:
    return f"{group.get(node_group_builder.STAMP_KEY)}|{group.get(node_group_builder.PLAN_KEY)}"


def publish(mat, plan: EffectPlan, preview: bool = True):
    """Mark ``mat``'s node group as an asset; render its preview now (``preview``) or when idle."""
    group = group_of(mat)
    if group is None:
        return None
    mark_group(group, plan)
    if not preview_current(group):
        if preview and not bpy.app.is_job_running("RENDER"):
            render_preview(group)
        else:
            queue_preview(group)
    return group


def _sphere_mesh(name):
    import bmesh

    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=48, v_segments=24, radius=1.0)
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    return mesh


def render_preview(group, size: int = PREVIEW_SIZE) -> None:
    """Render a sphere carrying ``group`` with its default inputs into the group's preview."""
    import numpy as np
    from mathutils import Vector

    name = "layered_brdf_preview"
    created = []
    scene = bpy.data.scenes.new(name)
    created.append(scene)
    tmpdir = tempfile.mkdtemp(prefix="layered_brdf_preview_")
    path = os.path.join(tmpdir, "preview.png")
    try:
        mesh = _sphere_mesh(name)
        mat = bpy.data.materials.new(name)
        created += [mesh, mat]
        tree = mat.node_tree
        tree.nodes.clear()
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        tree.links.new(node.outputs["BSDF"], out.inputs["Surface"])
        mesh.materials.append(mat)
        sphere = bpy.data.objects.new(name, mesh)
        cam_data = bpy.data.cameras.new(name)
        cam_data.type = "ORTHO"
        cam_data.ortho_scale = 2.1
        cam = bpy.data.objects.new(name + "_camera", cam_data)
        cam.location = (0.0, -5.0, 0.0)
        cam.rotation_euler = (1.5707963, 0.0, 0.0)
        sun_data = bpy.data.lights.new(name, "SUN")
        sun_data.energy = 3.0
        sun_data.angle = 0.05
        sun = bpy.data.objects.new(name + "_sun", sun_data)
        sun.rotation_mode = "QUATERNION"
        sun.rotation_quaternion = Vector((0.45, -1.0, 0.55)).to_track_quat("Z", "Y")
        world = bpy.data.worlds.new(name)
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.06, 0.06, 0.07, 1.0)
        created += [sphere, cam_data, cam, sun_data, sun, world]
        for obj in (sphere, cam, sun):
            scene.collection.objects.link(obj)
        scene.camera = cam
        scene.world = world
        r = scene.render
        r.engine = "CYCLES"
        r.resolution_x = r.resolution_y = size
        r.resolution_percentage = 100
        r.film_transparent = True
        r.threads_mode = "FIXED"
        r.threads = 2
        r.image_settings.file_format = "PNG"
        r.image_settings.color_mode = "RGBA"
        scene.view_settings.view_transform = "Standard"
        c = scene.cycles
        c.device = "CPU"
        c.samples = 4
        c.use_adaptive_sampling = False
        c.use_denoising = False
        c.max_bounces = 1
        render_to_file(path, scene)
        image = bpy.data.images.load(path)
        created.append(image)
        pixels = np.empty(size * size * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
        preview = group.preview_ensure()
        preview.image_size = (size, size)
        preview.image_pixels_float.foreach_set(pixels)
        group[PREVIEW_KEY] = _preview_stamp(group)
    finally:
        bpy.data.batch_remove(created)
        if os.path.exists(path):
            os.remove(path)
        os.rmdir(tmpdir)


def queue_preview(group) -> None:
    """Render ``group``'s preview when Blender is idle (interactive sessions only)."""
    if bpy.app.background:
        return
    _queued.add(group.name)
    if not bpy.app.timers.is_registered(_render_queued):
        bpy.app.timers.register(_render_queued, first_interval=0.5)
        if _render_queued not in _timers:
            _timers.append(_render_queued)


def _render_queued():
    if bpy.app.is_job_running("RENDER"):
        return 2.0
    while _queued:
        group = bpy.data.node_groups.get(_queued.pop())
        if group is not None and group.library is None and not preview_current(group):
            render_preview(group)
    return None


def cancel_queued() -> None:
    """Forget the queued previews and cancel every timer this module (or an earlier import of it) queued."""
    _queued.clear()
    for fn in [*_timers, _render_queued]:
        if bpy.app.timers.is_registered(fn):
            bpy.app.timers.unregister(fn)
    _timers.clear()
