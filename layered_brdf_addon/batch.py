"""Render jobs: validating a job's options, rendering it, and running many of them.

A job is the set of options of ``python -m layered_brdf_addon render``, as a mapping
(from the command line or a TOML/JSON job file).  :func:`request_from_options`
validates it without Blender; :func:`execute_render` renders a validated request in
this process; :func:`run_job` renders one in a fresh subprocess (bpy is not
thread-safe, and a crash must not take the runner down); :func:`run_batch` runs
many, serially, on a local Dask cluster or on a Dask scheduler's workers.
"""
from __future__ import annotations

import json
import math
import os
import platform
import socket
import subprocess
import sys
import time
import tomllib
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

from .model.params import PARAM_SPECS, LayeredParams, ParameterError
from .model.policy import plan_effects
from .model.presets import PRESETS, preset
from .outputs import (OutputPaths, camera_to_dict, output_stem, remove_stale_temps, sun_to_dict)

BACKENDS = ("nodes", "osl")
PARAM_NAMES = tuple(s.name for s in PARAM_SPECS)
RUN_OPTIONS = ("name", "preset", "params", "blend", "object", "backend", "samples", "resolution", "sun",
               "sun_strength", "seed", "threads", "output")
REFERENCE_ONLY = ("sun", "sun_strength")  # options of the reference scene only
REFERENCE_SAMPLES = 1
REFERENCE_RESOLUTION = 128
REFERENCE_THREADS = 2
MAX_RESOLUTION = 16384
_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd


# ---------------------------------------------------------------------------
# validation (no Blender)
@dataclass(frozen=True)
class RenderRequest:
    """A validated render: the material, the scene and where the outputs go."""

    params: LayeredParams
    output: Path
    backend: str = "nodes"
    preset: str | None = None
    params_file: Path | None = None
    overrides: Mapping[str, Any] = field(default_factory=dict)
    samples: int | None = None
    resolution: tuple[int, int] | None = None
    sun: tuple[float, float, float] | None = None
    sun_strength: float | None = None
    seed: int = 0
    threads: int | None = None
    blend: Path | None = None
    object: str | None = None
    name: str | None = None

    @property
    def paths(self) -> OutputPaths:
        return OutputPaths(self.output)

    def camera(self):
        """The reference scene's orthographic camera (one unit sphere, a 10% margin)."""
        from .model.sphere import OrthoCamera

        w, h = self.resolution or (REFERENCE_RESOLUTION, REFERENCE_RESOLUTION)
        return OrthoCamera(width=w, height=h)

    def sun_light(self):
        """The reference scene's zero-angle sun (the model's default where not given)."""
        from .model.sphere import Sun

        default = Sun()
        return Sun(direction=self.sun or default.direction,
                   strength=default.strength if self.sun_strength is None else self.sun_strength)

    def to_argv(self) -> list[str]:
        """Arguments of ``render`` that reproduce this request (absolute paths)."""
        argv: list[str] = []
        if self.preset:
            argv += ["--preset", self.preset]
        if self.params_file:
            argv += ["--params", str(self.params_file)]
        for name, value in self.overrides.items():
            spec = LayeredParams.spec(name)
            flag = option_flag(name)
            if spec.kind == "bool":
                argv.append(flag if value else "--no-" + flag[2:])
            else:
                argv += [flag, repr(value) if isinstance(value, float) else str(value)]
        if self.blend:
            argv += ["--blend", str(self.blend), "--object", str(self.object)]
        argv += ["--backend", self.backend, "--seed", str(self.seed)]
        if self.samples is not None:
            argv += ["--samples", str(self.samples)]
        if self.resolution is not None:
            argv += ["--resolution", f"{self.resolution[0]}x{self.resolution[1]}"]
        if self.sun is not None:
            argv += ["--sun", *(repr(float(c)) for c in self.sun)]
        if self.sun_strength is not None:
            argv += ["--sun-strength", repr(float(self.sun_strength))]
        if self.threads is not None:
            argv += ["--threads", str(self.threads)]
        if self.name:
            argv += ["--name", self.name]
        argv += ["--output", str(self.output)]
        return argv


def option_flag(name: str) -> str:
    """The command-line flag of an option or parameter: ``d_min`` -> ``--d-min``."""
    return "--" + name.replace("_", "-")


def int_option(name: str, value: Any, lo: int, hi: int) -> int:
    allowed = f"an integer in [{lo}, {hi}]"
    if isinstance(value, bool):
        raise ParameterError(name, value, allowed)
    try:
        x = int(value) if not isinstance(value, float) else (int(value) if value.is_integer() else None)
    except (TypeError, ValueError):
        x = None
    if x is None or not lo <= x <= hi:
        raise ParameterError(name, value, allowed)
    return x


def float_option(name: str, value: Any, lo: float = -math.inf, hi: float = math.inf) -> float:
    allowed = f"a number in [{lo:g}, {hi:g}]"
    if isinstance(value, bool):
        raise ParameterError(name, value, allowed)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, value, allowed) from None
    if not math.isfinite(x) or not lo <= x <= hi:
        raise ParameterError(name, value, allowed)
    return x


def parse_resolution(value: Any) -> tuple[int, int]:
    """``N`` (square), ``"WxH"`` or ``[W, H]`` as ``(width, height)``."""
    allowed = f"N or WxH with integers in [1, {MAX_RESOLUTION}]"
    if isinstance(value, (list, tuple)):
        parts = list(value)
    elif isinstance(value, str) and "x" in value.lower():
        parts = value.lower().split("x")
    else:
        parts = [value, value]
    if len(parts) != 2:
        raise ParameterError("resolution", value, allowed)
    try:
        w, h = (int_option("resolution", p, 1, MAX_RESOLUTION) for p in parts)
    except ParameterError:
        raise ParameterError("resolution", value, allowed) from None
    return w, h


def parse_sun(value: Any) -> tuple[float, float, float]:
    """Three finite numbers, not all zero: the direction from the scene towards the sun."""
    allowed = "three finite numbers X Y Z, not all zero (the direction towards the sun)"
    if isinstance(value, str):
        value = value.replace(",", " ").split()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ParameterError("sun", value, allowed)
    try:
        xyz = tuple(float_option("sun", c) for c in value)
    except ParameterError:
        raise ParameterError("sun", value, allowed) from None
    if math.hypot(*xyz) < 1e-9:
        raise ParameterError("sun", value, allowed)
    return xyz  # type: ignore[return-value]


def _read_table_file(path: str | os.PathLike, name: str, allowed: str) -> Any:
    """The contents of a ``.toml`` or ``.json`` file; :class:`ParameterError` naming ``name``
    (with ``allowed``) if it cannot be read or parsed."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError(name, str(p), f"{allowed} ({e.__class__.__name__}: {e})") from None
    try:
        if p.suffix.lower() == ".toml":
            return tomllib.loads(text)
        if p.suffix.lower() == ".json":
            return json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
        raise ParameterError(name, str(p), f"{allowed} ({e})") from None
    raise ParameterError(name, str(p), allowed)


def load_params_file(path: str | os.PathLike) -> dict[str, Any]:
    """Parameter values from a ``.json`` or ``.toml`` file.

    The file holds ``{name: value}``; a ``params`` table inside it is used instead
    when present, so a render's sidecar can be given to re-render its material.
    """
    p = Path(path)
    allowed = "a readable .json or .toml file of parameter values"
    data = _read_table_file(p, "params", allowed)
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise ParameterError("params", str(p), allowed + " (a table of name = value)")
    return data


def check_blend_file(path: str | os.PathLike) -> Path:
    """Raise :class:`ParameterError` unless ``path`` looks like a .blend Blender can read."""
    p = Path(path)
    allowed = "a readable .blend file"
    try:
        with open(p, "rb") as f:
            head = f.read(7)
    except OSError as e:
        raise ParameterError("blend", str(p), f"{allowed} ({e.strerror or e})") from None
    if not any(head.startswith(m) for m in _BLEND_MAGIC):
        raise ParameterError("blend", str(p), f"{allowed} (this file is not a .blend)")
    return p.resolve()


def check_output(value: Any) -> Path:
    allowed = "a file path stem in a writable folder (STEM.png, STEM.exr and STEM.json are written)"
    if not isinstance(value, (str, os.PathLike)) or not str(value).strip():
        raise ParameterError("output", value, allowed)
    stem = output_stem(Path(value).expanduser()).absolute()
    if stem.is_dir():
        raise ParameterError("output", str(value), allowed + "; it names a folder")
    folder = stem.parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        raise ParameterError("output", str(value), allowed + f"; {folder} is not a writable folder")
    return stem


def _resolve(path: Any, base_dir: Path | None, name: str) -> Path:
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise ParameterError(name, path, "a file path")
    p = Path(path).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    return p


def request_from_options(options: Mapping[str, Any], *, base_dir: str | os.PathLike | None = None,
                         output_dir: str | os.PathLike | None = None) -> RenderRequest:
    """Validate a job's options (the ``render`` options, with ``_`` in names) without Blender.

    ``params`` and ``blend`` paths are relative to ``base_dir`` (default: the current
    folder); ``output`` is relative to ``output_dir`` (default: the current folder) and
    defaults to ``output_dir/NAME`` with NAME the job's name, preset or ``render``.
    Raises :class:`ParameterError` naming the first invalid option.
    """
    opts = {k: v for k, v in options.items() if v is not None}
    for key in opts:
        if key not in RUN_OPTIONS and key not in PARAM_NAMES:
            raise ParameterError(key, opts[key], "a render option (" + ", ".join(RUN_OPTIONS)
                                 + ") or a parameter name (" + ", ".join(PARAM_NAMES) + ")")
    base = Path(base_dir) if base_dir is not None else None
    name = opts.get("name")
    if name is not None and (not isinstance(name, str) or not name.strip()):
        raise ParameterError("name", name, "a non-empty string")

    preset_name = opts.get("preset")
    if preset_name is not None and (not isinstance(preset_name, str) or preset_name not in PRESETS):
        raise ParameterError("preset", preset_name, "one of " + ", ".join(sorted(PRESETS)))
    params = preset(preset_name) if preset_name else LayeredParams()
    params_file = None
    if "params" in opts:
        params_file = _resolve(opts["params"], base, "params").absolute()
        params = LayeredParams.from_dict(load_params_file(params_file), base=params)
    overrides = {k: opts[k] for k in PARAM_NAMES if k in opts}
    if overrides:
        params = LayeredParams.from_dict(overrides, base=params)
        overrides = {k: getattr(params, k) for k in overrides}

    backend = opts.get("backend", "nodes")
    if backend not in BACKENDS:
        raise ParameterError("backend", backend, "one of " + ", ".join(repr(b) for b in BACKENDS))
    if backend == "nodes" and params.lobe != "beckmann":
        raise ParameterError("lobe", params.lobe, "'beckmann' with the node backend (phong exists only in OSL)")

    blend = obj = None
    if "blend" in opts:
        blend = check_blend_file(_resolve(opts["blend"], base, "blend"))
        obj = opts.get("object")
        if not isinstance(obj, str) or not obj:
            raise ParameterError("object", obj, "the name of the object in the .blend that gets the material")
        for key in REFERENCE_ONLY:
            if key in opts:
                raise ParameterError(key, opts[key], "no value with a .blend (the file's own lights are used)")
    elif "object" in opts:
        raise ParameterError("object", opts["object"], "no value without a .blend (the reference scene has one sphere)")

    samples = int_option("samples", opts["samples"], 1, 1_000_000) if "samples" in opts else None
    resolution = parse_resolution(opts["resolution"]) if "resolution" in opts else None
    sun = parse_sun(opts["sun"]) if "sun" in opts else None
    strength = float_option("sun_strength", opts["sun_strength"], 0.0, 1e6) if "sun_strength" in opts else None
    seed = int_option("seed", opts.get("seed", 0), 0, 2**31 - 1)
    threads = int_option("threads", opts["threads"], 1, 1024) if "threads" in opts else None
    if blend is None:
        samples = REFERENCE_SAMPLES if samples is None else samples
        resolution = resolution or (REFERENCE_RESOLUTION, REFERENCE_RESOLUTION)
        threads = REFERENCE_THREADS if threads is None else threads

    out_base = Path(output_dir) if output_dir is not None else Path.cwd()
    if "output" in opts:
        out = opts["output"]
        if isinstance(out, (str, os.PathLike)) and not Path(out).expanduser().is_absolute():
            out = out_base / Path(out)
    else:
        out = out_base / (name or preset_name or (params_file.stem if params_file else "render"))
    output = check_output(out)
    return RenderRequest(params=params, output=output, backend=backend, preset=preset_name,
                         params_file=params_file, overrides=overrides, samples=samples, resolution=resolution,
                         sun=sun, sun_strength=strength, seed=seed, threads=threads, blend=blend, object=obj,
                         name=name)


# ---------------------------------------------------------------------------
# rendering in this process (imports bpy)
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
    from .blender.scene import ensure_passes

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


def render_exr(path: Path, scene, guard) -> float:
    """Render ``scene``'s camera and save every pass to the multilayer float EXR ``path``.

    The same file as :func:`layered_brdf_addon.blender.scene.render_to_exr`, written
    after the render under the guard's I/O lock, so an interrupt during the render
    stops it at once and one during the write waits for the file to be complete.
    Returns the render seconds.
    """
    import bpy

    s = scene.render.image_settings
    s.media_type = "MULTI_LAYER_IMAGE"
    s.file_format = "OPEN_EXR_MULTILAYER"
    s.color_depth = "32"
    s.exr_codec = "ZIP"
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=False, scene=scene.name)
    seconds = time.perf_counter() - t0
    guard.check()
    result = bpy.data.images.get("Render Result")
    if result is None:
        raise RuntimeError("Blender produced no render result")
    with guard.io():
        result.save_render(filepath=str(path), scene=scene)
    if not Path(path).exists():
        raise RuntimeError(f"Blender did not write {path}")
    return seconds


def _osl_aov_layers(scene, guard) -> dict[str, dict[str, Any]]:
    """The AOVs of an OSL render (Cycles writes none under OSL), from emission renders.

    Their temporary files go to a private folder that an interrupt removes.
    """
    import shutil
    import tempfile

    import numpy as np

    from .blender import scene as S
    from .blender.material import AOV_LOWER_NORMAL, AOV_THICKNESS, AOV_UPPER_NORMAL

    private = tempfile.mkdtemp(prefix="layered_brdf_aov_")
    cleanup = lambda: shutil.rmtree(private, ignore_errors=True)  # noqa: E731
    guard.add_cleanup(cleanup)
    saved = tempfile.tempdir
    tempfile.tempdir = private
    try:
        p = S.render_passes_osl(scene)
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


def execute_render(req: RenderRequest, command: Sequence[str] | None = None,
                   log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Render ``req`` in this process; write ``STEM.exr``, ``STEM.png`` and ``STEM.json``.

    The three files appear together (written under temporary names, renamed when all
    are complete); SIGINT and SIGTERM stop the render at once and leave no file
    behind (exit code 130).  Returns the sidecar.
    """
    from .outputs import InterruptGuard, StagedOutputs, exr_beauty, replace_exr_layers, write_json, write_png

    t_start = time.perf_counter()
    guard = InterruptGuard().arm()
    try:
        import bpy

        from . import __version__
        from .blender import scene as S
        from .blender.material import apply_layered_material
        guard.arm()
        guard.check()
        if req.blend is not None:
            scene, target = _open_blend(req)
            camera_info, sun_info, centers = _blend_camera_dict(scene), None, None
        else:
            S.reset_blender()
            camera, sun = req.camera(), req.sun_light()
            centers = ((0.0, 0.0, 0.0),)
            spec = S.SceneSpec(camera=camera, sun=sun, centers=centers, samples=req.samples,
                               threads=req.threads, seed=req.seed, osl=(req.backend == "osl"))
            target = S.build_scene(spec)[0]
            scene = bpy.context.scene
            camera_info, sun_info = camera_to_dict(camera), sun_to_dict(sun)
        guard.arm()
        guard.check()
        apply_layered_material(target, req.params, req.backend)
        guard.check()
        paths = req.paths
        with StagedOutputs(paths.all(), guard) as staged:
            exr_tmp = staged.temp(paths.exr)
            t_render = time.perf_counter()
            render_exr(exr_tmp, scene, guard)
            if req.backend == "osl":
                layers = _osl_aov_layers(scene, guard)
                guard.check()
                with guard.io():
                    replace_exr_layers(exr_tmp, layers)
            render_seconds = time.perf_counter() - t_render
            guard.check()
            rgb, alpha = exr_beauty(exr_tmp)
            with guard.io():
                write_png(staged.temp(paths.png), rgb, alpha if scene.render.film_transparent else None)
            guard.check()
            plan = plan_effects(req.params)
            sidecar = {
                "format": "layered-brdf render", "version": 1,
                "scene": "blend" if req.blend else "reference",
                "name": req.name, "preset": req.preset,
                "params_file": req.params_file, "overrides": dict(req.overrides),
                "params": req.params.to_dict(),
                "plan": {**plan.to_dict(), "key": plan.key, "describe": plan.describe()},
                "backend": req.backend,
                "samples": scene.cycles.samples, "seed": scene.cycles.seed,
                "threads": scene.render.threads, "filter_width": scene.cycles.filter_width,
                "camera": camera_info,
                "sun": sun_info,
                "centers": centers, "radius": 1.0 if centers else None,
                "blend": req.blend, "object": req.object,
                "lights": _blend_lights(scene) if req.blend else None,
                "outputs": {"png": paths.png, "exr": paths.exr, "json": paths.json},
                "png_encoding": "8-bit sRGB, Blender's Standard view transform (clipped to [0, 1])",
                "exr_passes": ["Combined", "Normal", "layer_thickness", "lower_normal", "upper_normal"],
                "render_seconds": render_seconds,
                "total_seconds": time.perf_counter() - t_start,
                "bpy_version": bpy.app.version_string, "layered_brdf_version": __version__,
                "host": socket.gethostname(), "python": platform.python_version(),
                "command": list(command) if command is not None else None,
            }
            with guard.io():
                write_json(staged.temp(paths.json), sidecar)
            guard.check()
        if log:
            log(f"wrote {paths.png}, {paths.exr}, {paths.json} (render {render_seconds:.2f} s)")
        return sidecar
    finally:
        guard.disarm()


# ---------------------------------------------------------------------------
# job files
@dataclass
class Job:
    """One entry of a job file: its options, and the validated request or why it is invalid."""

    index: int
    name: str
    options: dict[str, Any]
    request: RenderRequest | None = None
    error: str | None = None


def load_job_file(path: str | os.PathLike, output_dir: str | os.PathLike | None = None) -> list[Job]:
    """Jobs of a TOML or JSON job file.

    TOML: an optional ``[defaults]`` table and ``[[job]]`` tables.  JSON: a list of
    jobs, or ``{"defaults": {...}, "jobs": [...]}``.  Defaults for the reference
    scene's sun do not apply to jobs that render a .blend.  Every job has the options of
    ``render`` (``d_min = 80``, ``sun = [1, -1, 1]``, ...) and an optional ``name``.
    A file that cannot be read or has no list of jobs raises :class:`ParameterError`;
    a job with invalid options is returned with its ``error`` set (it fails alone).
    """
    p = Path(path)
    allowed = "a readable .toml or .json job file with a list of jobs ([[job]] tables)"
    data: Any = _read_table_file(p, "jobfile", allowed)
    defaults: Any = {}
    if isinstance(data, dict):
        extra = set(data) - {"defaults", "job", "jobs"}
        if extra:
            raise ParameterError("jobfile", str(p), f"{allowed}; unknown top-level keys: {', '.join(sorted(extra))}")
        defaults = data.get("defaults", {})
        data = data.get("job", data.get("jobs"))
    if not isinstance(defaults, dict):
        raise ParameterError("defaults", defaults, "a table of render options")
    if not isinstance(data, list) or not data:
        raise ParameterError("jobfile", str(p), allowed)
    jobs: list[Job] = []
    seen: dict[str, int] = {}
    for k, entry in enumerate(data):
        if not isinstance(entry, dict):
            raise ParameterError(f"job[{k}]", entry, "a table of render options")
        inherited = dict(defaults)
        if "blend" in entry or "blend" in defaults:
            for key in REFERENCE_ONLY:  # a .blend uses its own lights
                inherited.pop(key, None)
        options = {**inherited, **entry}
        explicit = options.get("name")
        base = explicit if isinstance(explicit, str) and explicit else (
            options.get("preset") if isinstance(options.get("preset"), str) else f"job{k + 1}")
        name = base
        if name in seen:
            if isinstance(explicit, str) and explicit:
                raise ParameterError("name", explicit, "a name no other job in the file has")
            name = f"{base}-{k + 1}"
        seen[name] = k
        options["name"] = name
        job = Job(k, name, options)
        try:
            job.request = request_from_options(options, base_dir=p.parent.absolute(), output_dir=output_dir)
        except ParameterError as e:
            job.error = str(e)
        jobs.append(job)
    stems: dict[Path, str] = {}
    for job in jobs:
        if job.request is None:
            continue
        other = stems.get(job.request.output)
        if other is not None:
            raise ParameterError("output", str(job.request.output),
                                 f"a different output for each job ('{other}' and '{job.name}' share it)")
        stems[job.request.output] = job.name
    return jobs


# ---------------------------------------------------------------------------
# running jobs in subprocesses
@dataclass
class JobResult:
    """How one job went; ``status`` is ok, invalid, failed, crashed, timeout or cancelled."""

    name: str
    status: str
    seconds: float = 0.0
    outputs: list[str] = field(default_factory=list)
    error: str = ""
    returncode: int | None = None
    command: list[str] = field(default_factory=list)
    render_seconds: float | None = None
    host: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "status": self.status, "seconds": self.seconds, "outputs": self.outputs,
                "error": self.error, "returncode": self.returncode, "command": self.command,
                "render_seconds": self.render_seconds, "host": self.host}


PARENT_ENV = "LAYERED_BRDF_PARENT_PID"


def follow_parent() -> None:
    """In a job's subprocess: get SIGTERM when the runner that started it dies (Linux).

    The runner sets ``LAYERED_BRDF_PARENT_PID``; a child whose parent is already gone
    stops at once.
    """
    expected = os.environ.get(PARENT_ENV)
    if not expected:
        return
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if str(os.getppid()) != expected:
        raise KeyboardInterrupt("the batch runner that started this render is gone")


def _error_from_stderr(stderr: str) -> str:
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for ln in reversed(lines):
        if "error:" in ln:
            return ln.split("error:", 1)[1].strip()
    return lines[-1] if lines else ""


def run_job(name: str, argv: Sequence[str], stem: str, timeout: float | None = None,
            python: str | None = None) -> JobResult:
    """Run ``python -m layered_brdf_addon render ARGV`` in a subprocess and report how it went.

    A job past ``timeout`` seconds gets SIGTERM, then SIGKILL 10 s later; temporary
    files of its outputs are removed whatever happened.  This is the function Dask
    runs on its workers, so it takes and returns plain data.
    """
    cmd = [python or sys.executable, "-m", "layered_brdf_addon", "render", *argv]
    t0 = time.perf_counter()
    status, error = "ok", ""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1", PARENT_ENV: str(os.getpid())})
    try:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.terminate()
            try:
                out, err = proc.communicate(timeout=10.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                out, err = proc.communicate()
            status, error = "timeout", f"no result after {timeout:g} s"
    except BaseException:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        remove_stale_temps(stem)
        raise
    seconds = time.perf_counter() - t0
    rc = proc.returncode
    paths = OutputPaths(Path(stem))
    if status == "ok" and rc != 0:
        if rc < 0:
            detail = _error_from_stderr(err)
            status, error = "crashed", f"killed by signal {-rc}" + (f": {detail}" if detail else "")
        else:
            status, error = ("invalid" if rc == 2 else "failed"), _error_from_stderr(err) or f"exit code {rc}"
    remove_stale_temps(stem)
    render_seconds = None
    if status == "ok":
        missing = [str(p) for p in paths.all() if not p.exists()]
        if missing:
            status, error = "failed", "the render exited 0 but did not write " + ", ".join(missing)
        else:
            try:
                render_seconds = json.loads(paths.json.read_text(encoding="utf-8")).get("render_seconds")
            except (OSError, ValueError):
                render_seconds = None
    outputs = [str(paths.png), str(paths.exr), str(paths.json)] if status == "ok" else []
    return JobResult(name, status, seconds, outputs, error, rc, cmd, render_seconds, socket.gethostname())


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="render", unit="job", file=sys.stderr, disable=not enabled, dynamic_ncols=True)


def run_batch(jobs: Sequence[Job], *, n_jobs: int = 1, scheduler: str | None = None, timeout: float | None = None,
              progress: bool = True) -> list[JobResult]:
    """Render every valid job; invalid ones are reported without running.

    ``scheduler`` (a Dask scheduler address) runs each job as a Dask task on the
    cluster's workers; otherwise ``n_jobs`` > 1 starts a local Dask cluster of that
    many single-threaded worker processes, and 1 runs the jobs one after another.
    Results are in job order.
    """
    results: dict[int, JobResult] = {}
    runnable = [j for j in jobs if j.request is not None]
    use_dask = runnable and (scheduler is not None or n_jobs > 1)
    client, cluster = _connect(scheduler, n_jobs) if use_dask else (None, None)
    bar = _progress(len(jobs), progress)
    try:
        for job in jobs:
            if job.request is None:
                results[job.index] = JobResult(job.name, "invalid", error=job.error or "invalid options")
                bar.update(1)
        if use_dask:
            for job, res in _run_on_dask(runnable, client, timeout=timeout):
                results[job.index] = res
                bar.set_postfix_str(job.name)
                bar.update(1)
        else:
            for job in runnable:
                bar.set_postfix_str(job.name)
                results[job.index] = run_job(job.name, job.request.to_argv(), str(job.request.output), timeout)
                bar.update(1)
    finally:
        bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return [results[j.index] for j in jobs]


def _connect(scheduler: str | None, n_jobs: int):
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as e:
            raise ParameterError("scheduler", scheduler, "the address of a running Dask scheduler, e.g. "
                                 f"tcp://host:8786 ({e.__class__.__name__}: {e})") from None
    import logging
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Pp]ort .* already in use.*")
        cluster = LocalCluster(n_workers=n_jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _run_on_dask(jobs: Sequence[Job], client, *, timeout: float | None):
    """Submit every job as a Dask task; yield ``(job, result)`` as they complete."""
    from dask.distributed import as_completed

    token = uuid.uuid4().hex[:8]
    futures = {}
    try:
        for job in jobs:
            fut = client.submit(run_job, job.name, job.request.to_argv(), str(job.request.output), timeout,
                                key=f"layered-brdf-{token}-{job.index}", pure=False, retries=0)
            futures[fut] = job
        for fut in as_completed(list(futures)):
            job = futures[fut]
            try:
                res = fut.result()
            except Exception as e:  # the worker died or the task could not run
                remove_stale_temps(job.request.output)
                res = JobResult(job.name, "crashed", error=f"{e.__class__.__name__}: {e}")
            yield job, res
    except BaseException:
        client.cancel(list(futures), force=True)
        for job in jobs:
            remove_stale_temps(job.request.output)
        raise


def exit_code(results: Iterable[JobResult]) -> int:
    """0 when every job rendered, else 1."""
    return 0 if all(r.ok for r in results) else 1
