"""The target of ``layered-brdf fit``: reading it.

A :class:`Source` is the target the options name (a reference-sphere render, a reflectance table or a
Principled BSDF material: :func:`.fit_request.source_of`), before anything is read; the loaders read
it into a target of :mod:`layered_brdf_addon.fit.targets` with the record of it that
``OUT.json`` keeps, or raise :class:`ParameterError` naming the option when it cannot be
fitted.  Only :func:`load_principled_target` imports bpy (it renders the material).
"""
from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..blender import tempdirs
from ..fit.targets import ReflectanceTarget, SphereTarget, SphereView
from ..fit.targets import TargetError as FitTargetError
from ..io.codecs import exr_beauty, muted_stderr, read_complete_exr_layers
from ..io.sidecar import SidecarError
from ..io.sphere_render import read_sphere_render
from ..model.params import ParameterError
from .fit_options import REFLECTANCE_ALLOWED, TARGET_ALLOWED, TILE_ALLOWED
from .input_files import MAX_INPUT_BYTES, check_blend_file, file_label, read_regular_file
from .option_values import shown
from .options import blender_output

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


def load_render_target(source: Source, tile: Any) -> LoadedTarget:
    """The EXR's Combined pass of a reference-sphere render (or one sphere of a gallery), seen
    by the sidecar's camera under its sun (:func:`..io.sphere_render.read_sphere_render`);
    :class:`ParameterError` naming ``target`` (or ``tile``) with the reason when it cannot be
    fitted."""
    label = file_label(source.path)
    try:
        render = read_sphere_render(source.path, read_complete_beauty, tile=tile)
    except SidecarError as e:
        if e.field == "tile":
            raise ParameterError("tile", shown(tile), f"{TILE_ALLOWED} ({e.reason})") from None
        raise ParameterError("target", label, f"{TARGET_ALLOWED} ({e.reason})") from None
    scene = render.scene
    view = SphereView(render.image, scene.camera, scene.sun, scene.centers, render.sphere)
    try:
        target = SphereTarget([view])
    except FitTargetError as e:
        raise ParameterError("target", label, f"{TARGET_ALLOWED} ({e})") from None
    record = {"kind": "render", "sidecar": source.path.absolute(), "exr": render.exr_path.absolute(),
              "scene": render.kind, "tile": render.tile, "size": [scene.camera.width, scene.camera.height],
              "pixels": int(len(target.observed))}
    return LoadedTarget(target, record)


def read_complete_beauty(exr: Path) -> np.ndarray:
    """The Combined pass (H, W, 3) of an EXR that holds every part its header lists (a file cut
    short is refused, not read as one with fewer passes); OpenEXR's complaints are not printed."""
    with muted_stderr():
        return exr_beauty(exr, read_complete_exr_layers(exr))[0]


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
def load_principled_target(source: Source, renders, guard, *, verbose: bool = False) -> LoadedTarget:
    """The Principled BSDF material ``--material`` of the .blend, rendered by Cycles on the
    reference sphere (:func:`layered_brdf_addon.blender.principled_target.principled_views`) as
    ``renders`` says (a :class:`~.fit_request.PrincipledRenders`: size, samples, HDRIs)."""
    size, samples, hdri_names = renders.size, renders.samples, list(renders.hdris)
    try:
        blend = check_blend_file(source.path)
    except ParameterError as e:
        raise ParameterError("principled", e.value, e.allowed) from None
    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    guard.add_cleanup(tempdirs.remove_process_tempdir)
    from ..blender.lookdev import hdri_path  # imports bpy: after enter_process_tempdir, for Blender's session folder
    from ..blender.principled_target import principled_views, surface_of, uniform_film  # imports bpy, as above

    hdris = [hdri_path(name) for name in hdri_names]  # a name Blender does not ship: refused before rendering
    guard.arm()
    with blender_output(verbose):
        try:
            views = principled_views(blend, source.name, size=size, samples=samples, hdris=hdris)
        except ParameterError as e:
            if e.name == "blend":
                raise ParameterError("principled", e.value, e.allowed) from None
            raise
    guard.arm()  # Blender may have replaced the handlers
    import bpy

    material = bpy.data.materials[source.name]  # the file is still open
    surface, uniform = surface_of(material), uniform_film(material)
    try:
        target = SphereTarget(views, uniform_film=uniform)
    except FitTargetError as e:
        raise ParameterError("material", source.name, f"a material that reflects light on the reference "
                             f"sphere ({e})") from None
    record = {"kind": "principled", "blend": blend, "material": source.name, "size": size, "samples": samples,
              "suns": [list(v.sun.direction) for v in views if v.sun is not None],
              "hdris": [v.environment.name for v in views if v.environment is not None],
              "surface": surface, "uniform_film": uniform, "pixels": int(len(target.observed))}
    return LoadedTarget(target, record)
