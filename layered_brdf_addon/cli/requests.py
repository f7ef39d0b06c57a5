"""Validating a render request without Blender.

A request is the set of options of ``python -m layered_brdf_addon render``, as a mapping
(from the command line or a job file's entry).  :func:`request_from_options` checks it
and returns a :class:`RenderRequest`, or raises :class:`ParameterError` naming the first
invalid option.  Nothing here imports bpy.
"""
from __future__ import annotations

import json

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ..model import policy
from ..model.params import LayeredParams, ParameterError
from ..model.presets import preset
from ..io.staging import OutputPaths, TargetError, check_targets, output_stem
from ..model.sphere import OrthoCamera, Sun
from .input_files import check_blend_file, file_label, from_file, load_params_file, merged_values, same_file
from .option_table import job_options, options_of, read_options, scene_options_of
from .option_values import (MAX_STEM_BYTES, MAX_TEXT, OPTION_ALLOWED, PARAM_NAMES, check_plain, option_flag,
                            short_name, shown)


def run_options() -> tuple[str, ...]:
    """The options of ``render`` that a request (and a job) holds, as the option table declares them."""
    return job_options()


def reference_only() -> tuple[str, ...]:
    """The options of the reference scene only (a .blend has its own lights)."""
    return tuple(s.name for s in options_of("render") if s.reference_only)
REFERENCE_SAMPLES = 1
REFERENCE_RESOLUTION = 128
REFERENCE_THREADS = 2


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
    scene_options: Mapping[str, Any] = field(default_factory=dict)  # every table option given, as read

    @property
    def paths(self) -> OutputPaths:
        return OutputPaths(self.output)

    def camera(self) -> OrthoCamera:
        """The reference scene's orthographic camera (one unit sphere, a 10% margin)."""
        w, h = self.resolution or (REFERENCE_RESOLUTION, REFERENCE_RESOLUTION)
        return OrthoCamera(width=w, height=h)

    def sun_light(self) -> Sun:
        """The reference scene's zero-angle sun (the model's default where not given)."""
        default = Sun()
        return Sun(direction=self.sun or default.direction,
                   strength=default.strength if self.sun_strength is None else self.sun_strength)

    def to_argv(self) -> list[str]:
        """Arguments of ``render`` that reproduce this request (absolute paths): each option of the table
        (the request's value where it has a field, else as read), then the parameters given."""
        argv: list[str] = []
        for spec in options_of("render"):
            if not spec.job:
                continue
            attr = spec.field or spec.name
            value = getattr(self, attr) if attr in self.__dataclass_fields__ else self.scene_options.get(spec.name)
            if value is not None:
                argv += spec.to_argv(value)
        for name, value in self.overrides.items():
            spec = LayeredParams.spec(name)
            flag = option_flag(name)
            if spec.kind == "bool":
                argv.append(flag if value else "--no-" + flag[2:])
            elif spec.kind == "stack":
                argv += [flag, json.dumps(value.to_dict() if hasattr(value, "to_dict") else value)]
            else:
                argv += [flag, repr(value) if isinstance(value, float) else str(value)]
        return argv


def check_output(value: Any, *, inputs: Iterable[tuple[str, Path]] = (), confine_to: str | os.PathLike | None = None,
                 name: str = "output") -> Path:
    """The absolute stem of an output set whose three files can be written; else
    :class:`ParameterError` naming ``name``.

    Checked before anything renders: the stem's file name (at most
    :data:`MAX_STEM_BYTES` bytes, not hidden), every file of the set
    (:func:`~.staging.check_targets`: no folder in the way, the folder writable, names
    that fit), that no file of the set is one of ``inputs`` (``(label, path)``), and with
    ``confine_to`` that the set stays inside that folder (symlinks resolved; the stem is
    then returned resolved).
    """
    allowed = OPTION_ALLOWED["output"]
    if not isinstance(value, (str, os.PathLike)) or not str(value).strip() or "\x00" in str(value) \
            or len(str(value)) > MAX_TEXT:
        raise ParameterError(name, shown(value), allowed)
    stem = output_stem(Path(value).expanduser()).absolute()
    if confine_to is not None:
        root = os.path.realpath(confine_to)
        folder = os.path.realpath(stem.parent)
        if os.path.commonpath([root, folder]) != root:
            raise ParameterError(name, str(value), f"a path inside the output folder {root} "
                                 f"(this one resolves to {os.path.join(folder, stem.name)})")
        stem = Path(folder) / stem.name
    if stem.name in ("", ".", "..") or stem.name.startswith("."):
        raise ParameterError(name, str(value), allowed + "; a stem whose name does not start with '.' "
                             "(hidden names are the temporary files')")
    if len(os.fsencode(stem.name)) > MAX_STEM_BYTES:
        raise ParameterError(name, shown(str(value)), allowed + f"; a stem whose name is at most {MAX_STEM_BYTES} "
                             f"bytes (this one has {len(os.fsencode(stem.name))})")
    if stem.is_dir():
        raise ParameterError(name, str(value), allowed + "; it names a folder")
    paths = OutputPaths(stem)
    try:
        check_targets(paths.all())
    except TargetError as e:
        raise ParameterError(name, str(value), f"{allowed}; {e}") from None
    for label, p in inputs:
        for f in paths.all():
            if same_file(f, p):
                raise ParameterError(name, str(value), f"{allowed}, none of them an input file "
                                     f"({f.name} would replace {label} {p})")
    return stem


def _resolve(path: Any, base_dir: Path | None, name: str) -> Path:
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise ParameterError(name, path, "a file path")
    p = Path(path).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    return p


def request_from_options(options: Mapping[str, Any], *, base_dir: str | os.PathLike | None = None,
                         output_dir: str | os.PathLike | None = None, confine: bool = False,
                         extra_inputs: Sequence[tuple[str, Path]] = ()) -> RenderRequest:
    """Validate a job's options (the ``render`` options, with ``_`` in names) without Blender.

    ``params`` and ``blend`` paths are relative to ``base_dir`` (default: the current
    folder); ``output`` is relative to ``output_dir`` (default: the current folder) and
    defaults to ``output_dir/NAME`` with NAME the job's name, preset or ``render``.
    With ``confine`` the outputs must stay inside ``output_dir`` (a batch's jobs).  No
    output may replace the params file, the .blend or one of ``extra_inputs``.  Every
    output target is checked (:func:`check_output`).  Raises :class:`ParameterError`
    naming the first invalid option, or a :class:`~.input_files.FileValueError` naming the params
    file and the key when the invalid value was read from that file.
    """
    opts = {k: v for k, v in options.items() if v is not None}
    for key in opts:
        if key not in run_options() and key not in PARAM_NAMES:
            raise ParameterError(short_name(key), shown(opts[key]), "a render option (" + ", ".join(run_options())
                                 + ") or a parameter name (" + ", ".join(PARAM_NAMES) + ")")
        check_plain(key, opts[key])
    base = Path(base_dir) if base_dir is not None else None
    given = read_options("render", opts)  # each value checked alone; together and on disk below
    name, preset_name = given.get("name"), given.get("preset")
    params = preset(preset_name) if preset_name else LayeredParams()
    params_file, file_values, label = None, {}, ""
    if "params" in opts:
        params_file = _resolve(opts["params"], base, "params").absolute()
        label = file_label(opts["params"])
        file_values = load_params_file(params_file, label)
    overrides = {k: opts[k] for k in PARAM_NAMES if k in opts}
    if file_values or overrides:
        try:
            params = LayeredParams.from_dict(merged_values(file_values, overrides), base=params)
            params.check_used(overrides)
        except ParameterError as e:
            raise from_file(e, file_values, label, overridden=overrides) from None
        overrides = {k: getattr(params, k) for k in overrides}

    scene = {s.name: given[s.name] for s in scene_options_of("render") if s.name in given}
    backend = scene.get("backend", "nodes")
    try:
        policy.check_backend(backend, params.lobe)
    except ParameterError as e:
        raise from_file(e, file_values, label, overridden=overrides) from None

    blend = obj = None
    if "blend" in opts:
        blend = check_blend_file(_resolve(opts["blend"], base, "blend"))
        obj = opts.get("object")
        if not isinstance(obj, str) or not obj:
            raise ParameterError("object", shown(obj), "the name of the object in the .blend that gets the material")
        for key in reference_only():
            if key in opts:
                raise ParameterError(key, opts[key], "no value with a .blend (the file's own lights are used)")
    elif "object" in opts:
        raise ParameterError("object", opts["object"], "no value without a .blend (the reference scene has one sphere)")

    samples, threads = scene.get("samples"), scene.get("threads")
    resolution = given.get("resolution")
    if blend is None:
        samples = REFERENCE_SAMPLES if samples is None else samples
        resolution = resolution or (REFERENCE_RESOLUTION, REFERENCE_RESOLUTION)
        threads = REFERENCE_THREADS if threads is None else threads

    out_base = Path(output_dir) if output_dir is not None else Path.cwd()
    if "output" in opts:
        out = opts["output"]
        if isinstance(out, (str, os.PathLike)) and "\x00" not in str(out) \
                and not Path(out).expanduser().is_absolute():
            out = out_base / Path(out)
    else:
        out = out_base / (name or preset_name or (params_file.stem if params_file else "render"))
    inputs = [(label, p) for label, p in (("the params file", params_file), ("the .blend", blend)) if p is not None]
    output = check_output(out, inputs=[*inputs, *extra_inputs], confine_to=out_base if confine else None)
    return RenderRequest(params=params, output=output, backend=backend, preset=preset_name,
                         params_file=params_file, overrides=overrides, samples=samples, resolution=resolution,
                         sun=scene.get("sun"), sun_strength=scene.get("sun_strength"), seed=scene.get("seed", 0),
                         threads=threads, blend=blend, object=obj, name=name, scene_options=scene)
