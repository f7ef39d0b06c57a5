"""Principled BSDF materials as fitting targets: rendered on the reference sphere in a scene of
their own (the artist's file left as it was), refused by name when they are not Principled,
and converted into layered materials by a fit.

The conversions are measured on Blender's Principled BSDF with Thin Film (a soap film, an
oil film on a dark base, anodised titanium), each fitted from the preset it resembles.  The
fit matches the closure form; the fitted material is then rendered by Cycles and compared
with the Principled render over every lit pixel of the sphere.
"""
from __future__ import annotations

import time

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender import fit_operator, lookdev
from layered_brdf_addon.blender.principled_target import (DEFAULT_SUNS, REFERENCE_WORLD, layered_views,
                                                          principled_materials, principled_views, principled_views_of,
                                                          start_for, uniform_film)
from layered_brdf_addon.blender.scene import SceneSpec, build_scene, render_passes, reset_blender
from layered_brdf_addon.blender.material import apply_layered_material
from layered_brdf_addon.fit import colour_space
from layered_brdf_addon.fit.targets import SphereTarget
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.sphere import sphere_geometry

SIZE = 64


def soap_film(name="Soap film"):
    """Blender's soap bubble: a clear base (IOR 1, transmission) under a 500 nm film of water."""
    return lookdev.principled_soap_film(name)


def saved(tmp_path, *materials):
    """The file saved with ``materials`` in it (kept by a fake user: they have no other)."""
    for mat in materials:
        mat.use_fake_user = True
    path = tmp_path / "materials.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def datablocks() -> dict:
    """Every datablock of the file by kind: (name, library, address)."""
    out = {}
    for prop in bpy.data.bl_rna.properties:
        if prop.type == "COLLECTION":
            blocks = [b for b in getattr(bpy.data, prop.identifier) if isinstance(b, bpy.types.ID)]
            out[prop.identifier] = sorted((b.name, b.library.filepath if b.library else "", b.as_pointer())
                                          for b in blocks)
    return out


def artists_file():
    """A file with a scene of its own, a rendered image in slot 3 of the Render Result and a
    world named as the reference scene's, in colours of its own."""
    scene = bpy.context.scene
    scene.name = "Artist's scene"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "CYCLES"
    scene.render.resolution_x = scene.render.resolution_y = 8
    scene.cycles.samples = 1
    bpy.ops.render.render()
    result = bpy.data.images["Render Result"]
    result.render_slots.active_index = 2
    world = bpy.data.worlds.new(REFERENCE_WORLD)
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.2, 0.3, 0.4, 1.0)
    background.inputs["Strength"].default_value = 0.5
    scene.world = world
    return scene, world


@pytest.mark.slow
def test_a_thin_film_renders_on_the_reference_sphere_and_the_file_stays_as_it_was():
    scene, world = artists_file()
    mat = soap_film()
    nodes = sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes)
    before, users = datablocks(), mat.users
    views = principled_views_of(mat, size=SIZE)
    assert [v.sun for v in views] == list(DEFAULT_SUNS)
    for view in views:
        assert view.image.shape == (SIZE, SIZE, 3) and np.all(np.isfinite(view.image))
        geo = sphere_geometry(view.camera, view.centers)
        lit = geo.mask & (geo.n0 @ view.sun.l > 0.1)
        assert np.all(view.image[lit].max(axis=-1) > 0.0)  # the film reflects wherever the sun reaches
        assert np.all(view.image[~geo.mask] == 0.0)  # a black world, direct light only
        rgb = view.image[lit]
        spread = (rgb.max(axis=-1) - rgb.min(axis=-1)) / np.maximum(rgb.max(axis=-1), 1e-9)
        assert spread.max() > 0.2  # interference colours, not a grey highlight
    assert datablocks() == before
    assert bpy.context.scene == scene and scene.world == world and world.name == REFERENCE_WORLD
    background = world.node_tree.nodes["Background"]
    assert tuple(background.inputs["Color"].default_value) == pytest.approx((0.2, 0.3, 0.4, 1.0))
    assert background.inputs["Strength"].default_value == pytest.approx(0.5)
    assert bpy.data.images["Render Result"].render_slots.active_index == 2
    assert mat.users == users and sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes) == nodes


@pytest.mark.slow
def test_a_fitted_material_is_rendered_in_the_target_s_scenes_and_the_file_stays_as_it_was():
    """What ``fit --principled --verify`` renders: the layered material in the scenes a Principled target
    is rendered in (a sun, an HDRI).  Cycles' render agrees with the closure form numpy computes for the
    same views (measured 0.0004 under the sun, 0.68 under forest.exr at 64 samples: the render's noise),
    and the material, node groups and scenes made for it are gone afterwards."""
    scene, world = artists_file()
    before = datablocks()
    params = preset("oil_slick").replace(thickness_mode="height")
    views = layered_views(params, size=48, suns=DEFAULT_SUNS[:1], hdris=[lookdev.hdri_path("forest")],
                          hdri_samples=64)
    assert datablocks() == before and bpy.context.scene == scene and scene.world == world
    assert [v.sun for v in views] == [DEFAULT_SUNS[0], None] and views[1].environment.name == "forest.exr"
    target = SphereTarget(views)
    sun, hdri = (float(np.mean(d)) for d in target.images_delta_e([target.render(params, k) for k in range(2)]))
    assert sun < 0.05 and hdri < 1.5, (sun, hdri)


@pytest.mark.slow
def test_a_blend_file_material_is_rendered_by_name(tmp_path):
    path = saved(tmp_path, soap_film("Bubble"))
    reset_blender()
    views = principled_views(path, "Bubble", size=32, suns=DEFAULT_SUNS[:1])
    assert len(views) == 1 and views[0].image.shape == (32, 32, 3) and views[0].image.max() > 0.0


def test_a_material_that_is_not_principled_is_refused_by_name(tmp_path):
    glow = bpy.data.materials.new("Glow")
    glow.node_tree.nodes.clear()
    glow.node_tree.nodes.new("ShaderNodeEmission")
    bubble = soap_film("Bubble")
    for value in (glow, "Bubble", None):
        with pytest.raises(ParameterError) as e:
            principled_views_of(value)
        assert e.value.name == "material"
    with pytest.raises(ParameterError, match="Principled BSDF node"):
        principled_views_of(glow)
    with pytest.raises(ParameterError) as e:
        principled_views_of(bubble, size=0)
    assert e.value.name == "size"
    path = saved(tmp_path, glow, bubble)
    for name in ("Missing", "Glow"):
        with pytest.raises(ParameterError, match="Principled") as e:
            principled_views(path, name)
        assert e.value.name == "material" and e.value.value == name
    with pytest.raises(ParameterError) as e:
        principled_views(tmp_path / "nowhere.blend", "Bubble")
    assert e.value.name == "blend"
    assert [m.name for m in principled_materials()] == ["Bubble"]


# --- conversions ------------------------------------------------------------------------------
def titanium_film():
    """Anodised titanium: a metal of titanium's colour under 200 nm of a TiO2-like film."""
    return lookdev.principled_thin_film("Titanium", 200.0, 2.4, (0.542, 0.497, 0.449), 1.0, 0.2)


def oil_film():
    """An oil film (350 nm, index 1.47) on a dark, glossy base."""
    return lookdev.principled_thin_film("Oil", 350.0, 1.47, (0.01, 0.01, 0.012), 0.0, 0.15)


# name: (the Principled material, the preset the fit starts from, the mean CIEDE2000 the fit
# reaches, that of the fitted material rendered by Cycles), the bounds measured with a margin.
# Titanium: the preset's film as IOR and Dispersion starts the fit 0.2% away from the measured
# indices it started from before, and the fit lands in another interference order (171 nm, not
# 300 nm): fitted 1.51 (was 1.66), rendered 0.84-1.11 (was 0.58-0.68).
CONVERSIONS = {
    "soap": (soap_film, "soap_bubble", 3.0, 3.0),
    "titanium": (titanium_film, "anodised_titanium", 2.0, 1.3),
    "oil": (oil_film, "oil_slick", 1.0, 1.0),
}


def rendered_delta_e(params, views, whites) -> list[float]:
    """Per view: the mean CIEDE2000 between the target and the layered material of ``params``
    rendered by Cycles in the reference scene, over the sphere's lit pixels, on the view's white."""
    out = []
    for view, white_y in zip(views, whites, strict=True):
        reset_blender()
        [sphere] = build_scene(SceneSpec(camera=view.camera, sun=view.sun, centers=view.centers))
        apply_layered_material(sphere, params)
        beauty = render_passes().beauty
        geo = sphere_geometry(view.camera, view.centers)
        lit = geo.mask & (geo.n0 @ view.sun.l > 0.0)
        lab = [colour_space.lab(np.maximum(img[lit], 0.0), white_y) for img in (view.image, beauty)]
        out.append(float(np.mean(colour_space.delta_e_2000(*lab))))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CONVERSIONS))
def test_a_principled_thin_film_converts_to_a_layered_material(name):
    make, start, fitted_bound, rendered_bound = CONVERSIONS[name]
    material = make()
    views = principled_views_of(material, size=96)
    t0, cpu0 = time.perf_counter(), time.process_time()
    result = fit_operator.run_fit(views, start_for(preset(start), material), uniform_film=uniform_film(material))
    seconds, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    assert result.params.d_max == result.params.d_min  # Principled's film has one thickness: so has the fit's
    rendered = rendered_delta_e(result.params, views, SphereTarget(views).view_whites)
    print(f"{name} from {start}: fitted mean CIEDE2000 {result.mean_delta_e:.2f}, rendered "
          f"{', '.join(f'{d:.2f}' for d in rendered)}; {result.evaluations} evaluations, {seconds:.0f} s "
          f"({cpu:.0f} s CPU)")
    assert result.mean_delta_e <= fitted_bound
    assert max(rendered) <= rendered_bound


def test_a_film_of_one_thickness_is_fitted_by_height_a_textured_one_keeps_its_pattern():
    uniform = soap_film()
    textured = lookdev.principled_thin_film("Patchy", 300.0, 1.4, (0.1, 0.1, 0.1), 0.0, 0.3,
                                            thickness_noise=(100.0, 500.0, 4.0, 2.0, 0.5))
    assert uniform_film(uniform) and not uniform_film(textured)
    noise = preset("oil_slick")
    assert noise.thickness_mode == "noise"
    assert start_for(noise, uniform) == noise.replace(thickness_mode="height")
    assert start_for(noise, textured) == noise
    height = preset("soap_bubble")
    assert start_for(height, uniform) == height
