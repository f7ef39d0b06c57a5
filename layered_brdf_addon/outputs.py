"""Render outputs on disk: staged writes, PNG from linear pixels, EXR layers, sidecars.

Every output is written under a temporary name in its final folder and renamed
when all files of the set are complete, so a reader never sees a partial PNG,
EXR or sidecar.  Nothing here imports bpy.
"""
from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

OUTPUT_SUFFIXES = (".png", ".exr", ".json")
SIDECAR_FORMAT = "layered-brdf render"
SIDECAR_VERSION = 1
_TEMP_MARK = ".tmp"


@dataclass(frozen=True)
class OutputPaths:
    """The three files of one render: ``stem.png``, ``stem.exr`` and ``stem.json``."""

    stem: Path

    @property
    def png(self) -> Path:
        return self.stem.with_name(self.stem.name + ".png")

    @property
    def exr(self) -> Path:
        return self.stem.with_name(self.stem.name + ".exr")

    @property
    def json(self) -> Path:
        return self.stem.with_name(self.stem.name + ".json")

    def all(self) -> tuple[Path, Path, Path]:
        """EXR, PNG, sidecar: the order in which they are committed (sidecar last)."""
        return (self.exr, self.png, self.json)


def output_stem(path: str | os.PathLike) -> Path:
    """The stem of an output path: ``out/a``, ``out/a.png`` and ``out/a.exr`` all give ``out/a``."""
    p = Path(path)
    if p.suffix.lower() in OUTPUT_SUFFIXES:
        p = p.with_suffix("")
    return p


def temp_path(final: Path, pid: int | None = None) -> Path:
    """The temporary name of ``final`` while it is written: hidden, same folder, same suffix."""
    pid = os.getpid() if pid is None else pid
    return final.with_name(f".{final.stem}{_TEMP_MARK}{pid}{final.suffix}")


def stale_temps(stem: str | os.PathLike) -> list[Path]:
    """Temporary files of the outputs of ``stem`` left by a process that was killed.

    Matches this module's temporary names (``.NAME.tmpPID.SUFFIX``) and the
    ``..NAME.tmpPID.partialPID.exr`` names Blender's EXR writer uses for them.
    """
    stem = Path(stem)
    folder = stem.parent
    if not folder.is_dir():
        return []
    pattern = re.compile(r"\.{1,2}" + re.escape(stem.name) + re.escape(_TEMP_MARK)
                         + r"\d+(\.partial\d+)?(\.png|\.exr|\.json)(\.rewrite)?")
    return sorted(p for p in folder.iterdir() if pattern.fullmatch(p.name) and p.is_file())


def remove_stale_temps(stem: str | os.PathLike) -> list[Path]:
    """Delete :func:`stale_temps` of ``stem``; returns what was removed."""
    removed = []
    for p in stale_temps(stem):
        try:
            p.unlink()
            removed.append(p)
        except FileNotFoundError:
            pass
    return removed


class InterruptGuard:
    """Ctrl-C and SIGTERM stop a render at once and leave no partial output.

    Blender's SIGINT handler swallows Ctrl-C, and a long render runs in C with
    Python's signal handlers waiting, so :meth:`arm` installs Python handlers and a
    wake-up pipe that a watchdog thread reads: on a signal it takes :attr:`io_lock`
    (held by every step that creates, writes or renames an output file, so none is
    half done), runs the registered clean-ups and ends the process with exit code
    130.  :meth:`check` raises KeyboardInterrupt for a signal noticed between steps
    (where the watchdog cannot run).  Outside the main thread the guard does nothing.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)
    EXIT_CODE = 130

    def __init__(self, message: str = "interrupted; no partial output was left"):
        self.message = message
        self.received: int | None = None
        self.io_lock = threading.RLock()
        self._cleanups: list[Callable[[], None]] = []
        self._previous: dict[int, Any] = {}
        self._previous_wakeup: int | None = None
        self._pipe: tuple[int, int] | None = None
        self._thread: threading.Thread | None = None

    @staticmethod
    def _main_thread() -> bool:
        return threading.current_thread() is threading.main_thread()

    def _handle(self, signum, frame) -> None:
        self.received = signum

    def arm(self) -> "InterruptGuard":
        """Install (again: Blender may have replaced them) the handlers; start the watchdog once."""
        if not self._main_thread():
            return self
        for s in self.SIGNALS:
            prev = signal.signal(s, self._handle)
            self._previous.setdefault(s, prev)
        if self._pipe is None:
            r, w = os.pipe()
            os.set_blocking(w, False)
            self._pipe = (r, w)
            self._thread = threading.Thread(target=self._watch, name="layered-brdf-interrupt", daemon=True)
            self._thread.start()
        prev_fd = signal.set_wakeup_fd(self._pipe[1], warn_on_full_buffer=False)
        if self._previous_wakeup is None:
            self._previous_wakeup = prev_fd
        return self

    def _watch(self) -> None:
        r = self._pipe[0]
        while True:
            try:
                data = os.read(r, 1)
            except OSError:
                return
            if not data:
                return
            if data[0] in {int(s) for s in self.SIGNALS}:
                self.received = data[0]
                self.abort()

    def add_cleanup(self, fn: Callable[[], None]) -> None:
        self._cleanups.append(fn)

    def remove_cleanup(self, fn: Callable[[], None]) -> None:
        if fn in self._cleanups:
            self._cleanups.remove(fn)

    def io(self) -> threading.RLock:
        """Hold while creating, writing or renaming output files."""
        return self.io_lock

    def abort(self) -> None:
        """Clean up and end the process now (from the watchdog)."""
        self.io_lock.acquire()
        for fn in list(self._cleanups):
            try:
                fn()
            except Exception:
                pass
        try:
            os.write(2, f"layered-brdf: {self.message}\n".encode())
        finally:
            os._exit(self.EXIT_CODE)

    def check(self) -> None:
        if self.received is not None:
            raise KeyboardInterrupt(f"received signal {signal.Signals(self.received).name}")

    def disarm(self) -> None:
        if not self._main_thread():
            return
        if self._pipe is not None:
            signal.set_wakeup_fd(self._previous_wakeup if self._previous_wakeup is not None else -1)
            r, w = self._pipe
            os.close(w)
            if self._thread is not None:
                self._thread.join(timeout=1.0)
            os.close(r)
            self._pipe = self._thread = None
            self._previous_wakeup = None
        for s, prev in self._previous.items():
            signal.signal(s, prev if prev is not None else signal.SIG_DFL)
        self._previous.clear()

    def __enter__(self) -> "InterruptGuard":
        return self.arm()

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.disarm()
        return False


class StagedOutputs:
    """A set of files written under temporary names and renamed together.

    Use as a context manager: write each file to :meth:`temp` (holding the guard's
    :meth:`InterruptGuard.io` lock); leaving the block normally renames them all (in
    the given order, so a sidecar listed last marks a complete set); leaving it by an
    exception, KeyboardInterrupt included, deletes them.  With a ``guard``, an abort
    by signal deletes them too.
    """

    def __init__(self, finals: Iterable[str | os.PathLike], guard: InterruptGuard | None = None):
        self.finals = [Path(f) for f in finals]
        self._temps = {f: temp_path(f) for f in self.finals}
        self.guard = guard
        self.committed: list[Path] = []

    def temp(self, final: str | os.PathLike) -> Path:
        return self._temps[Path(final)]

    def _lock(self):
        return self.guard.io() if self.guard is not None else contextlib.nullcontext()

    def __enter__(self) -> "StagedOutputs":
        with self._lock():
            for f in self.finals:
                f.parent.mkdir(parents=True, exist_ok=True)
        if self.guard is not None:
            self.guard.add_cleanup(self.discard)
        return self

    def commit(self) -> list[Path]:
        with self._lock():
            missing = [str(t) for t in self._temps.values() if not t.exists()]
            if missing:
                raise RuntimeError("outputs were not written: " + ", ".join(missing))
            for f in self.finals:
                os.replace(self._temps[f], f)
                self.committed.append(f)
        return list(self.committed)

    def discard(self) -> None:
        """Delete the temporary files (and Blender's partial files for them)."""
        with self._lock():
            for t in self._temps.values():
                for p in [t, *t.parent.glob(f".{t.stem}.partial*{t.suffix}"), t.with_name(t.name + ".rewrite")]:
                    try:
                        p.unlink()
                    except FileNotFoundError:
                        pass

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self.commit()
        finally:
            self.discard()
            if self.guard is not None:
                self.guard.remove_cleanup(self.discard)
        return False


# ---------------------------------------------------------------------------
# PNG
def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Blender's 'Standard' view transform on an sRGB display: clip to [0, 1], sRGB OETF."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def to_srgb8(linear_rgb: np.ndarray, alpha: np.ndarray | None = None) -> np.ndarray:
    """8-bit sRGB pixels (H, W, 3) or, with ``alpha`` (premultiplied input), straight RGBA."""
    rgb = np.asarray(linear_rgb, dtype=np.float64)[..., :3]
    if alpha is not None:
        a = np.clip(np.asarray(alpha, dtype=np.float64), 0.0, 1.0)
        rgb = np.where(a[..., None] > 0.0, rgb / np.maximum(a[..., None], 1e-12), 0.0)
        rgb = np.concatenate([srgb_encode(rgb), a[..., None]], axis=-1)
    else:
        rgb = srgb_encode(rgb)
    return np.round(rgb * 255.0).astype(np.uint8)


def write_png(path: str | os.PathLike, linear_rgb: np.ndarray, alpha: np.ndarray | None = None) -> Path:
    """Write linear scene-referred pixels (row 0 at the top) as an 8-bit sRGB PNG."""
    from PIL import Image

    pixels = to_srgb8(linear_rgb, alpha)
    Image.fromarray(pixels, "RGBA" if pixels.shape[-1] == 4 else "RGB").save(str(path), format="PNG")
    return Path(path)


# ---------------------------------------------------------------------------
# EXR
def read_exr_layers(path: str | os.PathLike) -> dict[str, dict[str, np.ndarray]]:
    """Parts of a multilayer EXR: ``{part name: {channel name: float32 array (H, W)}}``."""
    import OpenEXR

    out: dict[str, dict[str, np.ndarray]] = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            out[part.name()] = {name: np.array(ch.pixels) for name, ch in part.channels.items()}
    return out


def exr_beauty(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray | None]:
    """The Combined pass of a Blender multilayer EXR: RGB (H, W, 3) and alpha (or None)."""
    for channels in read_exr_layers(path).values():
        for prefix in ("ViewLayer.Combined.", "Combined.", ""):
            keys = [prefix + c for c in "RGB"]
            if all(k in channels for k in keys):
                rgb = np.stack([channels[k] for k in keys], axis=-1).astype(np.float64)
                a = channels.get(prefix + "A")
                return rgb, (None if a is None else a.astype(np.float64))
    raise KeyError(f"{path} has no Combined RGB channels")


def replace_exr_layers(path: str | os.PathLike, layers: Mapping[str, Mapping[str, np.ndarray]],
                       view_layer: str = "ViewLayer") -> None:
    """Rewrite ``path`` in place with the passes in ``layers`` replaced or added.

    ``layers`` maps a pass name (e.g. ``layer_thickness``) to its channels
    (e.g. ``{"X": array}``); channels are stored as ``ViewLayer.PASS.CHANNEL`` in a
    part named ``ViewLayer.PASS``, as Blender writes them.  The other parts and the
    file's headers are kept.
    """
    import OpenEXR

    path = Path(path)
    with OpenEXR.File(str(path), separate_channels=True) as f:
        parts = []
        for part in f.parts:
            header = dict(part.header)
            channels = {name: np.array(ch.pixels) for name, ch in part.channels.items()}
            parts.append((part.name(), header, channels))
    by_name = {name: (header, channels) for name, header, channels in parts}
    order = [name for name, _, _ in parts]
    template = dict(parts[0][1])
    for pass_name, chans in layers.items():
        part_name = f"{view_layer}.{pass_name}"
        if part_name in by_name:
            header = dict(by_name[part_name][0])
        else:
            header = dict(template)
            header["colorInteropID"] = "data"
        header["name"] = part_name
        channels = {f"{part_name}.{c}": np.ascontiguousarray(a, dtype=np.float32) for c, a in chans.items()}
        by_name[part_name] = (header, channels)
        if part_name not in order:
            order.append(part_name)
    keep = {"compression", "name", "type", "lineOrder", "pixelAspectRatio", "screenWindowCenter",
            "screenWindowWidth", "colorInteropID"}
    new_parts = []
    for name in order:
        header, channels = by_name[name]
        header = {k: v for k, v in header.items() if k in keep or (isinstance(v, str) and k not in
                                                                     ("dataWindow", "displayWindow"))}
        new_parts.append(OpenEXR.Part(header, channels, name))
    tmp = path.with_name(path.name + ".rewrite")
    try:
        with OpenEXR.File(new_parts) as out:
            out.write(str(tmp))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


# ---------------------------------------------------------------------------
# sidecar
def to_jsonable(value: Any) -> Any:
    """numpy scalars and arrays, paths and tuples as plain JSON values."""
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def write_json(path: str | os.PathLike, data: Mapping[str, Any]) -> Path:
    Path(path).write_text(json.dumps(to_jsonable(data), indent=2, sort_keys=False) + "\n", encoding="utf-8")
    return Path(path)


def read_sidecar(path: str | os.PathLike) -> dict[str, Any]:
    """A render's sidecar (``stem.json`` or any path of the set)."""
    p = Path(path)
    if p.suffix.lower() != ".json":
        p = OutputPaths(output_stem(p)).json
    data = json.loads(p.read_text(encoding="utf-8"))
    if data.get("format") != SIDECAR_FORMAT:
        raise ValueError(f"{p} is not a layered-brdf sidecar")
    return data


def camera_to_dict(camera) -> dict[str, Any]:
    """An :class:`~layered_brdf_addon.model.sphere.OrthoCamera` with its world matrix."""
    return {"type": "ORTHO", "view": list(camera.view), "ortho_scale": camera.ortho_scale,
            "width": camera.width, "height": camera.height, "target": list(camera.target),
            "distance": camera.distance, "matrix_world": camera.matrix_world()}


def camera_from_dict(d: Mapping[str, Any]):
    from .model.sphere import OrthoCamera

    return OrthoCamera(view=tuple(d["view"]), ortho_scale=float(d["ortho_scale"]), width=int(d["width"]),
                       height=int(d["height"]), target=tuple(d.get("target", (0.0, 0.0, 0.0))),
                       distance=float(d.get("distance", 10.0)))


def sun_to_dict(sun) -> dict[str, Any]:
    return {"direction": list(sun.direction), "l": sun.l, "strength": sun.strength, "angle": 0.0}


def sun_from_dict(d: Mapping[str, Any]):
    from .model.sphere import Sun

    return Sun(direction=tuple(d["direction"]), strength=float(d["strength"]))


@dataclass
class SidecarScene:
    """What :func:`~layered_brdf_addon.model.sphere.render_spheres` needs to predict a render."""

    params: list
    camera: Any
    sun: Any
    centers: tuple


def scene_from_sidecar(data: Mapping[str, Any]) -> SidecarScene:
    """Parameters, camera, sun and sphere centres recorded by a reference-sphere render or the gallery."""
    from .model.params import LayeredParams

    if data.get("scene") not in ("reference", "gallery"):
        raise ValueError("only reference-sphere renders and galleries can be predicted "
                         f"(this sidecar's scene is {data.get('scene')!r})")
    if "tiles" in data:
        params = [LayeredParams.from_dict(t["params"]) for t in data["tiles"]]
    else:
        params = [LayeredParams.from_dict(data["params"])]
    centers = tuple(tuple(c) for c in data["centers"])
    return SidecarScene(params, camera_from_dict(data["camera"]), sun_from_dict(data["sun"]), centers)


def format_table(headers: Sequence[str], rows: Iterable[Sequence[Any]], max_width: int | None = None) -> str:
    """A plain-text table; with ``max_width`` the last column is cut to keep lines that short."""
    rows = [[str(c) for c in r] for r in rows]
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(headers)]
    fixed = sum(widths[:-1]) + 2 * (len(headers) - 1)
    if max_width is not None:
        widths[-1] = max(len(headers[-1]), min(widths[-1], max_width - fixed))

    def line(cells):
        out = []
        for i, (c, w) in enumerate(zip(cells, widths)):
            if i == len(cells) - 1:
                out.append(c if len(c) <= w else c[: max(1, w - 1)] + "\u2026")
            else:
                out.append(c.rjust(w) if _numeric(c) else c.ljust(w))
        return "  ".join(out).rstrip()

    sep = "  ".join("-" * (w if i < len(widths) - 1 else min(w, 40)) for i, w in enumerate(widths))
    return "\n".join([line(list(headers)), sep] + [line(r) for r in rows])


def _numeric(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
