"""Shared set-up of the render tests: one scene per module, several spheres per image."""
from __future__ import annotations

from dataclasses import dataclass

from layered_brdf_addon.model.sphere import OrthoCamera, Sun

from constants import SUN_40


@dataclass
class RenderedRow:
    params: list
    camera: OrthoCamera
    sun: Sun
    centers: tuple
    passes: object
    backend: str
    materials: list


def render_row(params_list, backend="nodes", sun=SUN_40, height=64, samples=1, plans=None):
    """Reset Blender, put one sphere per parameter set in a row, render once."""
    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes,
                                                  render_passes_osl, reset_blender, row_of_spheres)
    from layered_brdf_addon.blender.material import apply_layered_material

    reset_blender()
    n = len(params_list)
    cam = camera_for(n, height)
    centers = row_of_spheres(n)
    spheres = build_scene(SceneSpec(camera=cam, sun=sun, centers=centers, samples=samples,
                                        osl=(backend == "osl")))
    mats = []
    for k, (obj, p) in enumerate(zip(spheres, params_list)):
        plan = plans[k] if plans else None
        mats.append(apply_layered_material(obj, p, backend, plan=plan, name=f"Layered{k}"))
    if backend == "osl":
        passes = render_passes_osl()
    else:
        passes = render_passes()
    return RenderedRow(list(params_list), cam, sun, centers, passes, backend, mats)


def render_furnace(params_list, backend="nodes", height=32, samples=64, before=None):
    """:func:`render_row` under a uniform white world of radiance 1 (a white furnace), with the bounces a
    clear film needs (the far wall seen through it); ``before(row)`` edits the materials first."""
    import bpy

    from layered_brdf_addon.blender.scene import render_passes, render_passes_osl, set_uniform_environment

    row = render_row(params_list, backend=backend, height=height, samples=1)
    if before is not None:
        before(row)
    scene = bpy.context.scene
    scene.cycles.samples = samples
    scene.cycles.max_bounces = 8
    scene.cycles.transparent_max_bounces = 8
    set_uniform_environment(1.0)
    row.passes = render_passes_osl() if backend == "osl" else render_passes()
    return row


def ring_means(row, names, rings) -> dict:
    """The mean colour of each sphere of ``row`` (named in order by ``names``) over each ring of view cosines
    (``rings``: name -> (above, at most)): ``{(name, ring): RGB}``."""
    from layered_brdf_addon.model.geometry import dot
    from layered_brdf_addon.model.sphere import sphere_geometry

    geo = sphere_geometry(row.camera, row.centers)
    mu = dot(geo.n0, geo.view)
    out = {}
    for k, name in enumerate(names):
        for ring, (lo, hi) in rings.items():
            sel = geo.mask & (geo.sphere == k) & (mu > lo) & (mu <= hi)
            out[(name, ring)] = row.passes.beauty[sel][:, :3].mean(0)
    return out
