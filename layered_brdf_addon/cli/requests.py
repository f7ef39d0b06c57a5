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
import reprlib
import stat
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ..model import policy
from ..model.params import LOWER_MEDIA, LOWER_MEDIUM_KEYS, PARAM_SPECS, LayeredParams, ParameterError
from ..model.presets import PRESETS, preset
from .staging import OutputPaths, TargetError, check_targets, output_stem

PARAM_NAMES = tuple(s.name for s in PARAM_SPECS)
RUN_OPTIONS = ("name", "preset", "params", "blend", "object", "backend", "samples", "resolution", "sun",
               "sun_strength", "seed", "threads", "output")
REFERENCE_ONLY = ("sun", "sun_strength")  # options of the reference scene only
REFERENCE_SAMPLES = 1
REFERENCE_RESOLUTION = 128
REFERENCE_THREADS = 2
MAX_RESOLUTION = 16384
_BLEND_MAGIC = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")  # plain, gzip, zstd

# Limits on what a params or job file, and each value in it, may be.
MAX_INPUT_BYTES = 1 << 20  # a params or job file: 1 MiB
MAX_TEXT = 4096  # characters of a string value (a path, a name)
MAX_ITEMS = 16  # items of a list value (sun: 3, resolution: 2)
MAX_INT_DIGITS = 18  # digits of an integer value
MAX_NAME = 200  # characters of a name
MAX_STEM_BYTES = 200  # bytes (UTF-8) of an output stem's file name

_SUN_ALLOWED = ("three finite numbers X Y Z, the direction towards the sun, with a length of at least 1e-9 "
                "whose square is finite (|X|, |Y|, |Z| below about 1e154)")
OPTION_ALLOWED = {
    "name": f"a name of 1-{MAX_NAME} characters without '/', '\\' or NUL, not starting with '.'",
    "preset": "one of " + ", ".join(sorted(PRESETS)),
    "params": "the path of a .json or .toml file of parameter values",
    "blend": "the path of a .blend file",
    "object": "the name of the object in the .blend that gets the material",
    "backend": "one of " + ", ".join(policy.BACKENDS),
    "samples": "an integer in [1, 1000000]",
    "resolution": f"N or WxH with integers in [1, {MAX_RESOLUTION}]",
    "sun": _SUN_ALLOWED,
    "sun_strength": "a number in [0, 1e+06]",
    "seed": f"an integer in [0, {2**31 - 1}]",
    "threads": "an integer in [1, 1024]",
    "output": "a file path stem in a writable folder (STEM.png, STEM.exr and STEM.json are written)",
}


# ---------------------------------------------------------------------------
# values in messages, and values too big for any option
class _Shown:
    """A value's short form for an error message: ``repr`` gives it as is (unquoted)."""

    def __init__(self, text: str):
        self.text = text

    def __repr__(self) -> str:
        return self.text


class _ShortRepr(reprlib.Repr):
    """``reprlib`` cut to a message line: 2 levels, 8 items, 60 characters.  An integer of
    more digits than any option takes is named, not printed: a screen of digits says
    less, and Python refuses to print one of over 4300."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxlist, self.maxtuple, self.maxdict, self.maxstring, self.maxother = 2, 8, 8, 8, 60, 60

    def repr_int(self, x: int, level: int) -> str:
        return repr(x) if abs(x) < 10 ** MAX_INT_DIGITS else f"<an integer of more than {MAX_INT_DIGITS} digits>"


_SHORT_REPR = _ShortRepr()


def shown(value: Any) -> Any:
    """``value`` as an error message shows it: its repr cut short, since a file's value
    may be a megabyte of text or lists nested thousands of levels deep."""
    return _Shown(_SHORT_REPR.repr(value))


def short_name(key: Any) -> str:
    """A key of a file as a parameter name in a message (long or odd keys cut)."""
    text = key if isinstance(key, str) else repr(shown(key))
    return text if len(text) <= 60 else text[:57] + "..."


def allowed_for(name: str) -> str:
    """What option or parameter ``name`` allows, for a message."""
    for s in PARAM_SPECS:
        if s.name == name:
            return s.allowed
    return OPTION_ALLOWED.get(name, "a plain value")


def _plain_scalar(value: Any) -> bool:
    """Whether ``value`` is a scalar any validator can take: not a list or table, a text of
    at most :data:`MAX_TEXT` characters, an integer of at most :data:`MAX_INT_DIGITS` digits."""
    if isinstance(value, (list, tuple, dict)):
        return False
    if isinstance(value, str):
        return len(value) <= MAX_TEXT
    return not isinstance(value, int) or abs(value) < 10 ** MAX_INT_DIGITS


def check_plain(name: str, value: Any) -> Any:
    """``value`` if it is a plain value an option may take (a short text, a number that is not
    absurdly long, a flat list of at most :data:`MAX_ITEMS` of those); else
    :class:`ParameterError` naming ``name``.  Checked before the option's own validator,
    so that none has to cope with a megabyte of text, nested lists or a 400-digit integer."""
    items = value if isinstance(value, (list, tuple)) else [value]
    if len(items) > MAX_ITEMS or not all(map(_plain_scalar, items)):
        raise ParameterError(short_name(name), shown(value), allowed_for(name))
    return value


class FileValueError(ParameterError):
    """An invalid value read from a file (a ``--params`` file, a job's ``params``): the
    message names the file and the key, not a command-line option nobody typed."""

    def __init__(self, name: str, value: Any, allowed: str, file: str):
        super().__init__(name, value, allowed)
        self.file = file
        self.args = (f"parameter '{name}' = {value!r} in {file}: allowed {allowed}",)


def file_label(path: Any) -> str:
    """A file's path as the user gave it, for a message (a long one cut at the front)."""
    text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else repr(shown(path))
    return text if len(text) <= 80 else "..." + text[-77:]


def from_file(e: ParameterError, values: Mapping[str, Any], file: str,
              overridden: Iterable[str] = ()) -> ParameterError:
    """``e`` as a :class:`FileValueError` naming ``file`` when the value it names was read
    from it (is one of ``values`` and not ``overridden`` by an option); else ``e``."""
    if isinstance(e, FileValueError) or e.name not in values or e.name in set(overridden):
        return e
    return FileValueError(e.name, e.value, e.allowed, file)


def merged_values(file_values: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """A params file's values with the typed options over them, validated as one set.

    Checked together, a file's ``d_min = 300`` and a typed ``--d-max 400`` make a valid
    range (checked one after the other, the file's value would meet the default ``d_max``).
    A lower medium typed as an option fills its n and k over the file's (as it would over
    a preset's), unless they are typed too.
    """
    values = dict(file_values)
    medium = overrides.get("lower_medium")
    if isinstance(medium, str) and medium in LOWER_MEDIA and medium != "custom":
        for key in LOWER_MEDIUM_KEYS:
            values.pop(key, None)
    values.update(overrides)
    return values


PRESETS_ALLOWED = "preset names among " + ", ".join(PRESETS)


def check_preset_names(names: Sequence[Any]) -> tuple[str, ...]:
    """The presets of ``--presets`` (``gallery``, ``lookdev``): distinct known names; else
    :class:`ParameterError` naming ``presets``, the option as typed."""
    names = list(names)
    if not names or not all(isinstance(n, str) for n in names):
        raise ParameterError("presets", shown(names), PRESETS_ALLOWED)
    if len(set(names)) != len(names):
        raise ParameterError("presets", shown(names), "distinct preset names")
    for name in names:
        if name not in PRESETS:
            raise ParameterError("presets", shown(name), PRESETS_ALLOWED)
    return tuple(names)


def check_name(value: Any, name: str = "name") -> str:
    """A job or render name: used as a file name, so it is a name and not a path."""
    allowed = OPTION_ALLOWED["name"]
    if not isinstance(value, str) or not value.strip() or len(value) > MAX_NAME:
        raise ParameterError(name, shown(value), allowed)
    if any(c in value for c in "/\\\x00") or value.startswith(".") or os.path.isabs(value):
        raise ParameterError(name, shown(value), allowed + " (a name, not a path)")
    return value


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
            argv += ["--blend", str(self.blend), f"--object={self.object}"]
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
            argv.append(f"--name={self.name}")
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
    """Three finite numbers whose direction can be taken: the direction from the scene
    towards the sun.  Refused: non-finite components, a length below 1e-9, and a squared
    length that overflows (the renderer would fall back to straight up)."""
    allowed = _SUN_ALLOWED
    check_plain("sun", value)
    if isinstance(value, str):
        value = value.replace(",", " ").split()
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ParameterError("sun", shown(value), allowed)
    try:
        xyz = tuple(float_option("sun", c) for c in value)
    except ParameterError:
        raise ParameterError("sun", shown(value), allowed) from None
    n2 = math.fsum(c * c for c in xyz)
    if not math.isfinite(n2) or n2 < 1e-18:
        raise ParameterError("sun", shown(value), allowed)
    return xyz  # type: ignore[return-value]


_FILE_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
               (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def read_regular_file(path: str | os.PathLike, name: str, allowed: str, limit: int | None = None,
                      head: int | None = None) -> bytes:
    """The bytes of a regular file (at most ``head`` of them), or :class:`ParameterError`
    naming ``name``: for a file that cannot be opened, one that is not a regular file (a
    FIFO, a device, a folder: never waited on or read), and one over ``limit`` bytes."""
    p = Path(path)
    try:  # O_NONBLOCK: opening a FIFO does not wait for a writer
        fd = os.open(p, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise ParameterError(name, str(p), f"{allowed} ({e.strerror or e})") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((k for test, k in _FILE_KINDS if test(mode)), "not a regular file")
            raise ParameterError(name, str(p), f"{allowed} (a regular file; this is {kind})")
        os.set_blocking(fd, True)
        want = head if head is not None else (limit + 1 if limit is not None else -1)
        chunks, total = [], 0
        while want < 0 or total < want:
            chunk = os.read(fd, 1 << 16 if want < 0 else min(1 << 16, want - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    except OSError as e:
        raise ParameterError(name, str(p), f"{allowed} ({e.strerror or e})") from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if limit is not None and head is None and len(data) > limit:
        raise ParameterError(name, str(p), f"{allowed} (at most {limit // (1 << 20)} MiB; this file is larger)")
    return data


def read_table_file(path: str | os.PathLike, name: str, allowed: str) -> Any:
    """The contents of a ``.toml`` or ``.json`` file; :class:`ParameterError` naming ``name``
    (with ``allowed``) if it cannot be read or parsed, is not a regular file or is larger
    than :data:`MAX_INPUT_BYTES`.

    The standard parsers read it; the size cap bounds their work.  A file nested deeper
    than they follow (their RecursionError: some hundreds of levels of TOML, about 1,000
    of JSON on Python 3.11 and 10,000 on 3.13) is refused as a whole, and so is one with
    an integer of more digits than Python converts (4300): no option takes either."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ParameterError(name, str(p), allowed)
    data = read_regular_file(p, name, allowed, limit=MAX_INPUT_BYTES)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise ParameterError(name, str(p), f"{allowed} (UnicodeDecodeError: {e})") from None
    try:
        return tomllib.loads(text) if suffix == ".toml" else json.loads(text)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as e:
        raise ParameterError(name, str(p), f"{allowed} ({str(e)[:200]})") from None
    except RecursionError:
        raise ParameterError(name, str(p), f"{allowed} (values nested deeper than can be read)") from None
    except ValueError:  # the parsers' only other error: int() refuses a literal of over 4300 digits
        raise ParameterError(name, str(p), f"{allowed} (an integer too long to read; options take at most "
                             f"{MAX_INT_DIGITS} digits)") from None


def load_params_file(path: str | os.PathLike, label: str | None = None) -> dict[str, Any]:
    """Parameter values from a ``.json`` or ``.toml`` file.

    The file holds ``{name: value}``; a ``params`` table inside it is used instead
    when present, so a render's sidecar can be given to re-render its material.  An
    unknown key or an absurd value is a :class:`FileValueError` naming the file as
    ``label`` (default: ``path``) and the key.
    """
    p = Path(path)
    label = str(p) if label is None else label
    allowed = "a readable .json or .toml file of parameter values (a regular file of at most 1 MiB)"
    data = read_table_file(p, "params", allowed)
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise ParameterError("params", str(p), allowed + " (a table of name = value)")
    for key, value in data.items():
        if key not in PARAM_NAMES:
            raise FileValueError(short_name(key), shown(value), "a known parameter name: " + ", ".join(PARAM_NAMES),
                                 label)
        try:
            check_plain(key, value)
        except ParameterError as e:
            raise from_file(e, data, label) from None
    return data


def check_blend_file(path: str | os.PathLike) -> Path:
    """Raise :class:`ParameterError` unless ``path`` looks like a .blend Blender can read."""
    p = Path(path)
    allowed = "a readable .blend file"
    head = read_regular_file(p, "blend", allowed, head=7)
    if not any(head.startswith(m) for m in _BLEND_MAGIC):
        raise ParameterError("blend", str(p), f"{allowed} (this file is not a .blend)")
    return p.resolve()


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether writing ``a`` would replace ``b``: the same resolved path, or (both existing)
    the same file (a hard link, a symlink)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


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
    naming the first invalid option, or a :class:`FileValueError` naming the params
    file and the key when the invalid value was read from that file.
    """
    opts = {k: v for k, v in options.items() if v is not None}
    for key in opts:
        if key not in RUN_OPTIONS and key not in PARAM_NAMES:
            raise ParameterError(short_name(key), shown(opts[key]), "a render option (" + ", ".join(RUN_OPTIONS)
                                 + ") or a parameter name (" + ", ".join(PARAM_NAMES) + ")")
        check_plain(key, opts[key])
    base = Path(base_dir) if base_dir is not None else None
    name = opts.get("name")
    if name is not None:
        check_name(name)

    preset_name = opts.get("preset")
    if preset_name is not None and (not isinstance(preset_name, str) or preset_name not in PRESETS):
        raise ParameterError("preset", shown(preset_name), "one of " + ", ".join(sorted(PRESETS)))
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
        except ParameterError as e:
            raise from_file(e, file_values, label, overridden=overrides) from None
        overrides = {k: getattr(params, k) for k in overrides}

    backend = opts.get("backend", "nodes")
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
        if isinstance(out, (str, os.PathLike)) and "\x00" not in str(out) \
                and not Path(out).expanduser().is_absolute():
            out = out_base / Path(out)
    else:
        out = out_base / (name or preset_name or (params_file.stem if params_file else "render"))
    inputs = [(label, p) for label, p in (("the params file", params_file), ("the .blend", blend)) if p is not None]
    output = check_output(out, inputs=[*inputs, *extra_inputs], confine_to=out_base if confine else None)
    return RenderRequest(params=params, output=output, backend=backend, preset=preset_name,
                         params_file=params_file, overrides=overrides, samples=samples, resolution=resolution,
                         sun=sun, sun_strength=strength, seed=seed, threads=threads, blend=blend, object=obj,
                         name=name)
