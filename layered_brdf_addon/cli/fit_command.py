"""``layered-brdf fit``: the layered material that reproduces a target.

A target is one of:

* a reference-sphere render of ``layered-brdf render`` (``TARGET``: its sidecar ``STEM.json``,
  or ``STEM``, ``STEM.exr`` or ``STEM.png`` with the sidecar beside it): the EXR's Combined
  pass, seen by the sidecar's camera under its sun; one sphere of a gallery with ``--tile``;
* a table of a smooth film's mirror reflectance (``--reflectance FILE.csv``): rows of angle,
  wavelength or channel, and reflectance;
* a Principled BSDF material of a .blend (``--principled FILE.blend --material NAME``),
  rendered by Cycles on the reference sphere under a few suns.

The fit (:func:`layered_brdf_addon.fit.solve.fit`) runs in numpy from a start (a preset, a
params file, their modes overridden by options) and writes, together and only once it is
done:

* ``OUT.json``: the fitted parameters in the format of the panel's user presets (``format``,
  ``version``, ``name``, ``params``), which ``render --params OUT.json`` reads too, with a
  ``fit`` record: the target, the start, the free parameters, the mean CIEDE2000, the model
  evaluations, the seconds and the starts tried;
* ``OUT.png``: target | fit | CIEDE2000 per pixel (a sphere target, one row per view), or a
  swatch per angle, target above fit, and the reflectance curves (a reflectance table).

Everything the command is given is checked before the fit: invalid input is exit code 2
with nothing written; an interrupt leaves nothing behind (exit code 130).  Nothing here
imports bpy except the ``--principled`` path.
"""
from __future__ import annotations

import argparse
import csv
import io
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .. import __version__
from ..fit.environment import DEFAULT_HDRIS
from ..model.params import PARAM_SPECS, LayeredParams, ParameterError
from ..model.presets import PRESETS, preset
from .options import EXIT_OK, blender_output, param_metavar
from .requests import (MAX_INPUT_BYTES, MAX_STEM_BYTES, MAX_TEXT, file_label, from_file, int_option,
                       load_params_file, merged_values, option_flag, read_regular_file, read_table_file,
                       same_file, shown)
from .staging import OutputPaths, TargetError, check_targets, output_stem

# The start when neither --start nor --params is given, by the target's kind: the preset whose
# fits of test targets came closest (layered renders of physical and paper films; Principled
# BSDF materials: a dielectric with and without a thin film, a metal with one).  A Principled
# BSDF's film is uniform: its start's thickness goes by height, which a fit can make uniform.
DEFAULT_STARTS = {"render": ("soap_bubble", {}), "principled": ("glazed_clay", {"thickness_mode": "height"}),
                  "reflectance": ("anodised_titanium", {})}
# The start's modes an option may override (the options of ``render`` for them).
MODE_OPTIONS = ("thickness_mode", "normal_mode", "optics", "lower_medium", "base_layer", "accuracy")
STARTS_RANGE = (1, 10)
STEPS_PER_START = 40  # the optimiser's steps from each start
PRINCIPLED_SIZE = 96
PRINCIPLED_SAMPLES = 1
PRINCIPLED_HDRIS = DEFAULT_HDRIS
PRESET_FORMAT = "layered_brdf.preset"  # the panel's user presets (blender/user_presets.py)
PRESET_FORMAT_VERSION = 1
DEFAULT_OUTPUT_DIR = Path("out")

TARGET_ALLOWED = ("a reference-sphere render of 'layered-brdf render': its sidecar STEM.json, or STEM, "
                  "STEM.exr or STEM.png with the sidecar and the EXR beside it")
SOURCE_ALLOWED = ("exactly one target: TARGET (a render's sidecar), --reflectance FILE.csv or "
                  "--principled FILE.blend")
REFLECTANCE_ALLOWED = ("a readable CSV file (at most 1 MiB) whose header names the columns angle (degrees from "
                       "the normal, in [0, 90)), wavelength (nm) or channel (r, g, b), and reflectance (a "
                       "fraction in [0, 1]), one row per angle and wavelength or channel")
OUTPUT_ALLOWED = "a file path stem in a writable folder (STEM.json and STEM.png are written)"


# ---------------------------------------------------------------------------
# the sub-command's options
def add_parser(sub) -> argparse.ArgumentParser:
    """The ``fit`` sub-command of ``sub`` (the parser's sub-parsers)."""

    f = sub.add_parser(
        "fit", help="fit a layered material to a render, a reflectance table or a Principled BSDF material",
        description="Fit the parameters of a layered material to a target: a reference-sphere render "
        "(TARGET), a film's mirror reflectance (--reflectance) or a Principled BSDF material rendered on the "
        "reference sphere (--principled).  Writes OUT.json (the parameters, a user preset of the panel that "
        "'render --params' reads too, with a record of the fit) and OUT.png (target, fit and their CIEDE2000 "
        "difference), together and only once the fit is done.")
    tgt = f.add_argument_group("target (exactly one)")
    tgt.add_argument("target", nargs="?", default=None, metavar="TARGET",
                     help="a reference-sphere render: its sidecar STEM.json, or STEM, STEM.exr or STEM.png "
                     "(the sidecar and the EXR beside it); the EXR's Combined pass is fitted")
    tgt.add_argument("--tile", default=None, metavar="NAME|INDEX",
                     help="the sphere of a gallery render to fit: its preset name or its index from 0")
    tgt.add_argument("--reflectance", default=None, metavar="FILE.csv",
                     help="a film's mirror reflectance: a CSV whose header names angle (degrees), wavelength "
                     "(nm) or channel (r, g, b) and reflectance (0-1); e.g. 'angle_deg,wavelength_nm,reflectance'")
    tgt.add_argument("--principled", default=None, metavar="FILE.blend",
                     help="a .blend holding the Principled BSDF material --material, rendered by Cycles on the "
                     "reference sphere under three suns")
    tgt.add_argument("--material", default=None, metavar="NAME", help="the material of --principled")
    tgt.add_argument("--size", default=None, metavar="PX",
                     help=f"--principled: pixels of each render (default {PRINCIPLED_SIZE})")
    tgt.add_argument("--samples", default=None, metavar="N",
                     help=f"--principled: samples per pixel (default {PRINCIPLED_SAMPLES}, exact under a sun)")
    tgt.add_argument("--hdri", nargs="+", default=None, metavar="NAME",
                     help="--principled: Blender's bundled HDRIs the material is also rendered under and fitted "
                          f"to (default {' '.join(PRINCIPLED_HDRIS)}; 'none': the suns only)")
    st = f.add_argument_group("start and free parameters")
    st.add_argument("--start", default=None, metavar="PRESET",
                    help="the preset the fit starts from, whose modes (optics, lower medium, normals, thickness "
                    "pattern) it keeps: they decide what the fit can reach, so choose the preset of the target's "
                    f"kind of material. Default: {DEFAULT_STARTS['render'][0]} for TARGET, "
                    f"{DEFAULT_STARTS['principled'][0]} with --thickness-mode height for --principled, "
                    f"{DEFAULT_STARTS['reflectance'][0]} for --reflectance (the presets that came closest on test "
                    "targets of each kind). One of " + ", ".join(PRESETS))
    st.add_argument("--params", default=None, metavar="FILE",
                    help="start from the parameter values of a .json or .toml file (a render's sidecar or an "
                    "earlier fit's OUT.json work too), over --start when given")
    st.add_argument("--vary", nargs="+", default=None, metavar="NAME",
                    help="the parameters the fit may change (default: the continuous parameters the start's "
                    "modes use; for --reflectance the layer's indices and thickness)")
    st.add_argument("--starts", default=None, metavar="N",
                    help=f"thickness orders tried besides the start, an integer in [{STARTS_RANGE[0]}, "
                    f"{STARTS_RANGE[1]}] (default 3)")
    for spec in PARAM_SPECS:
        if spec.name in MODE_OPTIONS:
            st.add_argument(option_flag(spec.name), dest=spec.name, choices=spec.options, default=None,
                            metavar=param_metavar(spec), help=mode_help(spec))
    out = f.add_argument_group("output")
    out.add_argument("--output", default=None, metavar="OUT",
                     help="output stem: writes OUT.json and OUT.png (default out/NAME-fit, NAME the target's)")
    out.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    out.add_argument("--verbose", action="store_true", help="--principled: show Blender's own log")
    return f


def mode_help(spec) -> str:
    """Help of a mode option: what it overrides, the parameter's description."""
    text = f"the start's {spec.label.lower()}, instead of its own: {spec.description}"
    if spec.name == "thickness_mode":
        text += "; a noise is fitted through the colours' statistics, a height pixel by pixel"
    return text.replace("%", "%%")


# ---------------------------------------------------------------------------
# the target
@dataclass
class Source:
    """Which target the options name, before it is read: its kind, its files and a name."""

    kind: str  # "render", "reflectance" or "principled"
    path: Path
    name: str
    inputs: list[tuple[str, Path]] = field(default_factory=list)  # files no output may replace


@dataclass
class LoadedTarget:
    """A target ready to fit (:mod:`layered_brdf_addon.fit.targets`) and what the record says of it."""

    target: Any
    record: dict[str, Any]


def source_of(ns: argparse.Namespace) -> Source:
    """The target the options name; :class:`ParameterError` unless exactly one is named and
    the options that go with it are given with it only."""
    given = [k for k in ("target", "reflectance", "principled") if getattr(ns, k) is not None]
    if len(given) != 1:
        raise ParameterError("target", shown([getattr(ns, k) for k in given]) if given else None, SOURCE_ALLOWED)
    kind = given[0]
    if ns.tile is not None and kind != "target":
        raise ParameterError("tile", ns.tile, "no value without TARGET (a gallery render's sphere)")
    if kind != "principled":
        for name in ("material", "size", "samples", "hdri"):
            if getattr(ns, name) is not None:
                raise ParameterError(name, getattr(ns, name), "no value without --principled")
    if kind == "target":
        return _render_source(ns.target)
    if kind == "reflectance":
        p = _path(ns.reflectance, "reflectance", REFLECTANCE_ALLOWED)
        return Source("reflectance", p, p.stem, [("the reflectance table", p)])
    p = _path(ns.principled, "principled", "the path of a .blend file")
    if not isinstance(ns.material, str) or not ns.material.strip():
        raise ParameterError("material", ns.material, "the name of a material of the .blend holding a "
                             "Principled BSDF (with --principled)")
    return Source("principled", p, ns.material, [("the .blend", p)])


def _path(value: Any, name: str, allowed: str) -> Path:
    if not isinstance(value, str) or not value.strip() or "\x00" in value or len(value) > MAX_TEXT:
        raise ParameterError(name, shown(value), allowed)
    return Path(value).expanduser()


def _render_source(value: Any) -> Source:
    p = _path(value, "target", TARGET_ALLOWED)
    side = p if p.suffix.lower() == ".json" else OutputPaths(output_stem(p)).json
    paths = OutputPaths(side.with_suffix(""))
    return Source("render", side, paths.stem.name,
                  [("the target's sidecar", paths.json), ("the target's EXR", paths.exr),
                   ("the target's PNG", paths.png)])


SCENE_REFUSALS = {
    "blend": "a render of a .blend (--blend), whose geometry and lights numpy does not know",
    "lookdev": "a look-dev sheet (a shader ball under an HDRI)",
}


def load_render_target(source: Source, tile: Any) -> LoadedTarget:
    """The EXR's Combined pass of a reference-sphere render (or one sphere of a gallery), seen
    by the sidecar's camera under its sun; :class:`ParameterError` naming ``target`` (or
    ``tile``) when it cannot be fitted."""
    from ..fit.targets import SphereTarget, SphereView, TargetError as FitTargetError
    from .sidecar import SIDECAR_FORMAT, scene_from_sidecar

    label = file_label(source.path)
    data = read_table_file(source.path, "target", TARGET_ALLOWED)

    def refuse(why: str) -> ParameterError:
        return ParameterError("target", label, f"{TARGET_ALLOWED} ({why})")

    if not isinstance(data, dict) or data.get("format") != SIDECAR_FORMAT:
        raise refuse(f"{label} is not the sidecar of a layered-brdf render")
    kind = data.get("scene")
    if kind not in ("reference", "gallery"):
        what = SCENE_REFUSALS.get(kind, f"a sidecar of scene {shown(kind)!r}")
        raise refuse(f"only reference-sphere renders can be reproduced in numpy; this is {what}")
    try:
        scene = scene_from_sidecar(data)
    except (KeyError, TypeError, ValueError, ParameterError) as e:
        raise refuse(f"its camera, sun or spheres cannot be read: {e}") from None
    sphere, tile_name = _sphere_of(data, tile, len(scene.centers))
    exr = OutputPaths(source.path.with_suffix("")).exr
    rgb = _read_beauty(exr, refuse)
    w, h = scene.camera.width, scene.camera.height
    if rgb.shape[:2] != (h, w):
        raise refuse(f"its EXR is {rgb.shape[1]}x{rgb.shape[0]} pixels where the sidecar's camera renders {w}x{h}")
    view = SphereView(rgb, scene.camera, scene.sun, scene.centers, sphere)
    _check_finite(view, refuse)
    try:
        target = SphereTarget([view])
    except FitTargetError as e:
        raise refuse(str(e)) from None
    record = {"kind": "render", "sidecar": source.path.absolute(), "exr": exr.absolute(), "scene": kind,
              "tile": tile_name, "size": [w, h], "pixels": int(len(target.observed))}
    return LoadedTarget(target, record)


def _sphere_of(data: dict, tile: Any, count: int) -> tuple[int, str | None]:
    """The index of the sphere to fit, and its tile's name in a gallery."""
    if data.get("scene") == "reference":
        if tile is not None:
            raise ParameterError("tile", tile, "no value for a reference render (it holds one sphere)")
        return 0, None
    names = [t.get("name") if isinstance(t, dict) else None for t in data.get("tiles", [])]
    allowed = f"a tile of the gallery: a name among {', '.join(map(str, names))} or an index in [0, {count - 1}]"
    if tile is None:
        raise ParameterError("tile", None, allowed + " (a gallery holds several spheres: --tile chooses one)")
    if tile in names:
        return names.index(tile), tile
    try:
        k = int(tile)
    except (TypeError, ValueError):
        raise ParameterError("tile", shown(tile), allowed) from None
    if not 0 <= k < min(count, len(names) or count):
        raise ParameterError("tile", shown(tile), allowed)
    return k, names[k] if k < len(names) else None


def _read_beauty(exr: Path, refuse: Callable[[str], ParameterError]) -> np.ndarray:
    from .codecs import exr_beauty, muted_stderr, read_complete_exr_layers

    if not exr.is_file():
        raise refuse(f"its EXR {file_label(exr)} is missing: the target image is the EXR's Combined pass")
    try:
        with muted_stderr():
            rgb, _ = exr_beauty(exr, read_complete_exr_layers(exr))
    except Exception as e:
        raise refuse(f"its EXR {file_label(exr)} cannot be read: {e.__class__.__name__}: {e}") from None
    return rgb


def _check_finite(view, refuse: Callable[[str], ParameterError]) -> None:
    from ..model.sphere import sphere_geometry

    geo = sphere_geometry(view.camera, view.centers)
    pixels = np.asarray(view.image)[geo.sphere == view.sphere][:, :3]
    bad = int(np.count_nonzero(~np.all(np.isfinite(pixels), axis=-1)))
    if bad:
        raise refuse(f"{bad} of the sphere's {len(pixels)} pixels in its EXR are NaN or infinite")


# --- reflectance tables ----------------------------------------------------
# What a column of a reflectance table may be called (lower case, letters only, a unit
# such as "deg", "nm", "(degrees)" or "[nm]" taken off).
COLUMN_NAMES = {
    "angle": ("angle", "theta", "aoi", "incidence", "angleofincidence", "incidenceangle"),
    "wavelength": ("wavelength", "lambda", "wl"),
    "channel": ("channel", "colour", "color", "band"),
    "reflectance": ("reflectance", "reflectivity", "refl", "r"),
}
UNIT_SUFFIXES = ("degrees", "degree", "deg", "nanometres", "nanometers", "nm")


def column_role(header: str) -> str | None:
    """What a header cell names: ``angle``, ``wavelength``, ``channel``, ``reflectance`` or None."""
    text = re.sub(r"[\(\[].*?[\)\]]", "", header.strip().lower())
    key = re.sub(r"[^a-z]", "", text)
    for suffix in UNIT_SUFFIXES:
        if key.endswith(suffix) and key != suffix:
            key = key[: -len(suffix)]
            break
    return next((role for role, names in COLUMN_NAMES.items() if key in names), None)


def reflectance_rows(text: str) -> tuple[list[tuple[str, str, str]], list[int]]:
    """The (angle, wavelength or channel, reflectance) cells of a CSV table and each row's line
    number; ValueError saying what is wrong with the header or a row.  Blank lines and lines
    starting with ``#`` are skipped; the delimiter is a comma, a semicolon or a tab."""
    lines = [(n, line) for n, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ValueError("the file is empty: no header and no rows")
    delimiter = max(",;\t", key=lines[0][1].count)
    reader = csv.reader(io.StringIO("\n".join(line for _, line in lines)), delimiter=delimiter)
    header = next(reader)
    columns: dict[str, int] = {}
    for i, cell in enumerate(header):
        role = column_role(cell)
        if role is not None and role in columns:
            raise ValueError(f"line {lines[0][0]}: two columns name the {role}")
        if role is not None:
            columns[role] = i
    if "wavelength" in columns and "channel" in columns:
        raise ValueError(f"line {lines[0][0]}: a wavelength and a channel column; a table has one of them")
    where = columns.get("wavelength", columns.get("channel"))
    missing = [r for r, have in (("angle", "angle" in columns), ("wavelength or channel", where is not None),
                                 ("reflectance", "reflectance" in columns)) if not have]
    if missing:
        raise ValueError(f"line {lines[0][0]}: the header {shown(header)} names no {' and no '.join(missing)} "
                         "column")
    need = max(columns.values()) + 1
    rows, numbers = [], []
    for (n, _), cells in zip(lines[1:], reader):
        if len(cells) < need:
            raise ValueError(f"line {n}: {len(cells)} cells where the header names {need} columns")
        rows.append((cells[columns["angle"]], cells[where].strip(), cells[columns["reflectance"]]))
        numbers.append(n)
    return rows, numbers


def load_reflectance_target(source: Source) -> LoadedTarget:
    """A reflectance table as a :class:`~layered_brdf_addon.fit.targets.ReflectanceTarget`;
    :class:`ParameterError` naming ``reflectance`` and the line when it cannot be fitted."""
    from ..fit.targets import ReflectanceTarget, TargetError as FitTargetError

    label = file_label(source.path)
    data = read_regular_file(source.path, "reflectance", REFLECTANCE_ALLOWED, limit=MAX_INPUT_BYTES)
    try:
        rows, numbers = reflectance_rows(data.decode("utf-8-sig"))
    except UnicodeDecodeError as e:
        raise ParameterError("reflectance", label, f"{REFLECTANCE_ALLOWED} (not UTF-8 text: {e})") from None
    except (ValueError, csv.Error) as e:
        raise ParameterError("reflectance", label, f"{REFLECTANCE_ALLOWED} ({e})") from None
    try:
        target = ReflectanceTarget.from_rows(rows)
    except FitTargetError as e:
        why = re.sub(r"^row (\d+)", lambda m: f"line {numbers[int(m.group(1)) - 1]}", str(e))
        raise ParameterError("reflectance", label, f"{REFLECTANCE_ALLOWED} ({why})") from None
    record = {"kind": "reflectance", "file": source.path.absolute(), "rows": len(rows),
              "angles": [float(a) for a in target.angles]}
    return LoadedTarget(target, record)


# --- Principled BSDF materials ---------------------------------------------
def load_principled_target(source: Source, ns: argparse.Namespace, guard) -> LoadedTarget:
    """The Principled BSDF material ``--material`` of the .blend, rendered by Cycles on the
    reference sphere (:func:`layered_brdf_addon.blender.principled_target.principled_views`)."""
    from ..fit.targets import SphereTarget, TargetError as FitTargetError
    from .requests import check_blend_file

    size = int_option("size", ns.size, 8, 4096) if ns.size is not None else PRINCIPLED_SIZE
    samples = int_option("samples", ns.samples, 1, 65536) if ns.samples is not None else PRINCIPLED_SAMPLES
    hdri_names = list(PRINCIPLED_HDRIS) if ns.hdri is None else [] if ns.hdri == ["none"] else list(ns.hdri)
    try:
        blend = check_blend_file(source.path)
    except ParameterError as e:
        raise ParameterError("principled", e.value, e.allowed) from None
    from ..blender import tempdirs

    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    guard.add_cleanup(tempdirs.remove_process_tempdir)
    from ..blender.lookdev import hdri_path
    from ..blender.principled_target import principled_views

    hdris = [hdri_path(name) for name in hdri_names]  # a name Blender does not ship: refused before rendering
    guard.arm()
    with blender_output(ns.verbose):
        try:
            views = principled_views(blend, source.name, size=size, samples=samples, hdris=hdris)
        except ParameterError as e:
            if e.name == "blend":
                raise ParameterError("principled", e.value, e.allowed) from None
            raise
    guard.arm()  # Blender may have replaced the handlers
    try:
        target = SphereTarget(views)
    except FitTargetError as e:
        raise ParameterError("material", source.name, f"a material that reflects light on the reference "
                             f"sphere ({e})") from None
    record = {"kind": "principled", "blend": blend, "material": source.name, "size": size, "samples": samples,
              "suns": [list(v.sun.direction) for v in views if v.sun is not None],
              "hdris": [v.environment.name for v in views if v.environment is not None],
              "pixels": int(len(target.observed))}
    return LoadedTarget(target, record)


# ---------------------------------------------------------------------------
# the start
def start_of(ns: argparse.Namespace, kind: str) -> tuple[LayeredParams, dict[str, Any]]:
    """The parameters the fit starts from, and the record of where they came from: ``--start``
    (default :data:`DEFAULT_STARTS` by the target's kind; none with only ``--params``), a
    ``--params`` file over it, the mode options over both."""
    name, defaults = ns.start, {}
    if name is not None and name not in PRESETS:
        raise ParameterError("start", shown(name), "one of " + ", ".join(PRESETS))
    if name is None and ns.params is None:
        name, defaults = DEFAULT_STARTS[kind]
    params = preset(name) if name is not None else LayeredParams()
    file_values, label, params_file = {}, "", None
    if ns.params is not None:
        params_file = _path(ns.params, "params", "the path of a .json or .toml file of parameter values").absolute()
        label = file_label(ns.params)
        file_values = load_params_file(params_file, label)
    overrides = {**defaults, **{k: getattr(ns, k) for k in MODE_OPTIONS if getattr(ns, k, None) is not None}}
    try:
        params = LayeredParams.from_dict(merged_values(file_values, overrides), base=params)
    except ParameterError as e:
        raise from_file(e, file_values, label, overridden=overrides) from None
    return params, {"preset": name, "params_file": params_file, "overrides": overrides}


def check_output(value: Any, inputs: Sequence[tuple[str, Path]]) -> OutputPaths:
    """The outputs ``OUT.json`` and ``OUT.png`` of the stem ``value``, checked before the fit: a
    stem whose name is not hidden nor too long, files that can be written (no folder in the way,
    a writable folder) and that replace none of ``inputs``; else :class:`ParameterError`
    naming ``output``."""
    if not isinstance(value, (str, Path)) or not str(value).strip() or "\x00" in str(value) \
            or len(str(value)) > MAX_TEXT:
        raise ParameterError("output", shown(value), OUTPUT_ALLOWED)
    stem = output_stem(Path(value).expanduser()).absolute()
    if stem.name in ("", ".", "..") or stem.name.startswith("."):
        raise ParameterError("output", str(value), OUTPUT_ALLOWED + "; a stem whose name does not start with '.'")
    if len(stem.name.encode("utf-8", "surrogateescape")) > MAX_STEM_BYTES:
        raise ParameterError("output", shown(str(value)), OUTPUT_ALLOWED + f"; a stem of at most {MAX_STEM_BYTES} "
                             "bytes")
    if stem.is_dir():
        raise ParameterError("output", str(value), OUTPUT_ALLOWED + "; it names a folder")
    paths = OutputPaths(stem)
    try:
        check_targets([paths.json, paths.png])
    except TargetError as e:
        raise ParameterError("output", str(value), f"{OUTPUT_ALLOWED}; {e}") from None
    for label, p in inputs:
        for f in (paths.json, paths.png):
            if same_file(f, p):
                raise ParameterError("output", str(value), f"{OUTPUT_ALLOWED}, none of them an input file "
                                     f"({f.name} would replace {label} {p})")
    return paths


def default_output(source: Source) -> Path:
    """``out/NAME-fit``, NAME the target's (its file's stem, the material's name)."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", source.name).strip("._") or "target"
    return DEFAULT_OUTPUT_DIR / f"{name}-fit"


# ---------------------------------------------------------------------------
# the fit and its outputs
def fit_with_progress(target, start: LayeredParams, vary, starts: int, enabled: bool,
                      should_stop: Callable[[], bool]):
    """:func:`~layered_brdf_addon.fit.solve.fit` with a tqdm bar of model evaluations on the
    standard error (its total the most the fit can take)."""
    from tqdm import tqdm

    from ..fit import solve
    from ..fit.free import default_vary, film_vary

    uniform = getattr(target, "uniform_film", False)
    names = vary if vary is not None else (film_vary if uniform else default_vary)(start)
    scan = solve.THICKNESS_SCAN_STEPS * (1 + len(solve.SCAN_HALF_WIDTHS))
    most = scan + (starts + 1) * STEPS_PER_START * (len(names) + 1)
    bar = tqdm(total=most, desc="fit", unit="eval", file=sys.stderr, disable=not enabled, dynamic_ncols=True)

    def progress(evaluations: int) -> None:
        bar.update(evaluations - bar.n)

    try:
        result = solve.fit(target, start, vary, starts=starts, steps_per_start=STEPS_PER_START,
                           progress=progress, should_stop=should_stop)
        bar.total = bar.n
        bar.refresh()
    finally:
        bar.close()
    return result


def fit_record(result, loaded: LoadedTarget, start_record: dict[str, Any], argv: Sequence[str] | None) -> dict:
    """The ``fit`` table of ``OUT.json``."""
    return {"target": loaded.record, "start": start_record, "vary": list(result.vary),
            "mean_delta_e_2000": float(result.mean_delta_e), "evaluations": int(result.evaluations),
            "seconds": float(result.seconds),
            "starts": [{"d_min": float(a), "d_max": float(b), "mean_delta_e_2000": float(de)}
                       for a, b, de in result.starts],
            "layered_brdf_version": __version__,
            "command": [sys.executable, "-m", "layered_brdf_addon", *argv] if argv is not None else None}


def output_document(name: str, params: LayeredParams, record: dict[str, Any]) -> dict[str, Any]:
    """``OUT.json``: a user preset of the panel (its format, version, name and parameters) with
    the record of the fit beside the parameters."""
    return {"format": PRESET_FORMAT, "version": PRESET_FORMAT_VERSION, "name": name,
            "params": params.validate().to_dict(), "fit": record}


def sphere_figure(target, params: LayeredParams, mean_delta_e: float):
    """Target | fit | CIEDE2000 per pixel, one row per view, each cropped to the fitted sphere."""
    from matplotlib.figure import Figure

    from ..fit import colour_space
    from .codecs import to_srgb8

    rows = len(target.views)
    fig = Figure(figsize=(9.6, 3.0 * rows + 0.4), dpi=100, layout="constrained")
    fig.suptitle(f"layered-brdf fit: mean CIEDE2000 {mean_delta_e:.2f} over the fitted colours", fontsize=11)
    noise = getattr(target, "matches_statistics", lambda p: False)(params)
    for k, view in enumerate(target.views):
        mask = target.mask(k)
        r, c = np.nonzero(mask)
        box = (slice(max(r.min() - 2, 0), r.max() + 3), slice(max(c.min() - 2, 0), c.max() + 3))
        observed = np.where(mask[..., None], np.asarray(view.image, dtype=float)[..., :3], 0.0)
        fitted = target.render(params, k)
        de = np.full(mask.shape, np.nan)
        de[mask] = colour_space.delta_e_2000(colour_space.lab(np.maximum(observed[mask], 0.0), target.white_y),
                                             colour_space.lab(np.maximum(fitted[mask], 0.0), target.white_y))
        suffix = f" (sun {k + 1})" if rows > 1 else ""
        panels = [(to_srgb8(observed[box]), "target" + suffix),
                  (to_srgb8(fitted[box]), "fit" + (" at the noise's median thickness" if noise else "")),
                  (de[box], f"CIEDE2000 per pixel, mean {np.nanmean(de):.2f}")]
        for j, (image, title) in enumerate(panels):
            ax = fig.add_subplot(rows, 3, 3 * k + j + 1)
            ax.set_axis_off()
            ax.set_title(title, fontsize=9)
            if j < 2:
                ax.imshow(image, interpolation="nearest")
            else:
                vmax = max(2.0, float(np.nanpercentile(image, 99)))
                shown_map = ax.imshow(image, cmap="magma", vmin=0.0, vmax=vmax, interpolation="nearest")
                fig.colorbar(shown_map, ax=ax, fraction=0.046, pad=0.04)
    return fig


def reflectance_figure(target, params: LayeredParams, mean_delta_e: float):
    """A swatch per angle, target above fit (one exposure for both), with each angle's CIEDE2000,
    and the reflectance of each channel against the angle, target and fit."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from ..fit import colour_space
    from .codecs import to_srgb8

    observed, fitted = np.asarray(target.observed, dtype=float), np.asarray(target.predict(params), dtype=float)
    de = colour_space.delta_e_2000(colour_space.lab(observed), colour_space.lab(np.maximum(fitted, 0.0)))
    brightest = float(colour_space.luminance(observed).max(initial=0.0))
    exposure = 1.0 if brightest >= 0.25 else 0.5 / max(brightest, 1e-6)
    fig = Figure(figsize=(max(6.0, 1.1 * len(observed) + 4.5), 4.2), dpi=100)
    fig.suptitle(f"layered-brdf fit: mean CIEDE2000 {mean_delta_e:.2f}", fontsize=11)
    swatches = fig.add_axes((0.1, 0.16, 0.45, 0.66))
    for i, row in enumerate(to_srgb8(np.stack([observed, fitted]) * exposure) / 255.0):
        for j, colour in enumerate(row):
            swatches.add_patch(Rectangle((j + 0.06, i + 0.06), 0.88, 0.88, color=colour))
    swatches.set_xlim(0.0, len(observed))
    swatches.set_ylim(2.0, 0.0)
    swatches.set_xticks(np.arange(len(observed)) + 0.5,
                        [f"{a:g}\u00b0\n\u0394E {d:.2f}" for a, d in zip(target.angles, de)], fontsize=8)
    swatches.set_yticks([0.5, 1.5], ["target", "fit"], fontsize=9)
    swatches.tick_params(length=0)
    for side in swatches.spines.values():
        side.set_visible(False)
    swatches.set_title("mirror reflection" + (f" (shown \u00d7{exposure:.3g})" if exposure != 1.0 else ""),
                       fontsize=9)
    curves = fig.add_axes((0.64, 0.16, 0.33, 0.66))
    for i, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        curves.plot(target.angles, observed[:, i], "o-", color=colour, lw=1.2, ms=3)
        curves.plot(target.angles, fitted[:, i], "--", color=colour, lw=1.2)
    curves.set_xlabel("angle (degrees)", fontsize=8)
    curves.set_ylabel("reflectance (R, G, B)", fontsize=8)
    curves.set_title("target (solid), fit (dashed)", fontsize=9)
    curves.tick_params(labelsize=7)
    return fig


def write_outputs(paths: OutputPaths, document: dict[str, Any], figure, guard) -> None:
    """``OUT.png`` and ``OUT.json`` written under temporary names and renamed together."""
    from .sidecar import write_json
    from .staging import StagedOutputs, writing

    with StagedOutputs([paths.png, paths.json], guard) as staged:
        with guard.io(), writing(paths.png):
            figure.savefig(staged.temp(paths.png), format="png")
        guard.check()
        with guard.io(), writing(paths.json):
            write_json(staged.temp(paths.json), document)
        guard.check()


def cmd_fit(ns: argparse.Namespace, argv: Sequence[str] | None = None) -> int:
    """``fit``: validate everything, read (or render) the target, fit, write OUT.json and OUT.png."""
    from ..fit.free import check_vary
    from ..fit.solve import FitCancelled
    from .staging import InterruptGuard

    source = source_of(ns)
    start, start_record = start_of(ns, source.kind)
    vary = check_vary(ns.vary) if ns.vary is not None else None
    starts = int_option("starts", ns.starts, *STARTS_RANGE) if ns.starts is not None else 3
    inputs = list(source.inputs)
    if start_record["params_file"] is not None:
        inputs.append(("the params file", start_record["params_file"]))
    paths = check_output(ns.output if ns.output is not None else default_output(source), inputs)
    with InterruptGuard() as guard:
        if source.kind == "render":
            loaded = load_render_target(source, ns.tile)
        elif source.kind == "reflectance":
            loaded = load_reflectance_target(source)
        else:
            loaded = load_principled_target(source, ns, guard)
        guard.check()
        try:
            result = fit_with_progress(loaded.target, start, vary, starts, ns.progress,
                                       should_stop=lambda: guard.received is not None)
        except FitCancelled:
            raise KeyboardInterrupt("the fit was interrupted") from None
        guard.check()
        draw = reflectance_figure if source.kind == "reflectance" else sphere_figure
        figure = draw(loaded.target, result.params, result.mean_delta_e)
        document = output_document(paths.stem.name, result.params, fit_record(result, loaded, start_record, argv))
        write_outputs(paths, document, figure, guard)
    print(f"fit: mean CIEDE2000 {result.mean_delta_e:.3f}, {result.seconds:.1f} s, {result.evaluations} "
          f"evaluations; wrote {paths.json}, {paths.png}")
    return EXIT_OK
