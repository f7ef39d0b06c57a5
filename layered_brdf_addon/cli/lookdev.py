"""The look-development sheet: every preset on the shader ball under a bundled HDRI.

One look-dev scene (:mod:`layered_brdf_addon.blender.lookdev`) is rendered once per
preset with the preset's material on the ball: every tile is the same shot.  (One
render of all balls in a grid measured 2.5x faster, but the balls reflect and shadow
each other and each sees the HDRI from elsewhere; docs/looks.md has the numbers.)  The
linear tiles are put in a grid,
encoded by Blender's own colour management with the scene's view transform (AgX by
default), and labelled with each preset's name for people.  The sheet ``STEM.png`` and
its sidecar ``STEM.json`` appear together or not at all.
"""
from __future__ import annotations

import contextlib
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .. import __version__
from ..blender import tempdirs
from ..io.codecs import muted_stderr, save_png
from ..io.sidecar import SIDECAR_FORMAT, SIDECAR_VERSION, write_json
from ..io.staging import (InterruptGuard, StagedOutputs, TargetError, check_targets, output_stem, reading_back,
                          writing)
from ..model.params import ParameterError
from ..model.policy import render_plan
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, STACK_PRESETS, preset, preset_label
from .gallery import GalleryLayout, compose_sheet, layout_for
from .option_table import LOOKDEV_SAMPLES, LOOKDEV_SIZE, read_options
from .render_job import view_png_encoding

DEFAULT_OUTPUT = Path("out") / "lookdev.png"
DEFAULT_PRESETS = tuple(ARTIST_PRESETS) + tuple(STACK_PRESETS) + tuple(PAPER_PRESETS)
DEFAULT_SIZE = LOOKDEV_SIZE
DEFAULT_SAMPLES = LOOKDEV_SAMPLES
BACKEND = "nodes"


@dataclass
class LookdevSettings:
    """Validated options of ``lookdev``."""

    output: Path = DEFAULT_OUTPUT  # the sheet (.png); the sidecar is the same stem .json
    size: int = DEFAULT_SIZE
    samples: int = DEFAULT_SAMPLES
    presets: tuple[str, ...] = DEFAULT_PRESETS
    hdri: str | None = None
    columns: int | None = None

    @property
    def sidecar(self) -> Path:
        return self.output.with_suffix(".json")


def check_sheet_output(value: Any) -> Path:
    """The sheet's path (``.png`` added to a stem), checked writable before anything renders,
    with its sidecar ``.json``; :class:`ParameterError` naming ``output`` otherwise."""
    allowed = "a file path (.png, or a stem) in a writable folder"
    if not isinstance(value, (str, Path)) or not str(value).strip() or "\x00" in str(value):
        raise ParameterError("output", value, allowed)
    if isinstance(value, str) and value.endswith(("/", "\\")):
        raise ParameterError("output", value, allowed + "; it names a folder")
    stem = output_stem(Path(value).expanduser())
    if stem.name.startswith("."):
        raise ParameterError("output", str(value), allowed + "; a name not starting with '.'")
    png = stem.with_name(stem.name + ".png")
    if png.is_dir() or stem.is_dir():
        raise ParameterError("output", str(value), allowed + "; it names a folder")
    try:
        check_targets([png, png.with_suffix(".json")])
    except TargetError as e:
        raise ParameterError("output", str(value), f"{allowed}; {e}") from None
    return png.absolute()


def settings_from_options(options: dict[str, Any]) -> LookdevSettings:
    """Validate ``lookdev`` options without Blender (the HDRI's name is checked when Blender
    is loaded, before anything is written)."""
    o = {k: v for k, v in options.items() if v is not None}
    sheet = read_options("lookdev", o)
    size, samples = sheet.get("size", DEFAULT_SIZE), sheet.get("samples", DEFAULT_SAMPLES)
    names, hdri = sheet.get("presets", DEFAULT_PRESETS), sheet.get("hdri")
    columns = sheet.get("columns")
    output = check_sheet_output(o.get("output", DEFAULT_OUTPUT))
    return LookdevSettings(output=output, size=size, samples=samples, presets=names, hdri=hdri, columns=columns)


def tile_label(name: str) -> list[str]:
    """A tile's caption: the preset's name for people, then its thickness range and indices (a stack's films)."""
    p = preset(name)
    d = f"{p.d_min:g}\u2013{p.d_max:g} nm" if p.d_min != p.d_max else f"{p.d_min:g} nm"
    if p.stack is not None:
        return [preset_label(name), f"{p.stack.size_label} \u00b7 {d}"]
    return [preset_label(name), f"{d} \u00b7 n {p.r1_g:g}"]


@dataclass
class LookdevResult:
    png: Path
    sidecar: Path
    layout: GalleryLayout
    tiles: list[dict[str, Any]]
    render_seconds: float
    total_seconds: float
    metadata: dict[str, Any] = field(default_factory=dict)


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="look-dev", unit="tile", file=sys.stderr, disable=not enabled,
                dynamic_ncols=True)


def render_tiles(scene, layout: GalleryLayout, tiles: Sequence[tuple[str, Callable[[], None]]], guard=None,
                 bar=None) -> tuple[np.ndarray, list[float]]:
    """Render ``scene`` once per tile, after the tile's callable has set it up (put its material
    on the ball), into the linear grid of ``layout`` (the render boxes); returns the grid
    (H, W, 3) and each tile's render seconds.  The EXRs go to a temporary folder; one that
    cannot be read back (that folder's disk is full) is a :class:`~.staging.WriteError`."""
    from ..blender.scene import passes_from_exr, render_to_exr  # imports bpy: only when rendering

    size = layout.size
    sheet = np.zeros((layout.rows * size, layout.columns * size, 3), np.float32)
    seconds = []
    with tempfile.TemporaryDirectory(prefix="lookdev_") as tmp_name:  # in the process's own temp folder
        for k, (name, setup) in enumerate(tiles):
            if bar is not None:
                bar.set_postfix_str(name)
            if guard is not None:
                guard.check()
            setup()
            exr = Path(tmp_name) / f"{k}.exr"
            seconds.append(render_to_exr(exr, scene, guard))
            x0, y0, x1, y1 = layout.render_box(k)
            with guard.io() if guard is not None else contextlib.nullcontext(), \
                    reading_back(exr, tmp_name), muted_stderr():
                sheet[y0:y1, x0:x1] = passes_from_exr(exr).beauty
            if bar is not None:
                bar.update(1)
    return sheet, seconds


def encode_sheet(scene, sheet: np.ndarray, layout: GalleryLayout, labels: Sequence[Sequence[str]],
                 title: str) -> np.ndarray:
    """The labelled sheet (8-bit RGB) of a linear grid, encoded by Blender with the scene's view settings."""
    from ..blender.scene import encode_view  # imports bpy: only when rendering

    return np.asarray(compose_sheet(encode_view(sheet, scene), layout, labels, title))


def timed_sheet(scene, tiles: Sequence[tuple[str, Callable[[], None]]], labels: Sequence[Sequence[str]],
                size: int, columns: int, title: str, desc: str, progress: bool) -> tuple[np.ndarray, list[float]]:
    """The labelled sheet (8-bit RGB) of ``tiles`` rendered in ``columns`` (:func:`render_tiles`), each label
    given a last line with its tile's render time (laid out with room for it), and the tiles' render seconds."""
    from tqdm import tqdm

    layout = layout_for([list(lab) + ["00.0 s"] for lab in labels], size, columns, title)
    bar = tqdm(total=len(tiles), desc=desc, unit="tile", disable=not progress, file=sys.stderr)
    try:
        sheet, seconds = render_tiles(scene, layout, tiles, bar=bar)
    finally:
        bar.close()
    timed = [list(lab) + [f"{sec:.1f} s render"] for lab, sec in zip(labels, seconds)]
    return encode_sheet(scene, sheet, layout, timed, title), seconds


def render_lookdev(s: LookdevSettings, command: Sequence[str] | None = None, progress: bool = True,
                   log: Callable[[str], None] | None = None) -> LookdevResult:
    """Render every preset of ``s`` on the shader ball; write the labelled sheet and its sidecar."""
    t_start = time.perf_counter()
    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    with InterruptGuard() as guard:
        guard.add_cleanup(tempdirs.remove_process_tempdir)
        import bpy  # after enter_process_tempdir: Blender makes its session folder in that folder

        from ..blender.lookdev import build_lookdev_scene, hdri_path  # imports bpy, as above
        from ..blender.material import apply_layered_material  # imports bpy, as above
        from ..blender.scene import reset_blender, view_settings_record  # imports bpy, as above

        hdri = hdri_path(s.hdri)  # a bad name: ParameterError before anything is made
        reset_blender()
        guard.arm()
        scene, ball = build_lookdev_scene(size=s.size, samples=s.samples, hdri=hdri.name)
        labels = [tile_label(n) for n in s.presets]
        title = (f"layered-brdf look-dev \u00b7 {hdri.stem} HDRI + sun \u00b7 Cycles {s.samples} spp \u00b7 "
                 f"{scene.view_settings.view_transform}")
        layout = layout_for(labels, s.size, s.columns, title)
        params = [preset(n) for n in s.presets]

        def assign(name, p):
            def put() -> None:
                ball.material_slots[0].material = None  # a material of its own per preset
                apply_layered_material(ball, p, BACKEND, name=name)
            return put

        bar = _progress(len(s.presets), progress)
        try:
            sheet, seconds = render_tiles(scene, layout, [(n, assign(n, p)) for n, p in zip(s.presets, params)],
                                          guard=guard, bar=bar)
        finally:
            bar.close()
        render_seconds = sum(seconds)
        tiles = [{"name": n, "label": labels[k], "box": layout.tile_box(k), "render_box": layout.render_box(k),
                  "render_seconds": seconds[k], "params": p.to_dict(), "plan": render_plan(p).key}
                 for k, (n, p) in enumerate(zip(s.presets, params))]
        guard.check()
        view = view_settings_record(scene)
        pixels = encode_sheet(scene, sheet, layout, labels, title)

        data = {
            "format": SIDECAR_FORMAT, "version": SIDECAR_VERSION, "scene": "lookdev", "title": title,
            "hdri": hdri.name, "engine": scene.render.engine, "backend": BACKEND, "size": s.size,
            "samples": s.samples, "seed": scene.cycles.seed, "threads": scene.render.threads,
            "png_encoding": view_png_encoding(view),
            "view": view, "tiles": tiles,
            "layout": {"columns": layout.columns, "rows": layout.rows, "size": layout.size,
                       "label_height": layout.label_height, "title_height": layout.title_height,
                       "sheet_size": layout.sheet_size},
            "outputs": {"png": s.output, "json": s.sidecar},
            "render_seconds": render_seconds, "bpy_version": bpy.app.version_string,
            "layered_brdf_version": __version__, "command": list(command) if command is not None else None,
        }
        with StagedOutputs([s.output, s.sidecar], guard) as staged:
            with guard.io(), writing(s.output):
                save_png(staged.temp(s.output), pixels)
            guard.check()
            data["total_seconds"] = time.perf_counter() - t_start
            with guard.io(), writing(s.sidecar):
                write_json(staged.temp(s.sidecar), data)
            guard.check()
    total = time.perf_counter() - t_start
    if log:
        log(f"wrote {s.output}, {s.sidecar}")
    return LookdevResult(s.output, s.sidecar, layout, tiles, render_seconds, total, data)
