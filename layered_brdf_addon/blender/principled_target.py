"""A Principled BSDF material as a fitting target: the material on the reference sphere
under a few suns, rendered by Cycles, one :class:`~layered_brdf_addon.fit.targets.SphereView`
per sun (``layered-brdf fit --principled``, the panel's *Fit to Render...*).

Each image is a render of the reference scene (docs/reference-scene.md, built by
:func:`.scene.build_scene`): a unit sphere, the orthographic camera, one zero-angle sun, a
black world, direct light only, a 0.01 px pixel filter, a fixed seed, no denoiser, no
adaptive sampling.  Under a delta light every pixel is the material's closures evaluated
once at the pixel centre, so one sample gives the exact image (see :data:`DEFAULT_SAMPLES`).

:func:`principled_views_of` works inside an artist's file: the render happens in a scene of
its own, which is removed afterwards with every datablock it made; the file's own data is
left as it was (the material only lends itself to the sphere for the render).
"""
from __future__ import annotations

import math
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Sequence

import bpy
import numpy as np

from ..fit import structures
from ..fit.environment import Environment
from ..fit.targets import SphereView
from ..model.params import LayeredParams, ParameterError
from ..model.sphere import Sun
from .material import apply_layered_material
from .scene import SceneSpec, build_scene, camera_for, render_to_file, set_hdri_environment
from . import tempdirs

DEFAULT_SIZE = 96
# Samples per pixel.  Under a sun Cycles evaluates the Principled BSDF's closures with no
# random choice: one sample is the exact pixel, as for the layered material.  Measured on a
# soap film, a titanium film and a rough coloured dielectric at 96 px: the seed changes no
# pixel at one sample; 256 samples (which spread over the 0.01 px filter) differ from one by
# 4e-5 of the brightest pixel on average, up to 1% at a few pixels on the shadow's edge or
# the rim.
DEFAULT_SAMPLES = 1
# Under an HDRI each pixel is a Monte Carlo estimate: measured on the layered presets
# (titanium, oil, soap) at 96 px under forest.exr, 256 samples leave the numpy twin of the
# render (fit/environment.py) 0.46-0.74 mean CIEDE2000 away, most of it the render's noise.
ENVIRONMENT_SAMPLES = 256
SUN_STRENGTH = math.pi  # a white Lambertian sphere reads 1 where the sun meets it head-on
PRINCIPLED = "ShaderNodeBsdfPrincipled"
TARGET_SLOT = "Layered BRDF fit target"  # the Render Result slot the target renders go to
REFERENCE_WORLD = "RefWorld"  # the world build_scene reuses by name
# The kinds of datablock building and rendering the target scene creates (and removes again).
SCENE_DATA = ("scenes", "objects", "meshes", "cameras", "lights", "worlds", "images")
# What applying a layered material makes besides (its material, node groups, OSL texts; its tables are images).
LAYERED_DATA = SCENE_DATA + ("materials", "node_groups", "texts")


def sun_off_view(degrees: float, azimuth: float = 90.0, strength: float = SUN_STRENGTH) -> Sun:
    """A sun ``degrees`` away from the view direction (the camera looks along +y from -y),
    turned about the view by ``azimuth`` degrees from the +x side (90: straight up)."""
    a, b = math.radians(degrees), math.radians(azimuth)
    return Sun(direction=(math.sin(a) * math.cos(b), -math.cos(a), math.sin(a) * math.sin(b)),
               strength=strength)


# The highlight near the centre, half-way out to the side and towards the rim: the film is
# seen at angles of incidence of about 15, 30 and 40 degrees, where its colours differ.
DEFAULT_SUNS = (sun_off_view(30.0), sun_off_view(60.0, azimuth=20.0), sun_off_view(80.0, azimuth=140.0))


# ---------------------------------------------------------------------------
def principled_node(material):
    """The material's Principled BSDF node (the one feeding the output, else the first), or None."""
    tree = material.node_tree if isinstance(material, bpy.types.Material) else None
    if tree is None:
        return None
    nodes = [n for n in tree.nodes if n.bl_idname == PRINCIPLED]
    linked = [n for n in nodes if any(s.is_linked for s in n.outputs)]
    return (linked or nodes or [None])[0]


def principled_materials() -> list:
    """The file's materials holding a Principled BSDF, by name."""
    return sorted((m for m in bpy.data.materials if principled_node(m) is not None), key=lambda m: m.name)


def check_principled(material, name=None):
    """``material`` when it holds a Principled BSDF; else :class:`ParameterError` naming
    ``material`` (shown as ``name`` when given)."""
    shown = name if name is not None else getattr(material, "name", repr(material))
    if not isinstance(material, bpy.types.Material):
        raise ParameterError("material", shown, "a material holding a Principled BSDF")
    if principled_node(material) is None:
        raise ParameterError("material", shown, "a material holding a Principled BSDF node "
                             "(this one has " + ("no node tree" if material.node_tree is None else "none") + ")")
    return material


def uniform_film(material) -> bool:
    """Whether the material's Principled BSDF has a film of one thickness (its Thin Film
    Thickness set, not driven by a link) or none."""
    node = principled_node(material)
    sock = node.inputs.get("Thin Film Thickness") if node is not None else None
    return sock is None or not sock.is_linked


def surface_of(material) -> str | None:
    """What the material's Principled BSDF says its surface is (a metal, see-through, a dielectric:
    :func:`..fit.structures.surface_kind`), from its Metallic and Transmission Weight; None where
    either is driven by a link."""
    node = principled_node(material)
    values = []
    for name in ("Metallic", "Transmission Weight"):
        sock = node.inputs.get(name) if node is not None else None
        values.append(None if sock is None or sock.is_linked else float(sock.default_value))
    return structures.surface_kind(*values)


def start_for(params: LayeredParams, material) -> LayeredParams:
    """The start of a fit to ``material``: a film of one thickness is fitted pixel by pixel,
    so a noise pattern's start becomes a thickness by height (and the fit, told the film is
    uniform, ties its range to one thickness: :attr:`..fit.targets.SphereTarget.uniform_film`).
    A noise start would be matched through its colour statistics instead, at six times the cost
    per evaluation, for the same result (measured on a 200 nm titanium film from
    ``anodised_titanium``: 465 s against 149 s by height on a busy two-core machine; rendered,
    both within 0.7 mean CIEDE2000 of the target).  A film driven by a texture keeps the start's
    pattern."""
    if params.thickness_mode == "noise" and uniform_film(material):
        return params.replace(thickness_mode="height")
    return params


def check_render_options(size, samples) -> tuple[int, int]:
    """``size`` and ``samples`` as positive integers; ParameterError naming the one that is not."""
    for name, value, (lo, hi) in (("size", size, (8, 4096)), ("samples", samples, (1, 65536))):
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ParameterError(name, value, f"an integer in [{lo}, {hi}]")
    return size, samples


# ---------------------------------------------------------------------------
def _pointers(kind: str) -> set[int]:
    return {block.as_pointer() for block in getattr(bpy.data, kind)}


@contextmanager
def _temporary_data(kinds: Sequence[str] = SCENE_DATA):
    """Remove, after the block, every datablock of ``kinds`` (by default scenes, objects, meshes,
    cameras, lights, worlds and images) made inside it: what building and rendering the target
    scene created, nothing that was there."""
    before = {kind: _pointers(kind) for kind in kinds}
    try:
        yield
    finally:
        made = [block for kind in kinds for block in getattr(bpy.data, kind)
                if block.as_pointer() not in before[kind]]
        if made:
            bpy.data.batch_remove(made)


@contextmanager
def _reference_world_free():
    """:func:`.scene.build_scene` takes the world named ``RefWorld`` when there is one: the
    file's own is renamed for the block (and back), so the scene gets a new world and the
    file's stays as it was.  A linked one is shadowed by a new local world of that name."""
    held = [w for w in bpy.data.worlds if w.name == REFERENCE_WORLD and w.library is None]
    names = [(w, w.name) for w in held]
    for w in held:
        w.name = f".layered_brdf_held_{w.as_pointer()}"
    if bpy.data.worlds.get(REFERENCE_WORLD) is not None:  # a linked world of that name
        bpy.data.worlds.new(REFERENCE_WORLD)  # local: found first, and removed with the scene
    try:
        yield
    finally:
        for w in bpy.data.worlds:
            if w.name == REFERENCE_WORLD and w.library is None:
                w.name = ".layered_brdf_target_world"  # ours: frees the name for the file's world
        for w, name in names:
            w.name = name


@contextmanager
def _own_render_slot():
    """Render into a slot of the Render Result of its own (added once, then reused) and put the
    active slot back after: the artist's last render stays where it was."""
    result = next((i for i in bpy.data.images if i.type == "RENDER_RESULT"), None)
    if result is None:  # made by the render, and removed with the scene's other data
        yield
        return
    slots = result.render_slots
    index = slots.active_index
    slots.active = next((s for s in slots if s.name == TARGET_SLOT), None) or slots.new(name=TARGET_SLOT)
    try:
        yield
    finally:
        slots.active_index = index


def _reference_scene(material, size: int, samples: int, sun: Sun):
    """A new scene holding the reference sphere (``material`` on it), camera and ``sun``,
    writing a linear float EXR of the Combined pass."""
    scene = bpy.data.scenes.new("Layered BRDF fit target")
    spec = SceneSpec(camera=camera_for(1, size), sun=sun, samples=samples, threads=os.cpu_count() or 2)
    with _reference_world_free():
        [sphere] = build_scene(spec, scene)
    sphere.data.materials.append(material)
    s = scene.render.image_settings
    s.media_type = "IMAGE"
    s.file_format = "OPEN_EXR"
    s.color_mode = "RGB"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    return scene, spec


def read_float_image(path) -> np.ndarray:
    """The linear RGB pixels (H, W, 3), row 0 at the top, of a single-layer float image,
    read by Blender (no EXR module needed); the image datablock is removed again."""
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = image.size
        channels = image.channels
        pixels = np.empty(w * h * channels, dtype=np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    return pixels.reshape(h, w, channels)[::-1, :, :3].astype(np.float64)


def _render_view(scene, spec, folder: Path, k: int, environment: Environment | None = None) -> SphereView:
    path = folder / f"target{k}.exr"
    render_to_file(path, scene)
    if environment is not None:
        return SphereView(read_float_image(path), spec.camera, None, spec.centers, environment=environment)
    return SphereView(read_float_image(path), spec.camera, spec.sun, spec.centers)


def environment_of(image_path, strength: float = 1.0) -> Environment:
    """The HDRI at ``image_path`` as the fit's :class:`~..fit.environment.Environment` (read
    by Blender: bottom row first, as its Environment Texture reads it)."""
    path = Path(image_path)
    if not path.is_file():
        raise ParameterError("hdri", str(image_path), "the path of an existing equirectangular image")
    try:
        pixels = read_float_image(path)
    except RuntimeError:
        raise ParameterError("hdri", str(image_path), "an image Blender can read") from None
    return Environment(pixels[::-1], strength, path.name)


def _check_views(size, samples, suns, hdris, hdri_samples) -> tuple:
    size, samples = check_render_options(size, samples)
    if isinstance(hdri_samples, bool) or not isinstance(hdri_samples, int) or not 1 <= hdri_samples <= 65536:
        raise ParameterError("hdri_samples", hdri_samples, "an integer in [1, 65536]")
    suns = tuple(suns)
    if not all(isinstance(s, Sun) for s in suns) or not (suns or hdris):
        raise ParameterError("suns", suns, "model.sphere.Sun values (one or more, unless HDRIs light the views)")
    return size, samples, suns


def _render_views(material, size, samples, suns, environments, hdri_samples, folder) -> list[SphereView]:
    """``material`` on the reference sphere, one render per sun, then one per HDRI (in ``folder``)."""
    views = []
    for k, sun in enumerate(suns):
        scene, spec = _reference_scene(material, size, samples, sun)
        views.append(_render_view(scene, spec, folder, k))
    for k, (path, environment) in enumerate(environments, start=len(suns)):
        scene, spec = _reference_scene(material, size, hdri_samples, Sun(strength=0.0))
        set_hdri_environment(path, environment.strength, scene)
        views.append(_render_view(scene, spec, folder, k, environment))
    return views


def principled_views_of(material, *, size: int = DEFAULT_SIZE, samples: int = DEFAULT_SAMPLES,
                        suns: Sequence[Sun] = DEFAULT_SUNS, hdris: Sequence = (),
                        hdri_samples: int = ENVIRONMENT_SAMPLES) -> list[SphereView]:
    """``material`` (a Principled BSDF material of this session) on the reference sphere, one
    Cycles render per sun of ``suns``: ``size`` x ``size`` pixels, ``samples`` per pixel; then
    one per HDRI of ``hdris`` (paths of equirectangular images, the world's only light),
    ``hdri_samples`` per pixel.

    The renders happen in a scene of their own, removed afterwards with everything made for
    it (the active scene stays active, the artist's last render stays in its slot of the
    Render Result); the EXRs go to a temporary folder of the add-on's, removed too.  A value
    that is not a material holding a Principled BSDF is refused (:class:`ParameterError`
    naming ``material``), as are a bad ``size`` or ``samples``, before anything is made.
    """
    check_principled(material)
    size, samples, suns = _check_views(size, samples, suns, hdris, hdri_samples)
    environments = [(Path(h), environment_of(h)) for h in hdris]
    with _temporary_data(), tempdirs.owned_tempdir("preview") as folder, _own_render_slot():
        return _render_views(material, size, samples, suns, environments, hdri_samples, folder)


def layered_views(params: LayeredParams, *, size: int = DEFAULT_SIZE, samples: int = DEFAULT_SAMPLES,
                  suns: Sequence[Sun] = DEFAULT_SUNS, hdris: Sequence = (),
                  hdri_samples: int = ENVIRONMENT_SAMPLES, backend: str = "nodes") -> list[SphereView]:
    """The layered material of ``params`` rendered as :func:`principled_views_of` renders a
    Principled material (same scenes, suns, HDRIs, pixels and samples): what a fit to those
    views is checked against (``fit --principled ... --verify``).  The material, its node groups,
    texts and tables are made for the renders and removed with the scenes afterwards."""
    size, samples, suns = _check_views(size, samples, suns, hdris, hdri_samples)
    environments = [(Path(h), environment_of(h)) for h in hdris]
    with _temporary_data(LAYERED_DATA), tempdirs.owned_tempdir("preview") as folder, _own_render_slot():
        material = bpy.data.materials.new("Layered BRDF fit check")
        apply_layered_material(material, params, backend=backend)
        return _render_views(material, size, samples, suns, environments, hdri_samples, folder)


def open_blend(blend_path) -> None:
    """Open ``blend_path`` in this session (what a command-line run does); ParameterError
    naming ``blend`` when Blender cannot."""
    path = Path(blend_path)
    if not path.is_file():
        raise ParameterError("blend", str(blend_path), "the path of an existing .blend file")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    except RuntimeError as e:
        reason = str(e).strip().splitlines()[-1] if str(e).strip() else "Blender could not open it"
        raise ParameterError("blend", str(blend_path), f"a .blend file Blender can open ({reason})") from None


def principled_views(blend_path, material_name: str, *, size: int = DEFAULT_SIZE, samples: int = DEFAULT_SAMPLES,
                     suns: Sequence[Sun] = DEFAULT_SUNS, hdris: Sequence = (),
                     hdri_samples: int = ENVIRONMENT_SAMPLES) -> list[SphereView]:
    """Open ``blend_path`` (replacing this session's file) and render its material
    ``material_name`` as :func:`principled_views_of` does.  A material the file does not hold,
    or one without a Principled BSDF, is a :class:`ParameterError` naming ``material``."""
    check_render_options(size, samples)
    open_blend(blend_path)
    material = bpy.data.materials.get(material_name) if isinstance(material_name, str) else None
    if material is None:
        names = ", ".join(m.name for m in principled_materials()) or "none"
        raise ParameterError("material", material_name, f"the name of a material in {Path(blend_path).name} "
                             f"holding a Principled BSDF ({names[:400]})")
    check_principled(material, material_name)
    return principled_views_of(material, size=size, samples=samples, suns=suns, hdris=hdris,
                               hdri_samples=hdri_samples)
