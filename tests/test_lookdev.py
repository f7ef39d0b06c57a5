"""The look-development scene: it builds inside the current file, renders a layered preset,
and removing it leaves the file as it was."""
from __future__ import annotations

import math

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender.lookdev import (GROOVE_DEPTH, build_lookdev_scene, eevee_engine, hdri_folder,
                                                hdri_path, principled_thin_film, remove_scene, thin_film_equivalent)
from layered_brdf_addon.blender import tables
from layered_brdf_addon.blender.material import apply_layered_material
from layered_brdf_addon.blender.scene import render_passes
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.presets import preset

COLLECTIONS = ("scenes", "objects", "meshes", "cameras", "lights", "worlds", "images", "materials", "node_groups",
               "collections", "texts")
SESSION_IMAGES = {"Render Result", "Viewer Node"}  # Blender's own, shared by every render


def datablocks() -> dict[str, set[int]]:
    return {c: {b.as_pointer() for b in getattr(bpy.data, c) if b.name not in SESSION_IMAGES} for c in COLLECTIONS}


def test_hdri_path_prefers_forest_and_names_the_choices():
    assert hdri_path().name == "forest.exr" and hdri_path().is_file()
    assert hdri_path("courtyard") == hdri_path("courtyard.exr") == hdri_folder() / "courtyard.exr"
    with pytest.raises(ParameterError) as e:
        hdri_path("no_such_sky")
    assert e.value.name == "hdri" and "forest" in str(e.value) and "studio" in str(e.value)


def test_bad_options_name_the_parameter_and_create_nothing():
    before = datablocks()
    for kwargs, name in [(dict(size=0), "size"), (dict(size=5000), "size"), (dict(samples=0), "samples"),
                         (dict(engine="LUXCORE"), "engine"), (dict(hdri="mars"), "hdri"),
                         (dict(view_transform="Filmic Ultra"), "view_transform")]:
        with pytest.raises(ParameterError) as e:
            build_lookdev_scene(**kwargs)
        assert e.value.name == name, kwargs
    assert datablocks() == before


def test_scene_settings_and_the_ball():
    scene, ball = build_lookdev_scene(size=48, samples=3)
    try:
        assert scene is not bpy.context.scene and scene.camera is not None
        assert scene.render.engine == "CYCLES" and scene.cycles.device == "CPU"
        assert (scene.render.resolution_x, scene.render.resolution_y) == (48, 48)
        assert scene.cycles.samples == 3 and not scene.cycles.use_denoising and not scene.cycles.use_adaptive_sampling
        assert scene.render.threads_mode == "FIXED" and scene.render.threads == 2
        assert scene.view_settings.view_transform == "AgX" and scene.view_settings.look == "None"
        env = [n for n in scene.world.node_tree.nodes if n.bl_idname == "ShaderNodeTexEnvironment"]
        assert len(env) == 1 and env[0].image.filepath.endswith("forest.exr")
        assert any(o.type == "LIGHT" and o.data.type == "SUN" and o.data.angle > 0 for o in scene.objects)
        assert len(ball.material_slots) == 1 and ball.material_slots[0].material is None
        assert all(p.use_smooth for p in ball.data.polygons)
        # a unit ball with a groove: radii from the centre between 1 - depth and 1
        co = np.empty(len(ball.data.vertices) * 3)
        ball.data.vertices.foreach_get("co", co)
        r = np.linalg.norm(co.reshape(-1, 3), axis=1)
        assert math.isclose(r.max(), 1.0, abs_tol=1e-6) and math.isclose(r.min(), 1.0 - GROOVE_DEPTH, abs_tol=1e-3)
        eevee, _ = build_lookdev_scene(size=16, samples=1, engine="BLENDER_EEVEE", view_transform="Standard")
        assert eevee.render.engine == eevee_engine() and eevee.view_settings.view_transform == "Standard"
        remove_scene(eevee)
    finally:
        remove_scene(scene)


@pytest.mark.slow
def test_renders_a_layered_preset_and_leaves_no_datablocks_behind():
    before = datablocks()
    scene, ball = build_lookdev_scene(size=32, samples=2)
    mat = apply_layered_material(ball, preset("oil_slick"), "nodes")
    beauty = render_passes(scene).beauty
    assert beauty.shape == (32, 32, 3) and np.all(np.isfinite(beauty))
    centre = beauty[10:22, 10:22].mean(axis=(0, 1))
    assert centre.sum() > 0.05  # the lit ball fills the middle of the frame
    added = {c: datablocks()[c] - before[c] for c in COLLECTIONS}
    assert added["scenes"] and added["objects"] and added["worlds"] and added["images"]
    remove_scene(scene)
    left = {c: datablocks()[c] - before[c] for c in COLLECTIONS}
    # only what the caller made is left: the material applied to the ball, its node groups and their
    # baked tables
    assert left["materials"] == {mat.as_pointer()}
    tables_read = {n.image.as_pointer() for g in bpy.data.node_groups for n in g.nodes
                   if n.bl_idname == "ShaderNodeTexImage" and n.image is not None and tables.DIGEST_KEY in n.image}
    assert left["images"] <= tables_read
    assert all(not left[c] for c in COLLECTIONS if c not in ("materials", "node_groups", "images"))
    bpy.data.materials.remove(mat)


def test_principled_thin_film_equivalent_of_a_preset():
    p = preset("anodised_titanium")
    kw = thin_film_equivalent("anodised_titanium", p)
    assert kw["thickness_nm"] == pytest.approx((p.d_min + p.d_max) / 2) and kw["ior"] == p.r1_g
    # The metal under the film (titanium's n and k): its reflectance at normal incidence.
    assert kw["metallic"] == 1.0 and kw["base_color"][0] == pytest.approx(
        ((p.r2_r - 1) ** 2 + p.k2_r ** 2) / ((p.r2_r + 1) ** 2 + p.k2_r ** 2))
    assert kw["thickness_noise"] == (p.d_min, p.d_max, p.noise_scale, p.noise_detail, p.noise_roughness)
    soap = thin_film_equivalent("soap_bubble", preset("soap_bubble"))
    assert soap["transmission"] == 1.0 and soap["base_color"] == (1.0, 1.0, 1.0)  # else it transmits nothing
    # The node's Upper Roughness: alpha = Roughness^2 = sqrt(2 / (4 e0 + 2)), the lobe the shaders render.
    assert kw["roughness"] == pytest.approx(math.sqrt(math.sqrt(2.0 / (4.0 * p.e0 + 2.0))))
    assert thin_film_equivalent("oil_slick", preset("oil_slick"))["metallic"] == 0.0
    mat = principled_thin_film("TF", **kw)
    bsdf = next(n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled")
    assert bsdf.inputs["Thin Film Thickness"].links[0].from_node.bl_idname == "ShaderNodeMapRange"
    assert bsdf.inputs["Thin Film IOR"].default_value == pytest.approx(kw["ior"])
    assert bsdf.inputs["Metallic"].default_value == 1.0
    assert bsdf.inputs["Roughness"].default_value == pytest.approx(kw["roughness"])
    with pytest.raises(ParameterError) as e:
        principled_thin_film("bad", -1.0, 1.3, (0.5, 0.5, 0.5), 0.0, 0.2)
    assert e.value.name == "thickness_nm"
