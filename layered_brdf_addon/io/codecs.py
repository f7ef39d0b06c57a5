"""Image files of a render: 8-bit sRGB PNG from linear pixels, multilayer float EXR.

Nothing here imports bpy.
"""
from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np


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


def save_png(path: str | os.PathLike, pixels: np.ndarray) -> Path:
    """Write 8-bit pixels (H, W, 3) or (H, W, 4), row 0 at the top, as a PNG."""
    from PIL import Image

    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    Image.fromarray(pixels, "RGBA" if pixels.shape[-1] == 4 else "RGB").save(str(path), format="PNG")
    return Path(path)


def read_exr_layers(path: str | os.PathLike) -> dict[str, dict[str, np.ndarray]]:
    """Parts of a multilayer EXR: ``{part name: {channel name: float32 array (H, W)}}``."""
    import OpenEXR

    out: dict[str, dict[str, np.ndarray]] = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            out[part.name()] = {name: np.array(ch.pixels) for name, ch in part.channels.items()}
    return out


@contextlib.contextmanager
def muted_stderr() -> Iterator[None]:
    """Send what is printed on the standard error (file descriptor 2) to /dev/null for the block.

    OpenEXR's library prints a line for every damaged chunk of a file cut short; the
    caller that reads such a file says what went wrong in one line instead.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def read_complete_exr_layers(path: str | os.PathLike) -> dict[str, dict[str, np.ndarray]]:
    """:func:`read_exr_layers` of a file that holds every part and channel its header lists;
    else ValueError naming what is missing.

    OpenEXR's Python binding leaves out, with only a warning, a part whose pixels cannot
    be read: a file cut short (by a full disk) would read as a file with fewer passes.
    """
    import OpenEXR

    layers = read_exr_layers(path)
    with OpenEXR.File(str(path), header_only=True) as f:
        listed = [(part.name(), [c.name for c in part.header.get("channels", [])]) for part in f.parts]
    missing = [name for name, channels in listed
               if name not in layers or any(c not in layers[name] for c in channels)]
    if missing:
        raise ValueError(f"{path} is incomplete: the pixels of part(s) {', '.join(map(str, missing))} "
                         "cannot be read")
    return layers


def exr_beauty(path: str | os.PathLike, layers: Mapping[str, Mapping[str, np.ndarray]] | None = None
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """The Combined pass of a Blender multilayer EXR: RGB (H, W, 3) and alpha (or None),
    from ``layers`` when they were read already."""
    for channels in (read_exr_layers(path) if layers is None else layers).values():
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
