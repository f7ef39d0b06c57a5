"""The paper's Figs. 3-6 as one labelled contact sheet, rendered in one Blender scene.

Every configuration of :data:`~layered_brdf_addon.model.presets.PAPER_PRESETS` is a
unit sphere in a grid seen by one orthographic camera; one Cycles render gives all
tiles, which are cut out and labelled with the preset's name and key parameters.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..blender import tempdirs
from ..io.codecs import to_srgb8
from ..io.sidecar import camera_to_dict, sun_to_dict
from ..io.staging import InterruptGuard, OutputPaths, output_stem
from ..model import policy
from ..model.params import LayeredParams, ParameterError
from ..model.policy import plan_effects, render_plan
from ..model.presets import PAPER_PRESETS, preset
from ..model.sphere import OrthoCamera, Sun
from .option_table import GALLERY_SAMPLES, GALLERY_SIZE, read_options, scene_options_of
from .render_job import render_outputs, sidecar
from .requests import check_output

SPACING = 2.2  # centre distance of neighbouring spheres (unit radius): a 10% margin per tile
DEFAULT_SIZE = GALLERY_SIZE
DEFAULT_SAMPLES = GALLERY_SAMPLES
DEFAULT_OUTPUT = Path("out") / "gallery.png"
ANTIALIAS_FILTER_WIDTH = 1.5  # Blender's default pixel filter, used when there is more than one sample
BACKGROUND = (24, 24, 26)
LABEL_BACKGROUND = (38, 38, 42)
TEXT = (235, 235, 235)
TEXT_DIM = (170, 170, 178)


@dataclass(frozen=True)
class GalleryLayout:
    """Pixel geometry of the contact sheet: a title band, then rows of tile + label cells."""

    count: int
    columns: int
    rows: int
    size: int
    label_height: int
    title_height: int
    font_size: int

    @property
    def cell_height(self) -> int:
        return self.size + self.label_height

    @property
    def sheet_size(self) -> tuple[int, int]:
        """(width, height) of the sheet."""
        return self.columns * self.size, self.title_height + self.rows * self.cell_height

    def cell(self, k: int) -> tuple[int, int]:
        return divmod(k, self.columns)

    def tile_box(self, k: int) -> tuple[int, int, int, int]:
        """(left, top, right, bottom) of tile ``k``'s image in the sheet."""
        r, c = self.cell(k)
        x0, y0 = c * self.size, self.title_height + r * self.cell_height
        return x0, y0, x0 + self.size, y0 + self.size

    def label_box(self, k: int) -> tuple[int, int, int, int]:
        x0, _, x1, y1 = self.tile_box(k)
        return x0, y1, x1, y1 + self.label_height

    def render_box(self, k: int) -> tuple[int, int, int, int]:
        """(left, top, right, bottom) of sphere ``k`` in the rendered image."""
        r, c = self.cell(k)
        return c * self.size, r * self.size, (c + 1) * self.size, (r + 1) * self.size


def label_lines(name: str, p: LayeredParams) -> list[str]:
    """The tile's caption: the preset name and the parameters that tell the tiles apart."""
    if p.d_min == p.d_max:
        d = f"d {p.d_min:g} nm"
    else:
        d = f"d {p.d_min:g}\u2013{p.d_max:g} nm" + (" (height)" if p.thickness_mode == "height" else "")
    films = f"stack of {p.stack.count} film{'s' if p.stack.count != 1 else ''}" if p.stack is not None else ""
    n = films or f"n {p.r1_r:g} {p.r1_g:g} {p.r1_b:g}"
    if p.normal_mode == "tilted" and p.tilt:
        n += f" \u00b7 tilt {p.tilt:g}\u00b0"
    elif p.normal_mode == "correlated":
        n += " \u00b7 correlated"
    lobes = f"ks {p.ks:g} kd {p.kd:g}"
    if p.ks > 0:
        lobes += f" \u00b7 e {p.e0:g}/{p.e1:g}"
    return [name, d, n, lobes]


def _font_path() -> str:
    import matplotlib

    return str(Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf")


def _font(size: int):
    from PIL import ImageFont

    return ImageFont.truetype(_font_path(), size)


def _fit_font_size(lines: Sequence[str], width: int, start: int, smallest: int = 5) -> int:
    fs = start
    while fs > smallest:
        font = _font(fs)
        if max(font.getlength(s) for s in lines) <= width:
            break
        fs -= 1
    return fs


def layout_for(names_labels: Sequence[Sequence[str]], size: int, columns: int | None = None,
               title: str = "") -> GalleryLayout:
    """Grid of ``ceil(sqrt(n))`` columns (or ``columns``) with a font that fits the captions."""
    n = len(names_labels)
    cols = columns or max(1, math.ceil(math.sqrt(n)))
    rows = math.ceil(n / cols)
    lines = [s for label in names_labels for s in label]
    fs = _fit_font_size(lines, size - 6, max(6, round(size / 11)))
    n_lines = max(len(label) for label in names_labels)
    label_h = n_lines * (fs + 3) + 6
    title_h = 0
    if title:
        tfs = _fit_font_size([title], cols * size - 8, max(fs + 1, 7))
        title_h = tfs + 10
    return GalleryLayout(n, cols, rows, size, label_h, title_h, fs)


def grid_centers(layout: GalleryLayout) -> tuple[tuple[float, float, float], ...]:
    """Sphere centres (x right, z up, camera looking along +y), row-major from the top left."""
    out = []
    for k in range(layout.count):
        r, c = layout.cell(k)
        out.append(((c - (layout.columns - 1) / 2.0) * SPACING, 0.0, ((layout.rows - 1) / 2.0 - r) * SPACING))
    return tuple(out)


def grid_camera(layout: GalleryLayout) -> OrthoCamera:
    """The orthographic camera that gives every sphere a ``size`` x ``size`` pixel cell."""
    return OrthoCamera(view=(0.0, -1.0, 0.0), ortho_scale=SPACING * max(layout.columns, layout.rows),
                       width=layout.columns * layout.size, height=layout.rows * layout.size)


def compose_sheet(srgb8: np.ndarray, layout: GalleryLayout, labels: Sequence[Sequence[str]], title: str = ""):
    """The contact sheet (a PIL image) from the rendered grid in 8-bit sRGB."""
    from PIL import Image, ImageDraw

    sheet = Image.new("RGB", layout.sheet_size, BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    if title:
        tfs = layout.title_height - 10
        draw.text((4, 5), title, fill=TEXT, font=_font(tfs))
    font = _font(layout.font_size)
    for k, label in enumerate(labels):
        x0, y0, x1, y1 = layout.render_box(k)
        sheet.paste(Image.fromarray(np.ascontiguousarray(srgb8[y0:y1, x0:x1, :3]), "RGB"), layout.tile_box(k)[:2])
        lx0, ly0, lx1, ly1 = layout.label_box(k)
        draw.rectangle((lx0, ly0, lx1 - 1, ly1 - 1), fill=LABEL_BACKGROUND)
        for j, line in enumerate(label):
            draw.text((lx0 + 3, ly0 + 3 + j * (layout.font_size + 3)), line, fill=TEXT if j == 0 else TEXT_DIM,
                      font=font)
    return sheet


@dataclass
class GallerySettings:
    """Validated gallery options."""

    output: Path = DEFAULT_OUTPUT
    size: int = DEFAULT_SIZE
    samples: int = DEFAULT_SAMPLES
    backend: str = "nodes"
    columns: int | None = None
    sun: tuple[float, float, float] | None = None
    sun_strength: float | None = None
    seed: int = 0
    threads: int = 2
    presets: tuple[str, ...] = tuple(PAPER_PRESETS)
    scene_options: dict[str, Any] = field(default_factory=dict)  # every table option given, as read

    def sun_light(self) -> Sun:
        default = Sun()
        return Sun(direction=self.sun or default.direction,
                   strength=default.strength if self.sun_strength is None else self.sun_strength)


def check_preset_lobe(name: str, backend: str) -> None:
    """Raise :class:`ParameterError` naming ``presets`` (the option that chose it) unless
    ``backend`` builds the lobe of preset ``name``."""
    lobe = preset(name).lobe
    if not policy.supports(backend, lobe):
        others = [b for b in policy.BACKENDS if policy.supports(b, lobe)]
        hint = f"; choose --backend {' or '.join(others)}" if others else ""
        raise ParameterError("presets", name, f"presets whose lobe the {backend} backend builds "
                             f"(the lobe of {name} is {lobe!r}{hint})")


def settings_from_options(options: dict[str, Any]) -> GallerySettings:
    """Validate gallery options (``output``, ``size``, ``samples``, ``backend``, ...) without Blender."""
    o = {k: v for k, v in options.items() if v is not None}
    given = read_options("gallery", o)  # each value checked alone; the presets' lobes and the output below
    scene = {s.name: given[s.name] for s in scene_options_of("gallery") if s.name in given}
    size, samples = given.get("size", DEFAULT_SIZE), given.get("samples", DEFAULT_SAMPLES)
    backend, columns = given.get("backend", "nodes"), given.get("columns")
    sun, strength = given.get("sun"), given.get("sun_strength")
    seed, threads = given.get("seed", 0), given.get("threads", 2)
    names = given.get("presets", tuple(PAPER_PRESETS))
    for name in names:
        check_preset_lobe(name, backend)
    output = check_output(o.get("output", DEFAULT_OUTPUT))
    return GallerySettings(output=output, size=size, samples=samples, backend=backend, columns=columns, sun=sun,
                           sun_strength=strength, seed=seed, threads=threads, presets=names, scene_options=scene)


@dataclass
class GalleryTile:
    name: str
    params: LayeredParams
    label: list[str]
    box: tuple[int, int, int, int]  # in the sheet
    center: tuple[float, float, float]


@dataclass
class GalleryResult:
    png: Path
    exr: Path
    sidecar: Path
    layout: GalleryLayout
    tiles: list[GalleryTile]
    render_seconds: float
    total_seconds: float
    metadata: dict[str, Any] = field(default_factory=dict)


def title_for(s: GallerySettings) -> str:
    what = "Granier & Heidrich 2003, Figs. 3\u20136" if s.presets == tuple(PAPER_PRESETS) else "layered-brdf presets"
    return f"{what} \u00b7 {s.backend} \u00b7 {s.samples} spp"


def render_gallery(s: GallerySettings, command: Sequence[str] | None = None,
                   log: Callable[[str], None] | None = None) -> GalleryResult:
    """Render every preset of ``s`` in one scene and write the sheet, the EXR and a sidecar."""
    t_start = time.perf_counter()
    tempdirs.enter_process_tempdir()  # before bpy: Blender's session folder goes in it too
    with InterruptGuard() as guard:
        guard.add_cleanup(tempdirs.remove_process_tempdir)
        import bpy  # after enter_process_tempdir: Blender makes its session folder in that folder

        from ..blender.material import apply_layered_material  # imports bpy, as above
        from ..blender.scene import SceneSpec, build_scene, reset_blender  # imports bpy, as above

        params = [preset(n) for n in s.presets]
        labels = [label_lines(n, p) for n, p in zip(s.presets, params)]
        title = title_for(s)
        layout = layout_for(labels, s.size, s.columns, title)
        centers = grid_centers(layout)
        camera, sun = grid_camera(layout), s.sun_light()
        reset_blender()
        guard.arm()
        spheres = build_scene(SceneSpec(camera=camera, sun=sun, centers=centers, samples=s.samples,
                                        threads=s.threads, seed=s.seed, osl=(s.backend == "osl")))
        scene = bpy.context.scene
        if s.samples > 1:
            scene.cycles.filter_width = ANTIALIAS_FILTER_WIDTH
        for obj, name, p in zip(spheres, s.presets, params):
            obj.name = name
            apply_layered_material(obj, p, s.backend, name=name)
        guard.check()
        paths = OutputPaths(output_stem(s.output))
        tiles = [GalleryTile(n, p, lab, layout.tile_box(k), centers[k])
                 for k, (n, p, lab) in enumerate(zip(s.presets, params, labels))]

        def describe(render_seconds: float) -> dict[str, Any]:
            return sidecar(
                "gallery", scene, paths, backend=s.backend, camera=camera_to_dict(camera), sun=sun_to_dict(sun),
                centers=centers, render_seconds=render_seconds, t_start=t_start, command=command,
                tiles=[{"name": t.name, "label": t.label, "box": t.box, "render_box": layout.render_box(k),
                        "center": t.center, "params": t.params.to_dict(), "plan": render_plan(t.params).key}
                       for k, t in enumerate(tiles)],
                layout={"columns": layout.columns, "rows": layout.rows, "size": layout.size,
                        "label_height": layout.label_height, "title_height": layout.title_height,
                        "sheet_size": layout.sheet_size},
                title=title, exr_aovs=s.backend == "nodes")

        meta = render_outputs(scene, paths, guard, describe=describe,
                              png=lambda rgb, _: np.asarray(compose_sheet(to_srgb8(rgb), layout, labels, title)))
    total = time.perf_counter() - t_start
    if log:
        log(f"wrote {paths.png} ({layout.sheet_size[0]}x{layout.sheet_size[1]}), {paths.exr}, {paths.json}")
    return GalleryResult(paths.png, paths.exr, paths.json, layout, tiles, meta["render_seconds"], total, meta)


def summary_rows(result: GalleryResult) -> tuple[list[str], list[list[str]]]:
    """The gallery table: one row per tile (render time shared: one render for all)."""
    share = result.render_seconds / max(1, len(result.tiles))
    headers = ["preset", "thickness (nm)", "indices R G B", "normals", "ks", "kd", "render s"]
    rows = []
    for t in result.tiles:
        p = t.params
        plan = plan_effects(p)
        rows.append([t.name, f"{p.d_min:g}-{p.d_max:g}", f"{p.r1_r:g} {p.r1_g:g} {p.r1_b:g}",
                     plan.normals + (f" {p.tilt:g} deg" if plan.normals == "tilted" else ""),
                     f"{p.ks:g}", f"{p.kd:g}", f"{share:.2f}"])
    return headers, rows
