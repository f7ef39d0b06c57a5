"""Baked tables in a .blend (blender/tables.py): baked on apply, packed and stamped as the add-on's,
rebaked in place when a value changes (from a script or typed on the node), never shared with a
copied material once it changes, baked again when their texels are not what was baked (an undo) or
their format is older, removed when no material reads them; a file renders the same without the
add-on and from a library."""
from __future__ import annotations

import time

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.blender import sync, tables
from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_addon.blender.material_values import params_of
from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, render_passes, reset_blender, \
    row_of_spheres
from layered_brdf_addon.blender.stored_keys import SETTINGS
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.params import group_socket_name, LayeredParams
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.table_bake import table_layout
from layered_brdf_addon.model.sphere import sphere_geometry
from layered_brdf_reference.compare import agreement

from blender_helpers import add_sphere, addon  # noqa: F401 (addon: the add-on registered for this module)
from constants import SUN_40

OIL = preset("oil_slick")


def _images(group) -> list:
    return [readers[0].image for _, readers in sorted(node_group_builder.table_nodes(group).items())]


def _texels(image) -> np.ndarray:
    return tables._pixels(image).copy()


def _apply(target, params):
    """What the panel's preset menu does: the material built and its settings written."""
    if isinstance(target, bpy.types.Material):
        return sync.apply(target, params, "nodes", plan_effects(params), preview=False)
    return sync.apply_to_object(target, params, "nodes", preview=False)


def _current(mat, check_pixels=True) -> bool:
    return tables.tables_current(shader_node(mat).node_tree, params_of(mat), plan_effects(params_of(mat)),
                                 check_pixels)


def test_apply_bakes_packed_tables_stamped_as_the_add_on_s():
    mat = _apply(add_sphere(), OIL)
    group = shader_node(mat).node_tree
    assert group[node_group_builder.PLAN_KEY].endswith("Tb") and "baked tables" in group.name
    images = _images(group)
    assert len(images) == 5  # reflected, transmitted, diffuse + Base Shader, anisotropies, transmittance
    for image in images:
        assert image.packed_file is not None and image.is_float and image.name.startswith(".")
        assert image.colorspace_settings.name == "Non-Color" and image.alpha_mode == "CHANNEL_PACKED"
        assert image[tables.DIGEST_KEY] == group[tables.DIGEST_KEY]
    assert sum(i.size[0] * i.size[1] * 16 for i in images) <= 1 << 20
    assert _current(mat)


def test_a_change_rebakes_the_same_images_in_place():
    mat = _apply(add_sphere(), OIL)
    group = shader_node(mat).node_tree
    images = _images(group)
    before = [_texels(i) for i in images]
    times = []
    for k, ks in enumerate((0.3, 0.35, 0.4, 0.45, 0.5)):
        t = time.perf_counter()
        _apply(mat, OIL.replace(ks=ks))
        times.append(time.perf_counter() - t)
    print(f"apply with a changed value: median {1000 * np.median(times):.1f} ms over {len(times)}")
    assert shader_node(mat).node_tree == group and _images(group) == images
    assert any(np.abs(_texels(i) - b).max() > 1e-4 for i, b in zip(images, before))
    assert _current(mat)
    assert len([i for i in bpy.data.images if tables.DIGEST_KEY in i]) == 5  # no leftovers


def test_a_tilted_boundary_reads_each_image_at_two_slices_and_rebakes_them_in_place():
    """A tilted boundary's tables: every image a row of azimuth slices, read by two Image Texture nodes
    (the diffuse image, the same in every slice, by one); a new tilt rebakes the same images, a new tilt
    azimuth (turned point by point) bakes nothing."""
    tilted = OIL.replace(normal_mode="tilted", tilt=12.0, d_min=300.0, d_max=330.0)
    mat = _apply(add_sphere(), tilted)
    group = shader_node(mat).node_tree
    assert group[node_group_builder.PLAN_KEY].endswith("Tb") and _current(mat)
    layout = table_layout(tilted, plan_effects(tilted))
    readers = node_group_builder.table_nodes(group)
    assert sorted(readers) == list(range(layout.images)) and layout.oriented
    for k, nodes in readers.items():
        assert len(nodes) == (1 if k == layout.diffuse_image else 2)
        assert all(n.image == nodes[0].image for n in nodes)
    images = _images(group)
    assert all(i.size[0] == layout.azimuths * (layout.width + 2) for i in images)
    assert sum(i.size[0] * i.size[1] * 16 for i in images) <= 1 << 20
    crcs = [i[tables.CHECKSUM_KEY] for i in images]
    _apply(mat, tilted.replace(tilt_azimuth=45.0))
    assert [i[tables.CHECKSUM_KEY] for i in images] == crcs
    _apply(mat, tilted.replace(tilt=14.0))
    assert shader_node(mat).node_tree == group and _images(group) == images and _current(mat)
    assert [i[tables.CHECKSUM_KEY] for i in images] != crcs
    assert len([i for i in bpy.data.images if tables.DIGEST_KEY in i]) == layout.images


def test_a_value_typed_on_the_node_is_rebaked_when_the_material_syncs():
    mat = _apply(add_sphere(), OIL)
    node = shader_node(mat)
    node.inputs[group_socket_name(LayeredParams.spec("ks"))].default_value = 0.25
    assert not _current(mat)
    assert sync.sync_material(mat)
    assert params_of(mat).ks == pytest.approx(0.25) and _current(mat)


def test_a_flowing_noise_keeps_the_tables_and_bakes_nothing():
    """A keyframed noise phase (a film that flows) is not in the tables: the material keeps reading them, and
    a frame change, a sync or a new noise scale bakes nothing."""
    mat = _apply(add_sphere(), OIL)
    node = shader_node(mat)
    sock = node.inputs[group_socket_name(LayeredParams.spec("noise_phase"))]
    for frame, phase in ((1, 0.0), (20, 3.0)):
        sock.default_value = phase
        sock.keyframe_insert("default_value", frame=frame)
    bpy.context.view_layer.update()
    sync.sync_material(mat)
    group = shader_node(mat).node_tree
    assert group[node_group_builder.PLAN_KEY].endswith("Tb") and _current(mat)
    images = _images(group)
    crcs = [i[tables.CHECKSUM_KEY] for i in images]
    bpy.context.scene.frame_set(10)
    node.inputs[group_socket_name(LayeredParams.spec("noise_scale"))].default_value = OIL.noise_scale * 3.0
    assert not sync.sync_material(mat)  # nothing to rebuild or bake
    assert shader_node(mat).node_tree == group and _images(group) == images
    assert [i[tables.CHECKSUM_KEY] for i in images] == crcs and _current(mat)


def test_a_copied_material_gets_tables_of_its_own_when_it_changes():
    original = _apply(add_sphere(), OIL)
    copy = original.copy()
    group = shader_node(original).node_tree
    texels = [_texels(i) for i in _images(group)]
    assert shader_node(copy).node_tree == group  # equal values: the tables are shared
    shader_node(copy).inputs[group_socket_name(LayeredParams.spec("ks"))].default_value = 0.25
    sync.sync_material(copy)
    assert shader_node(copy).node_tree != group and shader_node(original).node_tree == group
    assert not set(_images(group)) & set(_images(shader_node(copy).node_tree))
    assert all(np.array_equal(_texels(i), t) for i, t in zip(_images(group), texels))
    assert _current(original) and _current(copy)


def test_texels_that_are_not_what_was_baked_are_baked_again():
    """An undo restores the material's values and the images' stamps, not the texels baked since:
    the handler reads every table back and rebakes what differs."""
    mat = _apply(add_sphere(), OIL)
    image = _images(shader_node(mat).node_tree)[0]
    stale = _texels(image)
    stale[..., 0] *= 1.5
    image.pixels.foreach_set(stale.ravel())
    assert _current(mat, check_pixels=False) and not _current(mat)
    sync.on_undo_redo()
    assert _current(mat)


def test_tables_of_another_format_are_rebaked_when_the_file_opens(tmp_path):
    mat = _apply(add_sphere(), OIL)
    name = mat.name
    group = shader_node(mat).node_tree
    group[tables.DIGEST_KEY] = "an older format"
    path = tmp_path / "older.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))  # the load handler rebakes
    assert _current(bpy.data.materials[name])


def test_tables_no_material_reads_are_removed():
    mat = _apply(add_sphere(), OIL)
    assert [i for i in bpy.data.images if tables.DIGEST_KEY in i]
    _apply(mat, OIL.replace(evaluation="arithmetic"))
    assert not plan_effects(params_of(mat)).tables
    assert not [i for i in bpy.data.images if tables.DIGEST_KEY in i]
    assert not [g for g in bpy.data.node_groups if tables.DIGEST_KEY in g]


def test_an_image_of_the_artist_s_is_never_touched():
    own = bpy.data.images.new("Artist's texture", 8, 8)
    own.use_fake_user = True
    mat = _apply(add_sphere(), OIL)
    _apply(mat, OIL.replace(evaluation="arithmetic"))
    assert bpy.data.images.get("Artist's texture") == own


CAMERA = camera_for(2, 64)
CENTERS = row_of_spheres(2)


@pytest.mark.slow
def test_a_file_renders_the_same_without_the_add_on_and_from_a_library(tmp_path):
    reset_blender()
    spheres = build_scene(SceneSpec(camera=CAMERA, sun=SUN_40, centers=CENTERS, samples=4))
    for obj, name in zip(spheres, ("oil_slick", "anodised_titanium")):
        apply_layered_material(obj, preset(name), name=name)
    expected = render_passes().beauty[..., :3]
    path = tmp_path / "tables.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    registered = hasattr(bpy.types.Material, SETTINGS)
    layered_brdf_addon.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        alone = render_passes().beauty[..., :3]
        # The same spheres with the materials linked from the saved file.
        reset_blender()
        spheres = build_scene(SceneSpec(camera=CAMERA, sun=SUN_40, centers=CENTERS, samples=4))
        with bpy.data.libraries.load(str(path), link=True) as (src, dst):
            dst.materials = ["oil_slick", "anodised_titanium"]
        for obj, mat in zip(spheres, dst.materials):
            obj.data.materials.clear()
            obj.data.materials.append(mat)
        linked = render_passes().beauty[..., :3]
    finally:
        if registered:
            layered_brdf_addon.register()
    geo = sphere_geometry(CAMERA, CENTERS)
    for k in range(2):
        for label, image in (("without the add-on", alone), ("linked", linked)):
            ag = agreement(image, expected, geo.sphere == k, rel_tol=1e-4)
            print(f"sphere {k} {label}: {ag}")
            assert ag.failing_fraction == 0.0, (k, label, ag)
        assert expected[geo.sphere == k].max() > 0.05


def test_a_change_of_the_row_count_keeps_the_node_s_values_links_and_the_group_s_name():
    mat = _apply(add_sphere(), OIL)
    node = shader_node(mat)
    name = node.node_tree.name
    base = mat.node_tree.nodes.new("ShaderNodeBsdfTransparent")  # the artist's own shader under the film
    mat.node_tree.links.new(base.outputs[0], node.inputs["Base Shader"])
    node.inputs[group_socket_name(LayeredParams.spec("ks"))].default_value = 0.4
    rows = _images(node.node_tree)[0].size[1]
    node.inputs[group_socket_name(LayeredParams.spec("d_max"))].default_value = 900.0  # more fringes: more rows
    sync.sync_material(mat)
    node = shader_node(mat)
    assert _images(node.node_tree)[0].size[1] > rows
    assert node.node_tree.name == name and params_of(mat).d_max == pytest.approx(900.0)
    assert params_of(mat).ks == pytest.approx(0.4) and _current(mat)
    assert node.inputs["Base Shader"].links[0].from_node == base
    assert len([g for g in bpy.data.node_groups if tables.DIGEST_KEY in g]) == 1
    assert len([i for i in bpy.data.images if tables.DIGEST_KEY in i]) == 5
