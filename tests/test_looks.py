"""The artist presets look like their names: dominant hues, saturation, brightness and a
mirror-like reflection where claimed, on spheres rendered under one of Blender's bundled
HDRIs (layered_brdf_reference/look_bounds.py holds the bounds); the looks they replaced fail the same checks."""
from __future__ import annotations

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                              row_of_spheres)
from layered_brdf_addon.blender.lookdev import hdri_path
from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_reference.look_bounds import LOOKS, equirect_lookup, failures, measure, mirror_directions
from layered_brdf_addon.model.base_layers import base_node, phong_to_roughness
from layered_brdf_addon.model.presets import ARTIST_PRESETS, STACK_PRESETS, preset
from layered_brdf_addon.model.sphere import Sun, sphere_geometry

from blender_helpers import add_sphere

SIZE = 64  # pixels per sphere
SAMPLES = 8
# Each look must hold under each of these bundled HDRIs (sunset and city are in the docs' sheet).
HDRIS = ("forest", "courtyard", "interior")

# The looks the presets had before they were tuned under an HDRI: titanium read as salmon
# copper, old metal as white plaster, the beetle as bronze, the glaze as matte clay.
REPLACED = {
    "anodised_titanium": dict(optics="paper", d_min=40.0, d_max=60.0, noise_scale=1.5, e0=250.0, e1=300.0, kd=0.6,
                              base_layer="none", base_r=0.45, base_g=0.43, base_b=0.4),
    "old_metal": dict(optics="paper", r1_r=1.5, r1_g=1.5, r1_b=1.5, d_min=1.0, d_max=30.0, noise_scale=8.0, noise_detail=2.0,
                      noise_roughness=0.5, e0=60.0, e1=60.0, ks=0.5, kd=1.0, base_layer="none",
                      base_r=0.55, base_g=0.5, base_b=0.45),
    "beetle_shell": dict(optics="paper", r1_r=1.56, r1_g=1.6, r1_b=1.7, d_min=220.0, d_max=260.0, normal_mode="tilted", tilt=8.0,
                         e0=300.0, e1=300.0, kd=0.4, base_r=0.02, base_g=0.08, base_b=0.03),
    "glazed_clay": dict(optics="paper", d_min=67.0, d_max=73.0, noise_scale=4.0, e0=120.0, e1=120.0, ks=0.6, kd=1.0,
                        base_r=0.75, base_g=0.42, base_b=0.28),
}
ROWS = [(name, preset(name)) for name in ARTIST_PRESETS] + \
       [(f"replaced {name}", preset(name).replace(**old)) for name, old in REPLACED.items()]


@pytest.fixture(scope="module")
def looks():
    return {hdri: measure_rows(hdri)[0] for hdri in HDRIS}


def measure_rows(hdri: str = HDRIS[0], rows=None) -> tuple[dict, np.ndarray]:
    """Every row (of :data:`ROWS`, or ``rows``: (name, parameters), each name a look's) on a sphere under the
    HDRI, no sun: the statistics of each sphere's pixels, and the render (linear)."""
    rows = ROWS if rows is None else rows
    reset_blender()
    n = len(rows)
    cam = camera_for(n, SIZE)
    centers = row_of_spheres(n)
    spheres = build_scene(SceneSpec(camera=cam, sun=Sun(strength=0.0), centers=centers, samples=SAMPLES))
    scene = bpy.context.scene
    scene.cycles.max_bounces = 4  # a clear film shows what lies behind it
    tree = scene.world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(hdri_path(hdri)))
    background = tree.nodes["Background"]
    background.inputs["Strength"].default_value = 1.0
    tree.links.new(env.outputs["Color"], background.inputs["Color"])
    for k, (obj, (_, params)) in enumerate(zip(spheres, rows)):
        apply_layered_material(obj, params, "nodes", name=f"Look{k}")
    beauty = render_passes().beauty[..., :3]
    geo = sphere_geometry(cam, centers)
    w, h = env.image.size
    pixels = np.empty(w * h * 4, dtype=np.float32)
    env.image.pixels.foreach_get(pixels)
    mirrored = equirect_lookup(pixels.reshape(h, w, 4), mirror_directions(geo.n0, geo.view))
    stats = {}
    for k, (name, _) in enumerate(rows):
        look = LOOKS[name.removeprefix("replaced ")]
        stats[name] = measure(beauty, mirrored, geo.mask & (geo.sphere == k), look)
    return stats, beauty


def test_every_artist_preset_has_a_look():
    assert set(LOOKS) == set(ARTIST_PRESETS) | set(STACK_PRESETS)


@pytest.mark.keeps_scene
@pytest.mark.parametrize("hdri", HDRIS)
@pytest.mark.parametrize("name", list(ARTIST_PRESETS))
def test_preset_looks_like_its_name(looks, name, hdri):
    assert failures(name, looks[hdri][name]) == [], f"{name} should read as {LOOKS[name].description} " \
                                                      f"under {hdri}"


@pytest.mark.keeps_scene
@pytest.mark.parametrize("name", list(REPLACED))
def test_the_replaced_look_fails_the_check(looks, name):
    assert failures(name, looks[HDRIS[0]][f"replaced {name}"]) != []


def test_a_metal_base_follows_the_base_colour_and_the_upper_roughness():
    """With the paper's optics (the lower boundary a mirror) the metal is a node of its own."""
    paper = preset("anodised_titanium").replace(optics="paper")
    obj = add_sphere()
    mat = apply_layered_material(obj, paper, "nodes")
    node = shader_node(mat)
    (link,) = node.inputs["Base Shader"].links
    base = link.from_node
    assert base.bl_idname == base_node(paper).node_type == "ShaderNodeBsdfMetallic"
    assert tuple(base.inputs["Base Color"].default_value)[:3] == pytest.approx(paper.base_color)
    params = paper.replace(e0=50.0, base_r=0.7)
    apply_layered_material(obj, params, "nodes")
    assert node.inputs["Base Shader"].links[0].from_node == base  # updated in place, not rebuilt
    assert base.inputs["Roughness"].default_value == pytest.approx(phong_to_roughness(50.0))
    assert base.inputs["Base Color"].default_value[0] == pytest.approx(0.7)
    # Another base: the metal goes (it is the add-on's), the artist's nodes stay.
    mine = mat.node_tree.nodes.new("ShaderNodeBsdfMetallic")
    apply_layered_material(obj, params.replace(base_layer="none"), "nodes")
    node = shader_node(mat)
    assert not node.inputs["Base Shader"].is_linked
    assert [n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfMetallic"] == [mine]


def test_with_physical_optics_the_metal_is_the_lower_boundary_not_a_second_layer():
    """Physical optics: the titanium under the oxide is the film's lower medium (its n and k); no
    metal node is added under it, and the one the paper's optics added goes."""
    obj = add_sphere()
    mat = apply_layered_material(obj, preset("anodised_titanium").replace(optics="paper"), "nodes")
    assert shader_node(mat).inputs["Base Shader"].is_linked
    mat = apply_layered_material(obj, preset("anodised_titanium"), "nodes")
    assert base_node(preset("anodised_titanium")) is None
    assert not shader_node(mat).inputs["Base Shader"].is_linked
    assert not [n for n in mat.node_tree.nodes if n.bl_idname == "ShaderNodeBsdfMetallic"]


def test_phong_to_roughness_is_sharper_for_higher_exponents():
    r = [phong_to_roughness(e) for e in (0.0, 10.0, 100.0, 1000.0)]
    assert r == sorted(r, reverse=True) and r[0] == pytest.approx(1.0) and 0.0 < r[-1] < 0.2


if __name__ == "__main__":  # the measured table of docs/looks.md
    import sys

    print("| preset | HDRI | looks like | share in its hues | median saturation | hue sectors | mirror correlation "
          "| median luminance | holds |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for hdri in sys.argv[1:] or HDRIS:
        rows, _ = measure_rows(hdri)
        for name, st in rows.items():
            look = LOOKS[name.removeprefix("replaced ")]
            share = f"{st.hue_share:.0%}" if look.hues else "-"
            fails = failures(name.removeprefix("replaced "), st)
            print(f"| {name} | {hdri} | {look.description} | {share} | {st.saturation:.2f} | {st.sectors} "
                  f"| {st.reflects:.2f} | {st.luminance:.3f} | {'yes' if not fails else 'no: ' + '; '.join(fails)} |")
