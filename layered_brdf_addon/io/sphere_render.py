"""A reference-sphere render read back as the target of a fit: its sidecar ``STEM.json`` (the camera,
the sun and the sphere centres of a ``render`` of the reference scene or of a ``gallery``) and the
Combined pass of its EXR ``STEM.exr``, with the sphere to fit.

:func:`read_sphere_render` does every check once and raises :class:`~.sidecar.SidecarError` saying
why a render cannot be fitted; the command line and the panel each say it in their own way.  The
EXR's reader is the caller's (the panel's Blender may lack the OpenEXR module).  Nothing here
imports bpy.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..model.errors import ParameterError
from ..model.sphere import sphere_geometry
from .messages import shown
from .regular_files import file_label
from .sidecar import SidecarError, SidecarScene, read_sidecar, scene_from_sidecar, sidecar_path

FITTED_SCENES = ("reference", "gallery")
SCENE_REFUSALS = {
    "blend": "a render of a .blend (--blend), whose geometry and lights numpy does not know",
    "lookdev": "a look-dev sheet (a shader ball under an HDRI)",
}


@dataclass
class SphereRender:
    """A render's pixels and scene, read back: the image (H, W, 3) of linear RGB, row 0 at the top
    (float64), the scene its sidecar records, the index of the sphere to fit and, in a gallery,
    its tile's name; the sidecar as read and the paths of the sidecar and the EXR."""

    image: np.ndarray
    scene: SidecarScene
    sphere: int
    tile: str | None
    sidecar: dict[str, Any]
    json_path: Path
    exr_path: Path

    @property
    def kind(self) -> str:
        """The sidecar's scene: ``"reference"`` or ``"gallery"``."""
        return self.sidecar["scene"]


def read_sphere_render(path: str | os.PathLike, read_beauty: Callable[[Path], Any], *, tile: Any = None,
                       sphere: int | None = None) -> SphereRender:
    """The render whose set holds ``path`` (``STEM``, ``STEM.json``, ``STEM.exr`` or ``STEM.png``),
    read as a :class:`SphereRender`.

    The sphere is chosen by ``tile`` (a gallery's tile by its name or index: required for a
    gallery, refused for a reference render, which holds one sphere) or by ``sphere`` (an index
    among the spheres of any render; not with ``tile``).  ``read_beauty(exr_path)`` reads the
    EXR's Combined pass (H, W, 3).  Raises :class:`~.sidecar.SidecarError` saying why (its
    ``field`` is ``"tile"`` for the choice of sphere, else ``"target"``) when the sidecar cannot
    be read, is not a reference-sphere render's or records a camera, sun or spheres no render can
    have, when no sphere or several match the choice, and when the EXR is missing, cannot be
    read, is not of the camera's size or holds NaN or infinite pixels on the sphere.
    """
    if tile is not None and sphere is not None:
        raise TypeError("read_sphere_render: a tile or a sphere, not both")
    json_path = sidecar_path(path)
    data = read_sidecar(json_path)

    def refuse(reason: str, field: str = "target") -> SidecarError:
        return SidecarError(reason, field, json_path)

    kind = data.get("scene")
    if kind not in FITTED_SCENES:
        what = SCENE_REFUSALS.get(kind, f"a sidecar of scene {shown(kind)!r}")
        raise refuse(f"only reference-sphere renders can be reproduced in numpy; this is {what}")
    try:
        scene = scene_from_sidecar(data)
    except KeyError as e:
        key = shown(e.args[0] if e.args else None)
        raise refuse(f"its camera, sun or spheres cannot be read: it lacks the key {key!r}") from None
    except (TypeError, ValueError, AttributeError, ParameterError) as e:
        raise refuse(f"its camera, sun or spheres cannot be read: {e}") from None
    index, name = _sphere_of(data, len(scene.centers), tile, sphere, refuse)
    exr = exr_of(json_path, data, refuse)
    image = _beauty(exr, read_beauty, refuse)
    w, h = scene.camera.width, scene.camera.height
    if image.shape[:2] != (h, w):
        raise refuse(f"its EXR is {image.shape[1]}x{image.shape[0]} pixels where the sidecar's camera renders "
                     f"{w}x{h}")
    _check_sphere_pixels(image, scene, index, refuse)
    return SphereRender(image, scene, index, name, data, json_path, exr)


def _sphere_of(data: dict, count: int, tile: Any, sphere: int | None,
               refuse: Callable[..., SidecarError]) -> tuple[int, str | None]:
    """The index of the sphere to fit, and its tile's name in a gallery (else None)."""
    tiles = data.get("tiles") if data.get("scene") == "gallery" else None
    names = [t.get("name") if isinstance(t, dict) else None for t in tiles] if isinstance(tiles, list) else []
    named = [n for n in names if isinstance(n, str)]
    choices = (f"a name among {', '.join(named)} or " if named else "") + f"an index in [0, {count - 1}]"

    def one_of_them(k: Any) -> tuple[int, str | None]:
        if isinstance(k, int) and not isinstance(k, bool) and 0 <= k < count:
            return k, names[k] if k < len(names) and isinstance(names[k], str) else None
        raise refuse(f"it holds {count} sphere(s): {shown(k)!r} is not one of them (choose {choices})", "tile")

    if sphere is not None:
        return one_of_them(sphere)
    if data.get("scene") != "gallery":
        if tile is not None:
            raise refuse("a reference render holds one sphere: no tile is chosen of it", "tile")
        return 0, None
    if tile is None:
        raise refuse(f"a gallery holds several spheres: choose one of its tiles, {choices}", "tile")
    if isinstance(tile, str) and tile in named:
        return names.index(tile), tile
    try:
        k = int(tile)
    except (TypeError, ValueError, OverflowError):
        k = tile
    return one_of_them(k)


def exr_of(sidecar: Path, data: dict, refuse: Callable[..., SidecarError]) -> Path:
    """The sidecar's EXR: beside it under the same stem (the files travel together), else where
    the sidecar says it was written; ``refuse(reason)`` raised when it is at neither."""
    beside = sidecar.with_suffix(".exr")
    if beside.is_file():
        return beside
    outputs = data.get("outputs")
    recorded = outputs.get("exr") if isinstance(outputs, dict) else None
    if isinstance(recorded, str) and recorded and Path(recorded).is_file():
        return Path(recorded)
    elsewhere = (f" (nor at {file_label(recorded)}, where it was written)"
                 if isinstance(recorded, str) and recorded and Path(recorded) != beside else "")
    raise refuse(f"its EXR {file_label(beside)} is missing{elsewhere}: the target image is the EXR's Combined pass")


def _beauty(exr: Path, read_beauty: Callable[[Path], Any], refuse: Callable[..., SidecarError]) -> np.ndarray:
    """The EXR's Combined pass as float64 (H, W, 3)."""
    try:
        image = np.asarray(read_beauty(exr), dtype=np.float64)
    except Exception as e:  # any reader's failure on any file is this file's fault, said in one line
        raise refuse(f"its EXR {file_label(exr)} cannot be read: {e.__class__.__name__}: {e}") from None
    if image.ndim != 3 or image.shape[2] < 3:
        raise refuse(f"its EXR {file_label(exr)} holds no RGB image (an array of shape {image.shape})")
    return image[..., :3]


def _check_sphere_pixels(image: np.ndarray, scene: SidecarScene, sphere: int,
                         refuse: Callable[..., SidecarError]) -> None:
    """``refuse(reason)`` raised when the camera sees no pixel of the sphere or some of them are
    NaN or infinite."""
    geo = sphere_geometry(scene.camera, scene.centers)
    pixels = image[geo.sphere == sphere]
    if not len(pixels):
        raise refuse(f"its camera sees no pixel of sphere {sphere}")
    bad = int(np.count_nonzero(~np.all(np.isfinite(pixels), axis=-1)))
    if bad:
        raise refuse(f"{bad} of the sphere's {len(pixels)} pixels in its EXR are NaN or infinite")
