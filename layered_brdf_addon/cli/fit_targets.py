"""The target of ``layered-brdf fit``: which one the options name and reading it.

:func:`source_of` says which target the options name (a reference-sphere render, a
reflectance table or a Principled BSDF material) before anything is read; the loaders read
it into a target of :mod:`layered_brdf_addon.fit.targets` with the record of it that
``OUT.json`` keeps, or raise :class:`ParameterError` naming the option when it cannot be
fitted.  Only :func:`load_principled_target` imports bpy (it renders the material).
"""
from __future__ import annotations

import argparse
import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..blender import tempdirs
from ..fit.environment import DEFAULT_HDRIS
from ..fit.targets import ReflectanceTarget, SphereTarget, SphereView
from ..fit.targets import TargetError as FitTargetError
from ..io.codecs import exr_beauty, muted_stderr, read_complete_exr_layers
from ..io.sidecar import SIDECAR_FORMAT, scene_from_sidecar
from ..io.staging import OutputPaths, output_stem
from ..model.params import ParameterError
from ..model.sphere import sphere_geometry
from .input_files import MAX_INPUT_BYTES, check_blend_file, file_label, read_regular_file, read_table_file
from .option_values import int_option, path_option, shown
from .options import blender_output

PRINCIPLED_SIZE = 96
PRINCIPLED_SIZES = (8, 4096)  # pixels of each render
PRINCIPLED_SAMPLING = (1, 65536)  # samples per pixel
PRINCIPLED_SAMPLES = 1
PRINCIPLED_HDRIS = DEFAULT_HDRIS

TARGET_ALLOWED = ("a reference-sphere render of 'layered-brdf render': its sidecar STEM.json, or STEM, "
                  "STEM.exr or STEM.png with the sidecar and the EXR beside it")
SOURCE_ALLOWED = ("exactly one target: TARGET (a render's sidecar), --reflectance FILE.csv or "
                  "--principled FILE.blend")
REFLECTANCE_ALLOWED = ("a readable CSV file (at most 1 MiB) whose header names the columns angle (degrees from "
                       "the normal, in [0, 90)), wavelength (nm) or channel (r, g, b), and reflectance (a "
                       "fraction in [0, 1]), one row per angle and wavelength or channel")


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
        p = path_option("reflectance", ns.reflectance, REFLECTANCE_ALLOWED)
        return Source("reflectance", p, p.stem, [("the reflectance table", p)])
    p = path_option("principled", ns.principled, "the path of a .blend file")
    if not isinstance(ns.material, str) or not ns.material.strip():
        raise ParameterError("material", ns.material, "the name of a material of the .blend holding a "
                             "Principled BSDF (with --principled)")
    return Source("principled", p, ns.material, [("the .blend", p)])


def _render_source(value: Any) -> Source:
    p = path_option("target", value, TARGET_ALLOWED)
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
    if not exr.is_file():
        raise refuse(f"its EXR {file_label(exr)} is missing: the target image is the EXR's Combined pass")
    try:
        with muted_stderr():
            rgb, _ = exr_beauty(exr, read_complete_exr_layers(exr))
    except Exception as e:
        raise refuse(f"its EXR {file_label(exr)} cannot be read: {e.__class__.__name__}: {e}") from None
    return rgb


def _check_finite(view, refuse: Callable[[str], ParameterError]) -> None:
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
        why = re.sub(r"\brow (\d+)", lambda m: f"line {numbers[int(m.group(1)) - 1]}", str(e))
        raise ParameterError("reflectance", label, f"{REFLECTANCE_ALLOWED} ({why})") from None
    record = {"kind": "reflectance", "file": source.path.absolute(), "rows": len(rows),
              "angles": [float(a) for a in target.angles]}
    return LoadedTarget(target, record)


# --- Principled BSDF materials ---------------------------------------------
def load_principled_target(source: Source, ns: argparse.Namespace, guard) -> LoadedTarget:
    """The Principled BSDF material ``--material`` of the .blend, rendered by Cycles on the
    reference sphere (:func:`layered_brdf_addon.blender.principled_target.principled_views`)."""
    size = int_option("size", ns.size, *PRINCIPLED_SIZES) if ns.size is not None else PRINCIPLED_SIZE
    samples = int_option("samples", ns.samples, *PRINCIPLED_SAMPLING) if ns.samples is not None else PRINCIPLED_SAMPLES
    hdri_names = list(PRINCIPLED_HDRIS) if ns.hdri is None else [] if ns.hdri == ["none"] else list(ns.hdri)
    try:
        blend = check_blend_file(source.path)
    except ParameterError as e:
        raise ParameterError("principled", e.value, e.allowed) from None
    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    guard.add_cleanup(tempdirs.remove_process_tempdir)
    from ..blender.lookdev import hdri_path  # imports bpy: after enter_process_tempdir, for Blender's session folder
    from ..blender.principled_target import principled_views  # imports bpy, as above

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
