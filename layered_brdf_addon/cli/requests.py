"""Validating a render request without Blender.

A request is the set of options of ``python -m layered_brdf_addon render``, as a mapping
(from the command line or a job file's entry).  :func:`request_from_options` checks it
and returns a :class:`RenderRequest`, or raises :class:`ParameterError` naming the first
invalid option.  Nothing here imports bpy.
"""
from __future__ import annotations

import json
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..model import policy
from ..model.params import PARAM_SPECS, LayeredParams, ParameterError
from ..model.presets import PRESETS, preset
from .staging import OutputPaths, output_stem

PARAM_NAMES = tuple(s.name for s in PARAM_SPECS)
RUN_OPTIONS = ("name", "preset", "params", "blend", "object", "backend", "samples", "resolution", "sun",
               "sun_strength", "seed", "threads", "output")
REFERENCE_ONLY = ("sun", "sun_strength")  # options of the reference scene only
REFERENCE_SAMPLES = 1
REFERENCE_RESOLUTION = 128
REFERENCE_THREADS = 2
MAX_RESOLUTION = 16384
_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd


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
        from ..model.sphere import OrthoCamera

        w, h = self.resolution or (REFERENCE_RESOLUTION, REFERENCE_RESOLUTION)
        return OrthoCamera(width=w, height=h)

    def sun_light(self):
        """The reference scene's zero-angle sun (the model's default where not given)."""
        from ..model.sphere import Sun

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


def read_table_file(path: str | os.PathLike, name: str, allowed: str) -> Any:
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
    data = read_table_file(p, "params", allowed)
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
    policy.check_backend(backend, params.lobe)

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
