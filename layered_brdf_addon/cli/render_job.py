"""Rendering in this process (imports bpy): the one path of ``render`` and ``gallery``.

:func:`render_outputs` renders a built scene (with
:func:`layered_brdf_addon.blender.scene.render_to_exr`, the add-on's one render call)
and writes ``STEM.exr``, ``STEM.png`` and the sidecar ``STEM.json`` together, under an
:class:`~.staging.InterruptGuard`; :func:`sidecar` is the one builder of the sidecar.
:func:`execute_render` renders a validated :class:`~.requests.RenderRequest`; the
gallery (:mod:`.gallery`) builds its grid scene and calls :func:`render_outputs` too.
"""
from __future__ import annotations

import contextlib
import platform
import shutil
import socket
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .. import __version__
from ..blender import tempdirs
from ..io.codecs import exr_beauty, muted_stderr, read_complete_exr_layers, replace_exr_layers, save_png, to_srgb8
from ..io.sidecar import SIDECAR_FORMAT, SIDECAR_VERSION, camera_to_dict, sun_to_dict, write_json
from ..io.staging import InterruptGuard, OutputPaths, StagedOutputs, reading_back, writing
from ..model.params import ParameterError
from ..model.policy import render_plan, tables_fallback
from .requests import RenderRequest

PNG_ENCODING = "8-bit sRGB, Blender's Standard view transform (clipped to [0, 1])"


def view_png_encoding(view: Mapping[str, Any]) -> str:
    """The sidecar's ``png_encoding`` of a PNG encoded by Blender with a scene's view settings."""
    return (f"8-bit, Blender's colour management of the scene: view transform {view['view_transform']}, "
            f"look {view['look']}, exposure {view['exposure']:g}, gamma {view['gamma']:g}, "
            f"display {view['display_device']}")
EXR_PASSES = ["Combined", "Normal", "layer_thickness", "lower_normal", "upper_normal"]


def _open_blend(req: RenderRequest):
    """Open the request's .blend; return (scene, target object)."""
    import bpy

    try:
        bpy.ops.wm.open_mainfile(filepath=str(req.blend), load_ui=False)
    except RuntimeError as e:
        reason = str(e).strip().splitlines()[-1] if str(e).strip() else "Blender could not open it"
        raise ParameterError("blend", str(req.blend), f"a .blend file Blender can open ({reason})") from None
    scene = bpy.context.scene
    obj = scene.objects.get(req.object)
    if obj is None:
        names = ", ".join(sorted(o.name for o in scene.objects))
        raise ParameterError("object", req.object, f"the name of an object in {req.blend.name} "
                             f"(scene '{scene.name}': {names[:400]})")
    if scene.camera is None:
        raise ParameterError("blend", str(req.blend), "a .blend whose scene has an active camera")
    r = scene.render
    r.engine = "CYCLES"
    if req.resolution is not None:
        r.resolution_x, r.resolution_y = req.resolution
        r.resolution_percentage = 100
    if req.threads is not None:
        r.threads_mode = "FIXED"
        r.threads = req.threads
    c = scene.cycles
    if req.samples is not None:
        c.samples = req.samples
    c.seed = req.seed
    c.use_animated_seed = False
    if req.backend == "osl":
        c.device = "CPU"
        c.shading_system = True
    from ..blender.scene import ensure_passes  # imports bpy: only when rendering

    ensure_passes(scene)
    return scene, obj


def _blend_camera_dict(scene) -> dict[str, Any]:
    cam = scene.camera
    r = scene.render
    d = {"type": cam.data.type, "name": cam.name, "matrix_world": [list(row) for row in cam.matrix_world],
         "width": r.resolution_x * r.resolution_percentage // 100,
         "height": r.resolution_y * r.resolution_percentage // 100,
         "sensor_fit": cam.data.sensor_fit, "sensor_width": cam.data.sensor_width,
         "sensor_height": cam.data.sensor_height, "clip_start": cam.data.clip_start, "clip_end": cam.data.clip_end}
    if cam.data.type == "ORTHO":
        d["ortho_scale"] = cam.data.ortho_scale
    else:
        d["lens"] = cam.data.lens
    return d


def _blend_lights(scene) -> list[dict[str, Any]]:
    from mathutils import Vector

    out = []
    for o in scene.objects:
        if o.type == "LIGHT" and not o.hide_render:
            d = {"name": o.name, "type": o.data.type, "energy": o.data.energy, "color": list(o.data.color),
                 "matrix_world": [list(row) for row in o.matrix_world]}
            if o.data.type == "SUN":
                d["direction"] = list((o.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))).normalized())
                d["angle"] = o.data.angle
            out.append(d)
    return out


def _osl_aov_layers(scene, guard) -> dict[str, dict[str, Any]]:
    """The AOVs of an OSL render (Cycles writes none under OSL), from emission renders.

    Their temporary files go to a private folder that an interrupt removes.
    """
    from ..blender.material import AOV_LOWER_NORMAL, AOV_THICKNESS, AOV_UPPER_NORMAL  # imports bpy: only when rendering
    from ..blender.scene import render_passes_osl  # imports bpy: only when rendering

    tempdirs.sweep_stale()
    private = str(tempdirs.owned_dir("aov"))
    cleanup = lambda: shutil.rmtree(private, ignore_errors=True)  # noqa: E731
    guard.add_cleanup(cleanup)
    saved = tempfile.tempdir
    tempfile.tempdir = private
    try:
        p = render_passes_osl(scene)
    finally:
        tempfile.tempdir = saved
        cleanup()
        guard.remove_cleanup(cleanup)
    one = np.ones(p.thickness.shape)
    return {AOV_THICKNESS: {"X": p.thickness},
            AOV_LOWER_NORMAL: {"R": p.lower_normal[..., 0], "G": p.lower_normal[..., 1],
                               "B": p.lower_normal[..., 2], "A": one},
            AOV_UPPER_NORMAL: {"R": p.upper_normal[..., 0], "G": p.upper_normal[..., 1],
                               "B": p.upper_normal[..., 2], "A": one}}


def sidecar(kind: str, scene, paths: OutputPaths, *, backend: str, camera: Mapping[str, Any],
            sun: Mapping[str, Any] | None, centers, render_seconds: float, t_start: float,
            command: Sequence[str] | None, png_encoding: str = PNG_ENCODING, **fields: Any) -> dict[str, Any]:
    """The sidecar of a render: what ``kind`` of scene (reference, blend, gallery), its
    ``fields`` (material, layout, ...), then what every render records: backend, sampling,
    camera, sun, sphere centres, outputs, how the PNG was encoded, timing and versions."""
    import bpy

    return {
        "format": SIDECAR_FORMAT, "version": SIDECAR_VERSION, "scene": kind, **fields,
        "backend": backend,
        "samples": scene.cycles.samples, "seed": scene.cycles.seed,
        "threads": scene.render.threads, "filter_width": scene.cycles.filter_width,
        "camera": camera, "sun": sun, "centers": centers, "radius": 1.0 if centers else None,
        "outputs": {"png": paths.png, "exr": paths.exr, "json": paths.json},
        "png_encoding": png_encoding,
        "render_seconds": render_seconds, "total_seconds": time.perf_counter() - t_start,
        "bpy_version": bpy.app.version_string, "layered_brdf_version": __version__,
        "host": socket.gethostname(), "python": platform.python_version(),
        "command": list(command) if command is not None else None,
    }


def render_outputs(scene, paths: OutputPaths, guard: InterruptGuard, *,
                   png: Callable[[np.ndarray, np.ndarray | None], np.ndarray],
                   describe: Callable[[float], dict[str, Any]], osl_aovs: bool = False) -> dict[str, Any]:
    """Render ``scene`` and write ``paths`` (EXR, PNG, sidecar) together; return the sidecar.

    ``png(rgb, alpha)`` turns the linear beauty pass into 8-bit pixels; ``describe(render
    seconds)`` gives the sidecar.  ``osl_aovs`` adds the AOVs that Cycles does not write
    under OSL (rendered as emission passes, counted in the render time).
    """
    from ..blender.scene import render_to_exr  # imports bpy: only when rendering

    with StagedOutputs(paths.all(), guard) as staged:
        exr_tmp = staged.temp(paths.exr)
        t_render = time.perf_counter()
        render_to_exr(exr_tmp, scene, guard)
        render_seconds = time.perf_counter() - t_render
        guard.check()
        rgb, alpha = read_written_beauty(exr_tmp, paths.exr, guard)
        if osl_aovs:
            t_aovs = time.perf_counter()
            layers = _osl_aov_layers(scene, guard)
            guard.check()
            with guard.io(), writing(paths.exr):
                replace_exr_layers(exr_tmp, layers)
            render_seconds += time.perf_counter() - t_aovs
            guard.check()
        pixels = png(rgb, alpha)
        with guard.io(), writing(paths.png):
            save_png(staged.temp(paths.png), pixels)
        guard.check()
        data = describe(render_seconds)
        with guard.io(), writing(paths.json):
            write_json(staged.temp(paths.json), data)
        guard.check()
    return data


def read_written_beauty(exr: Path, final: Path, guard: InterruptGuard | None = None
                        ) -> tuple[np.ndarray, np.ndarray | None]:
    """The beauty pass of the EXR that Blender wrote to ``exr`` (the staged file of ``final``),
    once every pass its header lists has been read.

    A file cut short (Blender's writer is silent about a full disk) is a
    :class:`~.staging.WriteError` naming ``final`` and saying why, rather than a missing
    channel or an EXR committed without some of its passes; OpenEXR's own complaints
    about the damaged chunks are not shown.
    """
    with guard.io() if guard is not None else contextlib.nullcontext(), \
            reading_back(final, Path(exr).parent), muted_stderr():
        return exr_beauty(exr, read_complete_exr_layers(exr))


def execute_render(req: RenderRequest, command: Sequence[str] | None = None,
                   log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Render ``req`` in this process; write ``STEM.exr``, ``STEM.png`` and ``STEM.json``.

    The three files appear together (written under temporary names, renamed when all
    are complete); SIGINT and SIGTERM stop the render at once and leave no file
    behind (exit code 130).  Returns the sidecar.
    """
    t_start = time.perf_counter()
    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    with InterruptGuard() as guard:
        guard.add_cleanup(tempdirs.remove_process_tempdir)
        import bpy  # after enter_process_tempdir: Blender makes its session folder in that folder

        from ..blender.material import animated_parameters, apply_layered_material  # imports bpy, as above
        from ..blender.scene import (SceneSpec, build_scene, encode_view, reset_blender,  # imports bpy, as above
                                     view_settings_record)

        guard.arm()
        guard.check()
        if req.blend is not None:
            scene, target = _open_blend(req)
            camera_info, sun_info, centers = _blend_camera_dict(scene), None, None
        else:
            reset_blender()
            camera, sun = req.camera(), req.sun_light()
            centers = ((0.0, 0.0, 0.0),)
            spec = SceneSpec(camera=camera, sun=sun, centers=centers, samples=req.samples,
                             threads=req.threads, seed=req.seed, osl=(req.backend == "osl"))
            target = build_scene(spec)[0]
            scene = bpy.context.scene
            camera_info, sun_info = camera_to_dict(camera), sun_to_dict(sun)
        guard.arm()
        guard.check()
        material = apply_layered_material(target, req.params, req.backend)
        guard.check()
        paths = req.paths
        # The plan the material was built with: a --blend material's keyframes, drivers and linked
        # sockets keep the effects they may switch on.
        animated = animated_parameters(material)
        plan = render_plan(req.params, animated, req.backend)
        fallback = tables_fallback(req.params, animated, req.backend)

        def describe(render_seconds: float) -> dict[str, Any]:
            return sidecar(
                "blend" if req.blend else "reference", scene, paths, backend=req.backend, camera=camera_info,
                sun=sun_info, centers=centers, render_seconds=render_seconds, t_start=t_start, command=command,
                name=req.name, preset=req.preset, params_file=req.params_file, overrides=dict(req.overrides),
                params=req.params.to_dict(), plan={**plan.to_dict(), "key": plan.key, "describe": plan.describe(),
                      **({"tables_fallback": fallback} if fallback else {})},
                blend=req.blend, object=req.object, lights=_blend_lights(scene) if req.blend else None,
                exr_passes=EXR_PASSES, png_view=view_settings_record(scene) if req.blend else None,
                png_encoding=view_png_encoding(view_settings_record(scene)) if req.blend else PNG_ENCODING)

        transparent = scene.render.film_transparent
        if req.blend:  # the PNG the .blend's own colour management gives (its view transform, look, exposure)
            png = lambda rgb, a: encode_view(rgb, scene, a if transparent else None)  # noqa: E731
        else:  # the reference sphere: Standard, clipped
            png = lambda rgb, a: to_srgb8(rgb, a if transparent else None)  # noqa: E731
        data = render_outputs(scene, paths, guard, png=png, describe=describe, osl_aovs=req.backend == "osl")
    if log:
        log(f"wrote {paths.png}, {paths.exr}, {paths.json} (render {data['render_seconds']:.2f} s)")
    return data
