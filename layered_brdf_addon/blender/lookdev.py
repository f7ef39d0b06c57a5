"""The look-development scene: a shader ball under one of Blender's bundled HDRIs.

:func:`build_lookdev_scene` makes a new scene (the file's other data is left alone, so
it can run inside an artist's file) with a procedurally built shader ball -- a
smooth-shaded sphere with a carved, tilted groove on a small pedestal, so a material
shows curvature, grazing angles and a concave edge -- a camera framing it, a world with
a bundled HDRI and a soft key sun, Cycles on the CPU with a fixed seed, no denoiser, no
adaptive sampling and two fixed threads.  :func:`remove_scene` removes the scene and
every datablock :func:`build_lookdev_scene` created, nothing else.
:func:`principled_thin_film` makes Blender's nearest built-in equivalent of a thin
film (Principled BSDF + Thin Film, Cycles only) and :func:`thin_film_equivalent` maps
a preset to its values, for side-by-side comparisons.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import bpy  # first: it makes mathutils importable
import numpy as np
from mathutils import Euler, Vector

from ..model.base_layers import phong_to_roughness
from ..model.params import LayeredParams, ParameterError
from .scene import deterministic_cycles, ensure_passes, hdri_world, mesh_from_arrays

HDRI_PREFERENCE = ("forest.exr", "courtyard.exr", "studio.exr")
HDRI_STRENGTH = 1.0
SUN_STRENGTH = 2.5  # W/m^2: a key about as bright as the HDRI's sky
SUN_ANGLE_DEG = 12.0  # a soft sun: its penumbra and highlights are wide
SUN_ROTATION_DEG = (55.0, 0.0, 35.0)
SEED = 0
THREADS = 2
ENGINES = ("CYCLES", "BLENDER_EEVEE")  # "BLENDER_EEVEE_NEXT" is taken as EEVEE too
SIZE_RANGE = (8, 4096)
SAMPLES_RANGE = (1, 1_000_000)

# The shader ball (object units): a unit sphere with a groove around an axis tilted
# towards the camera, on a short cylinder.
BALL_SEGMENTS = 192
BALL_RINGS = 128
GROOVE_LATITUDE_DEG = 25.0  # the groove's angle above the ball's equator
GROOVE_HALF_WIDTH_DEG = 7.0
GROOVE_DEPTH = 0.07
BALL_TILT_DEG = (40.0, 0.0, 25.0)  # the groove axis leans towards the camera and sideways
PEDESTAL_RADIUS = 0.45
PEDESTAL_HEIGHT = 0.3
PEDESTAL_COLOR = (0.05, 0.05, 0.055, 1.0)
CAMERA_LOCATION = (0.0, -5.2, 1.25)
CAMERA_TARGET = (0.0, 0.0, -0.12)
CAMERA_LENS_MM = 60.0

# the datablocks a look-dev scene owns, by scene (pointer) -> [(collection, datablock), ...]
_CREATED: dict[int, list[tuple[str, Any]]] = {}


# ---------------------------------------------------------------------------
# bundled HDRIs
def hdri_folder() -> Path:
    """Blender's bundled studio-light HDRIs."""
    return Path(bpy.utils.system_resource("DATAFILES")) / "studiolights" / "world"


def hdri_names() -> list[str]:
    """The names of the bundled HDRIs (``forest.exr``, ...)."""
    folder = hdri_folder()
    return sorted(p.name for p in folder.glob("*.exr")) if folder.is_dir() else []


def hdri_path(name: str | None = None) -> Path:
    """A bundled HDRI: ``name`` (``forest`` or ``forest.exr``), or by default the first of
    forest, courtyard and studio that this Blender ships (else the first one it ships).
    Raises :class:`ParameterError` naming ``hdri`` and the names available."""
    names = hdri_names()
    if name is None:
        for candidate in HDRI_PREFERENCE:
            if candidate in names:
                return hdri_folder() / candidate
        if names:
            return hdri_folder() / names[0]
        raise ParameterError("hdri", None, f"one of Blender's bundled HDRIs (none found in {hdri_folder()})")
    file = name if str(name).lower().endswith(".exr") else f"{name}.exr"
    if not isinstance(name, str) or file not in names:
        raise ParameterError("hdri", name, "one of Blender's bundled HDRIs: "
                             + (", ".join(n[:-4] for n in names) or f"none found in {hdri_folder()}"))
    return hdri_folder() / file


def eevee_engine() -> str | None:
    """EEVEE's engine id in this Blender (BLENDER_EEVEE_NEXT in 4.2-4.x, BLENDER_EEVEE again since)."""
    ids = {e.identifier for e in bpy.types.RenderSettings.bl_rna.properties["engine"].enum_items}
    return next((e for e in ("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT") if e in ids), None)


def _engine_id(engine: str) -> str:
    if engine == "CYCLES":
        return engine
    if engine in ("BLENDER_EEVEE", "BLENDER_EEVEE_NEXT", "EEVEE"):
        found = eevee_engine()
        if found is not None:
            return found
    raise ParameterError("engine", engine, "one of " + ", ".join(ENGINES))


def _int_in(name: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ParameterError(name, value, f"an integer in [{lo}, {hi}]")
    return int(value)


# ---------------------------------------------------------------------------
# the shader ball
def ball_profile(theta: np.ndarray) -> np.ndarray:
    """Radius of the ball at polar angle ``theta`` (radians from its axis): 1 with a
    smooth (raised-cosine) groove of depth GROOVE_DEPTH at GROOVE_LATITUDE_DEG."""
    centre = math.radians(90.0 - GROOVE_LATITUDE_DEG)
    half = math.radians(GROOVE_HALF_WIDTH_DEG)
    u = np.clip((theta - centre) / half, -1.0, 1.0)
    return 1.0 - GROOVE_DEPTH * 0.5 * (1.0 + np.cos(np.pi * u))


def _ball_arrays(segments: int = BALL_SEGMENTS, rings: int = BALL_RINGS):
    """Vertices and faces of the grooved ball: a UV sphere whose rings are denser in the groove."""
    # Ring angles: uniform, plus extra rings across the groove so its curvature is smooth.
    base = np.pi * np.arange(1, rings) / rings
    centre = math.radians(90.0 - GROOVE_LATITUDE_DEG)
    half = math.radians(GROOVE_HALF_WIDTH_DEG)
    extra = centre + half * np.linspace(-1.2, 1.2, 25)
    theta = np.unique(np.round(np.concatenate([base, extra]), 9))
    theta = theta[(theta > 0) & (theta < np.pi)]
    r = ball_profile(theta)
    phi = 2.0 * np.pi * np.arange(segments) / segments
    st, ct = (r * np.sin(theta))[:, None], (r * np.cos(theta))[:, None]
    ring_verts = np.stack([st * np.cos(phi), st * np.sin(phi), ct * np.ones_like(phi)], axis=-1).reshape(-1, 3)
    verts = np.concatenate([[[0.0, 0.0, 1.0]], ring_verts, [[0.0, 0.0, -1.0]]])
    n_rings = len(theta)
    top, bottom = 0, len(verts) - 1
    idx = 1 + np.arange(n_rings * segments).reshape(n_rings, segments)
    nxt = np.roll(idx, -1, axis=1)
    quads = np.stack([idx[:-1], idx[1:], nxt[1:], nxt[:-1]], axis=-1).reshape(-1, 4)
    cap_top = np.stack([np.full(segments, top), idx[0], nxt[0]], axis=-1)
    cap_bottom = np.stack([idx[-1], np.full(segments, bottom), nxt[-1]], axis=-1)
    return verts, [cap_top, quads, cap_bottom]


def _cylinder_arrays(radius: float, z0: float, z1: float, segments: int = 96):
    """A closed cylinder: side quads and two n-gon caps."""
    phi = 2.0 * np.pi * np.arange(segments) / segments
    ring = np.stack([radius * np.cos(phi), radius * np.sin(phi)], axis=-1)
    verts = np.concatenate([np.c_[ring, np.full(segments, z0)], np.c_[ring, np.full(segments, z1)]])
    lo, hi = np.arange(segments), segments + np.arange(segments)
    side = np.stack([lo, np.roll(lo, -1), np.roll(hi, -1), hi], axis=-1)
    return verts, [side, lo[::-1][None, :], hi[None, :]]


# ---------------------------------------------------------------------------
def _track(scene, collection: str, datablock):
    _CREATED.setdefault(scene.as_pointer(), []).append((collection, datablock))
    return datablock


def _view_transform(scene, view_transform: str) -> None:
    vs = scene.view_settings
    try:
        vs.view_transform = view_transform
    except TypeError as e:  # Blender lists the valid names in its message
        text = str(e)
        names = text[text.find("("):].strip() if "(" in text else "the names of Blender's view transforms"
        raise ParameterError("view_transform", view_transform, f"one of {names}") from None
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0


def build_lookdev_scene(size: int = 256, samples: int = 16, engine: str = "CYCLES", hdri: str | None = None,
                        view_transform: str = "AgX"):
    """A new look-development scene; returns ``(scene, ball)``, the ball's material slot empty.

    ``size`` x ``size`` pixels, ``samples`` per pixel, ``engine`` CYCLES (CPU, seed 0,
    no denoiser, no adaptive sampling, two fixed threads) or BLENDER_EEVEE; ``hdri`` a
    bundled HDRI (:func:`hdri_path`); the scene's view transform ``view_transform``
    (look None, exposure 0).  Nothing else in the file changes; :func:`remove_scene`
    takes it all away again.  Bad values raise :class:`ParameterError` before anything
    is created.
    """
    size = _int_in("size", size, *SIZE_RANGE)
    samples = _int_in("samples", samples, *SAMPLES_RANGE)
    engine = _engine_id(engine)
    env_path = hdri_path(hdri)

    scene = bpy.data.scenes.new("LookDev")
    _CREATED[scene.as_pointer()] = []
    try:
        _view_transform(scene, view_transform)
        ball = _populate(scene, size, samples, engine, env_path)
    except BaseException:
        remove_scene(scene)
        raise
    return scene, ball


def _populate(scene, size: int, samples: int, engine: str, env_path: Path):
    verts, faces = _ball_arrays()
    ball_mesh = _track(scene, "meshes", mesh_from_arrays("LookDevBall", verts, faces))
    ball_mesh.shade_smooth()
    ball = _track(scene, "objects", bpy.data.objects.new("LookDevBall", ball_mesh))
    ball.rotation_euler = Euler(tuple(math.radians(a) for a in BALL_TILT_DEG))
    ball_mesh.materials.append(None)  # the slot the caller fills
    scene.collection.objects.link(ball)

    ball_bottom = -float(np.max(ball_profile(np.array([np.pi]))))
    z1 = ball_bottom + 0.08  # the ball sits a little into the pedestal
    pv, pf = _cylinder_arrays(PEDESTAL_RADIUS, z1 - PEDESTAL_HEIGHT, z1)
    ped_mesh = _track(scene, "meshes", mesh_from_arrays("LookDevPedestal", pv, pf))
    ped_mat = _track(scene, "materials", bpy.data.materials.new("LookDevPedestal"))
    _principled_tree(ped_mat, PEDESTAL_COLOR, metallic=0.0, roughness=0.5)
    ped_mesh.materials.append(ped_mat)
    pedestal = _track(scene, "objects", bpy.data.objects.new("LookDevPedestal", ped_mesh))
    scene.collection.objects.link(pedestal)

    cam_data = _track(scene, "cameras", bpy.data.cameras.new("LookDevCamera"))
    cam_data.lens = CAMERA_LENS_MM
    cam_data.sensor_fit = "AUTO"
    cam = _track(scene, "objects", bpy.data.objects.new("LookDevCamera", cam_data))
    cam.location = CAMERA_LOCATION
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (Vector(CAMERA_TARGET) - Vector(CAMERA_LOCATION)).to_track_quat("-Z", "Y")
    scene.collection.objects.link(cam)
    scene.camera = cam

    sun_data = _track(scene, "lights", bpy.data.lights.new("LookDevSun", "SUN"))
    sun_data.energy = SUN_STRENGTH
    sun_data.angle = math.radians(SUN_ANGLE_DEG)
    sun = _track(scene, "objects", bpy.data.objects.new("LookDevSun", sun_data))
    sun.rotation_euler = Euler(tuple(math.radians(a) for a in SUN_ROTATION_DEG))
    scene.collection.objects.link(sun)

    world, image = hdri_world("LookDevWorld", env_path, HDRI_STRENGTH)
    _track(scene, "worlds", world)
    _track(scene, "images", image)
    scene.world = world

    scene.render.engine = engine
    deterministic_cycles(scene, (size, size), samples, THREADS, SEED)
    scene.render.film_transparent = False
    scene.cycles.shading_system = False
    scene.eevee.taa_render_samples = samples
    ensure_passes(scene)  # normal and the material's AOVs, as in the reference scene
    return ball


def _alive(block) -> bool:
    try:
        block.name
    except ReferenceError:
        return False
    return True


def remove_scene(scene) -> None:
    """Remove a look-dev scene and every datablock :func:`build_lookdev_scene` made for it
    (objects, meshes, camera, light, world, HDRI image, pedestal material).  Materials
    put on the ball afterwards belong to whoever made them and stay."""
    created = _CREATED.pop(scene.as_pointer(), [])
    if _alive(scene):
        bpy.data.scenes.remove(scene)
    order = ("objects", "meshes", "cameras", "lights", "materials", "worlds", "images")
    for coll in order:
        for kind, block in created:
            if kind == coll and _alive(block):
                getattr(bpy.data, coll).remove(block)


# ---------------------------------------------------------------------------
# Principled BSDF + Thin Film
def _principled_tree(mat, base_color, metallic: float, roughness: float, thin_film: tuple | None = None,
                     transmission: float = 0.0, thickness_noise: tuple | None = None):
    nt = mat.node_tree
    nt.nodes.clear()
    bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = tuple(base_color)[:3] + (1.0,)
    bsdf.inputs["Metallic"].default_value = metallic
    bsdf.inputs["Roughness"].default_value = roughness
    if transmission > 0.0:  # a clear film: light passes through unbent
        bsdf.inputs["Transmission Weight"].default_value = transmission
        bsdf.inputs["IOR"].default_value = 1.0
    if thin_film is not None:
        bsdf.inputs["Thin Film Thickness"].default_value = thin_film[0]
        bsdf.inputs["Thin Film IOR"].default_value = thin_film[1]
    if thin_film is not None and thickness_noise is not None:
        # The film's thickness from the same noise as the layered material's, over its range.
        d_min, d_max, scale, detail, rough = thickness_noise
        coords = nt.nodes.new("ShaderNodeTexCoord")
        noise = nt.nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = scale
        noise.inputs["Detail"].default_value = detail
        noise.inputs["Roughness"].default_value = rough
        span = nt.nodes.new("ShaderNodeMapRange")
        span.inputs["To Min"].default_value = d_min
        span.inputs["To Max"].default_value = d_max
        nt.links.new(coords.outputs["Object"], noise.inputs["Vector"])
        nt.links.new(noise.outputs["Fac"], span.inputs["Value"])
        nt.links.new(span.outputs["Result"], bsdf.inputs["Thin Film Thickness"])
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return bsdf


def principled_thin_film(name: str, thickness_nm: float, ior: float, base_color, metallic: float,
                         roughness: float, transmission: float = 0.0, thickness_noise: tuple | None = None):
    """A new material: Principled BSDF with Thin Film (``thickness_nm``, film ``ior``),
    ``base_color`` (RGB in [0, 1]), ``metallic``, ``roughness`` and ``transmission`` in [0, 1];
    ``thickness_noise`` ``(d_min, d_max, scale, detail, roughness)``: the film's thickness from a
    Noise Texture in object space over ``d_min..d_max`` instead of ``thickness_nm``."""
    checks = (("thickness_nm", thickness_nm, 0.0, 100000.0), ("ior", ior, 1.0, 1000.0),
              ("metallic", metallic, 0.0, 1.0), ("roughness", roughness, 0.0, 1.0))
    for pname, value, lo, hi in checks:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not lo <= value <= hi:
            raise ParameterError(pname, value, f"a number in [{lo:g}, {hi:g}]")
    color = tuple(base_color)
    if len(color) not in (3, 4) or not all(isinstance(c, (int, float)) and 0.0 <= c <= 1.0 for c in color[:3]):
        raise ParameterError("base_color", base_color, "three numbers in [0, 1]")
    mat = bpy.data.materials.new(name)
    _principled_tree(mat, color[:3], float(metallic), float(roughness), (float(thickness_nm), float(ior)),
                     float(transmission), thickness_noise)
    return mat


METAL_WORDS = ("metal", "titanium")
# A clear base for Principled's transmission, which the Base Color tints: a black base
# transmits nothing, and a "clear" film over it renders as a dark iridescent mirror.
CLEAR_BASE = (1.0, 1.0, 1.0)


def principled_soap_film(name: str = "Soap film", thickness_nm: float = 500.0, ior: float = 1.33,
                         roughness: float = 0.1):
    """Blender's soap bubble: a clear base (white, IOR 1, transmission 1) under a film of water."""
    return principled_thin_film(name, thickness_nm, ior, CLEAR_BASE, 0.0, roughness, transmission=1.0)


def thin_film_equivalent(name: str, params: LayeredParams) -> dict[str, Any]:
    """The Principled BSDF + Thin Film values nearest to a preset: the film's thickness in
    the middle of d_min..d_max, its index the green one (r1_g), the base colour, metallic
    1 for a preset whose name says metal or titanium (else 0), and the node's Upper Roughness
    (:func:`~..model.base_layers.phong_to_roughness` of e0: the same Roughness as Blender's
    BSDFs take it).  The keyword arguments of :func:`principled_thin_film`.

    A fair baseline: a noise-driven film takes the same noise over the same range; a clear
    film (transparent base) transmits; with physical optics over a metal, the base colour is
    the metal's reflectance at normal incidence, ``((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)``."""
    metallic = 1.0 if any(w in name.lower() for w in METAL_WORDS) else 0.0
    colour = params.base_color
    if params.base_layer == "transparent":
        colour = CLEAR_BASE  # Principled tints its transmission by the base colour
    if params.optics == "physical" and metallic:
        colour = tuple(((n - 1.0) ** 2 + k * k) / ((n + 1.0) ** 2 + k * k) for n, k in zip(params.r2, params.k2))
    out = dict(thickness_nm=0.5 * (params.d_min + params.d_max), ior=params.r1_g, base_color=colour,
               metallic=metallic, roughness=phong_to_roughness(params.e0),
               transmission=1.0 if params.base_layer == "transparent" else 0.0)
    if params.thickness_mode == "noise" and params.d_min != params.d_max:
        out["thickness_noise"] = (params.d_min, params.d_max, params.noise_scale, params.noise_detail,
                                  params.noise_roughness)
    return out
