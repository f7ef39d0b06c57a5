"""The reference sphere scene (docs/reference-scene.md) and rendering it to arrays.

Unit spheres, an orthographic camera, one zero-angle sun, a black world, direct
light only, a 0.01 px pixel filter (each sample hits the pixel centre, so one sample
per pixel is exact under a sun), fixed seed, no denoiser, no adaptive sampling, a
fixed thread count, float EXR with the beauty, normal and AOV passes.
"""
from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import bpy  # first: it makes mathutils importable
import numpy as np
from mathutils import Matrix, Vector

from ..model.sphere import OrthoCamera, Sun
from .own_nodes import shader_node
from .stored_keys import AOV_LOWER_NORMAL, AOV_THICKNESS, AOV_UPPER_NORMAL

SPHERE_SEGMENTS = 256
SPHERE_RINGS = 128


@dataclass
class SceneSpec:
    camera: OrthoCamera = field(default_factory=OrthoCamera)
    sun: Sun = field(default_factory=Sun)
    centers: tuple = ((0.0, 0.0, 0.0),)
    samples: int = 1
    threads: int = 2
    seed: int = 0
    osl: bool = False


SHADER_FAILED_RGB = (1.0, 0.0, 1.0)  # what Blender renders where a material does not compile


def shader_failed(rgb, tol: float = 0.1) -> np.ndarray:
    """Where the linear colours ``rgb`` (..., 3 or 4) are Blender's "shader failed" magenta,
    each channel within ``tol``."""
    return np.all(np.abs(np.asarray(rgb)[..., :3] - np.asarray(SHADER_FAILED_RGB)) < tol, axis=-1)


def reset_blender() -> None:
    """Start from factory settings with an empty file."""
    bpy.ops.wm.read_factory_settings(use_empty=True)


def row_of_spheres(n: int, spacing: float = 2.2) -> tuple:
    """Centres of ``n`` unit spheres in a row along x."""
    return tuple(((k - (n - 1) / 2.0) * spacing, 0.0, 0.0) for k in range(n))


def camera_for(n: int, height: int = 64, spacing: float = 2.2, view=(0.0, -1.0, 0.0)) -> OrthoCamera:
    """A camera framing ``n`` spheres in a row, ``height`` pixels per sphere."""
    return OrthoCamera(view=view, ortho_scale=spacing * n, width=height * n, height=height)


def sphere_arrays(segments: int = SPHERE_SEGMENTS, rings: int = SPHERE_RINGS):
    """Vertices (V, 3) and quad/triangle faces of a UV sphere of radius 1 (poles on z)."""
    theta = np.pi * np.arange(1, rings) / rings  # rings - 1 latitude circles
    phi = 2.0 * np.pi * np.arange(segments) / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring_verts = np.stack([st * np.cos(phi), st * np.sin(phi), ct * np.ones_like(phi)], axis=-1).reshape(-1, 3)
    verts = np.concatenate([[[0.0, 0.0, 1.0]], ring_verts, [[0.0, 0.0, -1.0]]])
    top, bottom = 0, len(verts) - 1
    idx = 1 + np.arange((rings - 1) * segments).reshape(rings - 1, segments)
    nxt = np.roll(idx, -1, axis=1)
    quads = np.stack([idx[:-1], idx[1:], nxt[1:], nxt[:-1]], axis=-1).reshape(-1, 4)
    cap_top = np.stack([np.full(segments, top), idx[0], nxt[0]], axis=-1)
    cap_bottom = np.stack([idx[-1], np.full(segments, bottom), nxt[-1]], axis=-1)
    return verts, cap_top, quads, cap_bottom


def mesh_from_arrays(name: str, verts: np.ndarray, face_sets: Sequence[np.ndarray]):
    """A new mesh of vertices ``verts`` (N, 3) and faces, each array of ``face_sets`` holding
    faces of one size (F, k) as vertex indices."""
    loops = np.concatenate([np.asarray(f).ravel() for f in face_sets])
    sizes = np.concatenate([np.full(len(f), np.asarray(f).shape[1]) for f in face_sets])
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", np.asarray(verts, dtype=np.float32).ravel())
    mesh.loops.add(len(loops))
    mesh.loops.foreach_set("vertex_index", loops.astype(np.int32))
    mesh.polygons.add(len(sizes))
    mesh.polygons.foreach_set("loop_start", starts.astype(np.int32))
    mesh.update(calc_edges=True)
    mesh.validate()
    return mesh


def _sphere_mesh(name: str):
    verts, tri_top, quads, tri_bottom = sphere_arrays()
    mesh = mesh_from_arrays(name, verts, (tri_top, quads, tri_bottom))
    mesh.shade_smooth()
    return mesh


def deterministic_cycles(scene, resolution: tuple[int, int], samples: int | None, threads: int, seed: int) -> None:
    """Cycles on the CPU rendering the same pixels every time: ``resolution`` at 100%, a fixed
    number of ``threads``, a fixed ``seed``, no denoiser, no adaptive sampling, no data kept
    between renders; ``samples`` per pixel (None: left as it is)."""
    r = scene.render
    r.resolution_x, r.resolution_y = resolution
    r.resolution_percentage = 100
    r.threads_mode = "FIXED"
    r.threads = threads
    r.use_persistent_data = False
    c = scene.cycles
    c.device = "CPU"
    if samples is not None:
        c.samples = samples
    c.seed = seed
    c.use_animated_seed = False
    c.use_denoising = False
    c.use_adaptive_sampling = False


def build_scene(spec: SceneSpec, scene=None):
    """Create the reference scene in ``scene`` (default: the current one). Returns the spheres."""
    scene = scene or bpy.context.scene
    for obj in list(scene.collection.objects):
        bpy.data.objects.remove(obj)
    mesh = _sphere_mesh("LayeredSphere")
    spheres = []
    for k, c in enumerate(spec.centers):
        obj = bpy.data.objects.new(f"Sphere{k}", mesh.copy() if k else mesh)
        obj.location = c
        # Camera rays only: no sphere shadows, occludes or reflects another (a convex
        # sphere cannot shadow itself), so every sphere sees the light alone.
        obj.visible_shadow = False
        obj.visible_diffuse = False
        obj.visible_glossy = False
        obj.visible_transmission = False
        obj.visible_volume_scatter = False
        scene.collection.objects.link(obj)
        spheres.append(obj)

    cam_data = bpy.data.cameras.new("RefCamera")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = spec.camera.ortho_scale
    cam_data.sensor_fit = "AUTO"
    cam_data.clip_end = 100.0
    cam = bpy.data.objects.new("RefCamera", cam_data)
    cam.matrix_world = Matrix(spec.camera.matrix_world().tolist())
    scene.collection.objects.link(cam)
    scene.camera = cam

    sun_data = bpy.data.lights.new("RefSun", "SUN")
    sun_data.energy = spec.sun.strength
    sun_data.angle = 0.0
    sun = bpy.data.objects.new("RefSun", sun_data)
    sun.rotation_mode = "QUATERNION"
    sun.rotation_quaternion = Vector(spec.sun.l.tolist()).to_track_quat("Z", "Y")
    scene.collection.objects.link(sun)

    world = bpy.data.worlds.get("RefWorld") or bpy.data.worlds.new("RefWorld")
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    scene.world = world

    scene.render.engine = "CYCLES"
    deterministic_cycles(scene, (spec.camera.width, spec.camera.height), spec.samples, spec.threads, spec.seed)
    scene.render.film_transparent = False
    c = scene.cycles
    c.shading_system = spec.osl
    c.filter_width = 0.01
    c.max_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    ensure_passes(scene)
    return spheres


def ensure_passes(scene) -> None:
    """The normal pass and the material's AOVs on the scene's first view layer."""
    vl = scene.view_layers[0]
    vl.use_pass_normal = True
    names = {a.name for a in vl.aovs}
    for name, kind in ((AOV_THICKNESS, "VALUE"), (AOV_LOWER_NORMAL, "COLOR"), (AOV_UPPER_NORMAL, "COLOR")):
        if name not in names:
            aov = vl.aovs.add()
            aov.name, aov.type = name, kind


@dataclass
class Passes:
    """Render passes as arrays with row 0 at the top of the image."""

    beauty: np.ndarray  # (H, W, 3)
    normal: np.ndarray  # (H, W, 3) Cycles' Normal pass (the closures' average normal)
    thickness: np.ndarray  # (H, W)
    lower_normal: np.ndarray  # (H, W, 3)
    upper_normal: np.ndarray  # (H, W, 3) n0, the shading normal the material used
    seconds: float = 0.0


def read_exr(path) -> dict[str, np.ndarray]:
    """Channels of a (multilayer) EXR as float arrays, rows top to bottom."""
    import OpenEXR

    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:  # Blender writes one part per pass
            for name, ch in part.channels.items():
                out[name] = np.asarray(ch.pixels, dtype=np.float64)
    return out


def _stack(ch, prefix, comps):
    for layer in ("ViewLayer.", ""):
        keys = [f"{layer}{prefix}.{c}" for c in comps]
        if all(k in ch for k in keys):
            return np.stack([ch[k] for k in keys], axis=-1)
    raise KeyError(f"EXR lacks {prefix} ({', '.join(sorted(ch))[:300]})")


def passes_from_exr(path) -> Passes:
    ch = read_exr(path)
    beauty = _stack(ch, "Combined", "RGB")
    normal = _stack(ch, "Normal", "XYZ")
    try:
        thick = _stack(ch, AOV_THICKNESS, "X")[..., 0]
    except KeyError:
        thick = np.zeros(beauty.shape[:2])
    aovs = []
    for name in (AOV_LOWER_NORMAL, AOV_UPPER_NORMAL):
        try:
            aovs.append(_stack(ch, name, "RGB"))
        except KeyError:
            aovs.append(np.zeros_like(beauty))
    return Passes(beauty, normal, thick, *aovs)


def render_to_file(path, scene=None, guard=None) -> float:
    """Render the scene's camera and save the result with the scene's output settings.

    The add-on's one render call: the tests, ``render``, ``gallery`` and the asset previews
    all render through it.  The file is written under a temporary name and renamed when
    complete.  With an :class:`~layered_brdf_addon.io.staging.InterruptGuard`, a signal
    during the render stops it at once and the write holds the guard's I/O lock, so an
    interrupt waits for a complete file.  Returns the render seconds.
    """
    import contextlib
    import time

    scene = scene or bpy.context.scene
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.partial{os.getpid()}{path.suffix}")
    t0 = time.perf_counter()
    try:
        bpy.ops.render.render(write_still=False, scene=scene.name)
        seconds = time.perf_counter() - t0
        if guard is not None:
            guard.check()
        result = bpy.data.images.get("Render Result")
        if result is None:
            raise RuntimeError("Blender produced no render result")
        with guard.io() if guard is not None else contextlib.nullcontext():
            result.save_render(filepath=str(tmp), scene=scene)
            if not tmp.exists():
                raise RuntimeError(f"Blender did not write {tmp}")
            os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return seconds


def render_to_exr(path, scene=None, guard=None) -> float:
    """Render the scene's camera to a multilayer float EXR (every pass); see :func:`render_to_file`."""
    scene = scene or bpy.context.scene
    s = scene.render.image_settings
    s.media_type = "MULTI_LAYER_IMAGE"  # Blender 5: multilayer EXR
    s.file_format = "OPEN_EXR_MULTILAYER"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    return render_to_file(path, scene, guard)


def view_settings_record(scene=None) -> dict:
    """The scene's colour management as plain data: view transform, look, exposure, gamma, display."""
    scene = scene or bpy.context.scene
    v = scene.view_settings
    return {"view_transform": v.view_transform, "look": v.look, "exposure": v.exposure, "gamma": v.gamma,
            "display_device": scene.display_settings.display_device}


def encode_view(rgb, scene=None, alpha=None) -> np.ndarray:
    """8-bit display pixels of linear (scene-referred) ``rgb`` (H, W, 3), rows top to bottom,
    encoded by Blender's own colour management with the scene's view transform, look,
    exposure, gamma, display and dither: what Blender writes when it saves a render of
    these pixels as an 8-bit PNG.  With ``alpha`` (premultiplied input) the result is
    straight RGBA (H, W, 4), else RGB."""
    from PIL import Image

    scene = scene or bpy.context.scene
    rgb = np.asarray(rgb, dtype=np.float32)[..., :3]
    h, w = rgb.shape[:2]
    a = np.ones((h, w, 1), np.float32) if alpha is None else np.asarray(alpha, np.float32).reshape(h, w, 1)
    img = bpy.data.images.new(".layered_brdf_encode", w, h, alpha=True, float_buffer=True)
    s = scene.render.image_settings
    saved = {k: getattr(s, k) for k in ("media_type", "file_format", "color_mode", "color_depth",
                                        "color_management")}
    try:
        img.pixels.foreach_set(np.ascontiguousarray(np.concatenate([rgb, a], axis=-1)[::-1]).ravel())
        s.media_type = "IMAGE"
        s.file_format = "PNG"
        s.color_mode = "RGB" if alpha is None else "RGBA"
        s.color_depth = "8"
        s.color_management = "FOLLOW_SCENE"
        with tempfile.TemporaryDirectory(prefix="layered_brdf_png_") as tmp:
            path = Path(tmp) / "encoded.png"
            img.save_render(filepath=str(path), scene=scene)
            with Image.open(path) as im:
                out = np.array(im.convert("RGB" if alpha is None else "RGBA"))
    finally:
        bpy.data.images.remove(img)
        for k in ("media_type", "file_format", "color_mode", "color_depth", "color_management"):
            try:
                setattr(s, k, saved[k])
            except (TypeError, ValueError):  # a value only valid for the format it belonged to
                pass
    return out


def render_passes(scene=None, keep: str | os.PathLike | None = None) -> Passes:
    """Render and return the passes (EXR in a temporary folder unless ``keep`` names a path)."""
    if keep is not None:
        seconds = render_to_exr(keep, scene)
        p = passes_from_exr(keep)
    else:
        with tempfile.TemporaryDirectory(prefix="layered_brdf_") as tmp:
            path = Path(tmp) / "render.exr"
            seconds = render_to_exr(path, scene)
            p = passes_from_exr(path)
    p.seconds = seconds
    return p


def _scripted_materials(scene):
    """The layered materials of ``scene`` that run the OSL shader (found by the add-on's stamp)."""
    mats = set()
    for obj in scene.objects:
        for slot in getattr(obj, "material_slots", []):
            m = slot.material
            if m is not None and m.node_tree is not None:
                node = shader_node(m)
                if node is not None and node.bl_idname == "ShaderNodeScript":
                    mats.add(m)
    return mats


def render_passes_osl(scene=None, keep: str | os.PathLike | None = None) -> Passes:
    """Passes of a scene whose layered materials use the OSL backend.

    Cycles writes no AOV under OSL shading, so the thickness and the normals are
    rendered in extra passes that route the script's outputs into an emission shader
    (normals encoded as ``0.5 + 0.5 n``); the materials are restored afterwards.
    """
    scene = scene or bpy.context.scene
    beauty = render_passes(scene, keep)
    extra = {}
    for output, encode in (("Thickness", False), ("LowerNormal", True), ("UpperNormal", True)):
        saved = []
        for m in _scripted_materials(scene):
            tree = m.node_tree
            node = shader_node(m)
            out_node = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
            old = [l.from_socket for l in out_node.inputs["Surface"].links]
            emit = tree.nodes.new("ShaderNodeEmission")
            emit.inputs["Strength"].default_value = 1.0
            src = node.outputs.get(output)
            added = [emit]
            if src is None:
                continue
            if encode:
                vm = tree.nodes.new("ShaderNodeVectorMath")
                vm.operation = "MULTIPLY_ADD"
                vm.inputs[1].default_value = (0.5, 0.5, 0.5)
                vm.inputs[2].default_value = (0.5, 0.5, 0.5)
                tree.links.new(src, vm.inputs[0])
                src = vm.outputs[0]
                added.append(vm)
            tree.links.new(src, emit.inputs["Color"])
            tree.links.new(emit.outputs[0], out_node.inputs["Surface"])
            saved.append((tree, out_node, old, added))
        if not saved:
            continue
        try:
            p = render_passes(scene)
        finally:
            for tree, out_node, old, added in saved:
                for n in added:
                    tree.nodes.remove(n)
                for s in old:
                    tree.links.new(s, out_node.inputs["Surface"])
        extra[output] = (p.beauty * 2.0 - 1.0) if encode else p.beauty[..., 0]
    if "Thickness" in extra:
        beauty.thickness = extra["Thickness"]
    if "LowerNormal" in extra:
        beauty.lower_normal = extra["LowerNormal"]
    if "UpperNormal" in extra:
        beauty.upper_normal = extra["UpperNormal"]
    return beauty


def set_uniform_environment(radiance: float = 1.0, scene=None) -> None:
    """Replace the lights by a uniform white world of the given radiance."""
    scene = scene or bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == "LIGHT":
            bpy.data.objects.remove(obj)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = radiance


def hdri_world(name: str, image_path, strength: float = 1.0):
    """A new world lit by the equirectangular HDRI at ``image_path`` (Environment Texture,
    default mapping, ``strength``); returns the world and the image, new datablocks that whoever
    builds a scene with them removes with it."""
    world = bpy.data.worlds.new(name)
    image = bpy.data.images.load(str(image_path), check_existing=False)
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    bg = nt.nodes.get("Background") or nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Strength"].default_value = strength
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    out = next((n for n in nt.nodes if n.bl_idname == "ShaderNodeOutputWorld"), None) \
        or nt.nodes.new("ShaderNodeOutputWorld")
    if not bg.outputs[0].links:
        nt.links.new(bg.outputs[0], out.inputs["Surface"])
    return world, image


def set_hdri_environment(image_path, strength: float = 1.0, scene=None):
    """Replace the lights by an equirectangular HDRI on a world of its own (:func:`hdri_world`);
    returns the world."""
    scene = scene or bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == "LIGHT":
            bpy.data.objects.remove(obj)
    world, _ = hdri_world("Layered BRDF environment", image_path, strength)
    scene.world = world
    return world


def set_area_light(matrix, size: float, power: float, scene=None):
    """Replace the lights by one square area light (world matrix ``matrix``, emitting along -Z)."""
    scene = scene or bpy.context.scene
    for obj in list(scene.objects):
        if obj.type == "LIGHT":
            bpy.data.objects.remove(obj)
    data = bpy.data.lights.new("RefArea", "AREA")
    data.shape = "SQUARE"
    data.size = size
    data.energy = power
    data.spread = np.pi
    obj = bpy.data.objects.new("RefArea", data)
    obj.matrix_world = Matrix(np.asarray(matrix).tolist())
    scene.collection.objects.link(obj)
    return obj
