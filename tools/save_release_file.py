"""Save a .blend as this checkout of the add-on makes it, for the migration tests of later versions.

Run from the root of a checkout of a released version, with that version's Blender Python:
``python tools/save_release_file.py OUT.blend``.  Three spheres: a node-group material with a
keyframed Upper Exponent and a driven Tilt (an Average driver of a scene property), one with a
Value node linked into an exponent, and an OSL material with keyframes on its exponent and
tilt; the frame set between keys.  Written whole: a temporary file renamed into place.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import bpy

sys.path.insert(0, os.getcwd())
import layered_brdf_addon  # noqa: E402  (from the checkout being recorded)
from layered_brdf_addon.blender.material import apply_layered_material, shader_node  # noqa: E402
from layered_brdf_addon.model import preset  # noqa: E402


def _sphere(name, x):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.9, location=(x, 0.0, 0.0), segments=48, ring_count=24)
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    return obj


def main(out: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    layered_brdf_addon.register()
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.05, 0.05, 0.05)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -9.0, 0.0)
    cam.rotation_euler = (1.5708, 0.0, 0.0)
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 6.2
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.9, 0.0, 0.5)
    sun.data.energy = 3.0
    sun.data.angle = 0.05
    scene.collection.objects.link(sun)
    scene["tilt_deg"] = 12.0

    keyed = apply_layered_material(_sphere("Keyed", -2.0), preset("fig4_tilted"), name="Keyed and driven")
    node = shader_node(keyed)
    sock = node.inputs["Upper Exponent"]
    for frame, value in ((1, 60.0), (9, 900.0)):
        sock.default_value = value
        sock.keyframe_insert("default_value", frame=frame)
    fc = node.inputs["Tilt (°)"].driver_add("default_value")
    fc.driver.type = "AVERAGE"
    var = fc.driver.variables.new()
    var.name = "tilt"
    var.targets[0].id_type = "SCENE"
    var.targets[0].id = scene
    var.targets[0].data_path = '["tilt_deg"]'

    linked = apply_layered_material(_sphere("Linked", 0.0), preset("fig4_parallel"), name="Linked exponent")
    tree = linked.node_tree
    value = tree.nodes.new("ShaderNodeValue")
    value.name = value.label = "Artist exponent"
    value.outputs[0].default_value = 250.0
    tree.links.new(value.outputs[0], shader_node(linked).inputs["Lower Exponent"])

    osl = apply_layered_material(_sphere("OSL", 2.0), preset("fig6_medium"), backend="osl", name="OSL keyed")
    node = shader_node(osl)
    for name, keys in (("e0", ((1, 40.0), (9, 400.0))), ("tilt", ((1, 5.0), (9, 25.0)))):
        for frame, v in keys:
            node.inputs[name].default_value = v
            node.inputs[name].keyframe_insert("default_value", frame=frame)
    scene.frame_set(4)
    tmp = out.with_name(out.name + ".tmp.blend")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp), compress=True)
    os.replace(tmp, out)
    layered_brdf_addon.unregister()


if __name__ == "__main__":
    main(Path(sys.argv[1]).resolve())
