"""Every artist preset's look built from the node alone, without the add-on: a material applied
with Effects 'all', the add-on removed, the file reopened, the node's sockets typed in (and, for the
soap film, Blender's own nodes linked: a Transparent BSDF under it, a thickness that grows
downwards into its Thickness input), rendered; compared with the preset applied by the add-on."""
from __future__ import annotations

import bpy
import pytest

import layered_brdf_addon
from layered_brdf_addon.blender.material import apply_layered_material
from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, render_passes, reset_blender, \
    row_of_spheres
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.params import BASE_COLOR_SOCKET, group_socket_name, iter_sockets, socket_units
from layered_brdf_addon.model.presets import ARTIST_PRESETS
from layered_brdf_addon.model.socket_units import to_socket
from layered_brdf_addon.model.sphere import sphere_geometry
from layered_brdf_reference.compare import agreement

from constants import MAX_FAILING_COARSE, REL_TOL_COARSE, SUN_40

NAMES = list(ARTIST_PRESETS)
START = "oil_slick"


CAMERA = camera_for(len(NAMES), 64)
CENTERS = row_of_spheres(len(NAMES))


def _scene():
    reset_blender()
    return build_scene(SceneSpec(camera=CAMERA, sun=SUN_40, centers=CENTERS, samples=16))


def _type_in(mat, name):
    """What an artist does in the node editor to give the material preset ``name``'s look."""
    params = preset(name)
    tree = mat.node_tree
    node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeGroup")
    for spec in iter_sockets():
        value = getattr(params, spec.name)
        sock = node.inputs[group_socket_name(spec)]
        if spec.component is not None:
            colour = list(sock.default_value)
            colour[spec.component] = value
            sock.default_value = colour
        else:
            sock.default_value = to_socket(socket_units(spec, "nodes"), value)
    if params.base_layer == "transparent":
        tree.links.new(tree.nodes.new("ShaderNodeBsdfTransparent").outputs[0], node.inputs["Base Shader"])
    if params.thickness_mode == "height":  # d_min + (d_max - d_min) clamp(0.5 - 0.5 z)
        coords, xyz = tree.nodes.new("ShaderNodeTexCoord"), tree.nodes.new("ShaderNodeSeparateXYZ")
        factor, thickness = tree.nodes.new("ShaderNodeMath"), tree.nodes.new("ShaderNodeMath")
        factor.operation = thickness.operation = "MULTIPLY_ADD"
        factor.use_clamp = True
        factor.inputs[1].default_value, factor.inputs[2].default_value = -0.5, 0.5
        thickness.inputs[1].default_value = params.d_max - params.d_min
        thickness.inputs[2].default_value = params.d_min
        tree.links.new(coords.outputs["Object"], xyz.inputs[0])
        tree.links.new(xyz.outputs["Z"], factor.inputs[0])
        tree.links.new(factor.outputs[0], thickness.inputs[0])
        tree.links.new(thickness.outputs[0], node.inputs["Thickness"])


@pytest.mark.slow
def test_each_artist_preset_is_built_from_the_node_alone(tmp_path):
    spheres = _scene()
    for k, (obj, name) in enumerate(zip(spheres, NAMES)):
        apply_layered_material(obj, preset(name), name=f"Preset {name}")
    expected = render_passes().beauty[..., :3]

    spheres = _scene()
    for k, obj in enumerate(spheres):
        apply_layered_material(obj, preset(START).replace(effects="all"), name=f"Edited {k}")
    path = tmp_path / "node_alone.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    registered = hasattr(bpy.types.Material, SETTINGS)
    layered_brdf_addon.unregister()  # no add-on: no handler, no panel
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        for k, name in enumerate(NAMES):
            _type_in(bpy.data.materials[f"Edited {k}"], name)
        edited = render_passes().beauty[..., :3]
    finally:
        if registered:  # left as found: a registered add-on's handlers would re-plan later tests' materials
            layered_brdf_addon.register()
    geo = sphere_geometry(CAMERA, CENTERS)
    for k, name in enumerate(NAMES):
        ag = agreement(edited, expected, geo.sphere == k, rel_tol=REL_TOL_COARSE)
        lit = expected[geo.sphere == k].max()
        print(f"{name}: node alone vs the add-on's preset {ag}; brightest {lit:.3f}")
        assert lit > 0.05, name  # the look is there to compare
        assert ag.failing_fraction <= MAX_FAILING_COARSE, (name, ag)
