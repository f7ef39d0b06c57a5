"""A reference-sphere render as a fitting target for the panel's *Fit to Render...*: its
sidecar ``STEM.json`` and beauty pass ``STEM.exr`` read back as a
:class:`~..fit.targets.SphereView` (``layered-brdf fit`` reads its targets in
``cli/fit_command.py``, with the command line's own checks and messages).

The sidecar records the camera, the sun and the sphere centres of a ``render`` of the
reference scene or of a ``gallery``; the EXR's Combined pass holds the linear pixels.  The
EXR is read with the OpenEXR module (the project's own environment) or, where that is
missing, OpenImageIO (bundled with Blender).  Imports no bpy.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Callable

import numpy as np

from ..io.codecs import exr_beauty
from ..io.sidecar import read_sidecar, scene_from_sidecar
from ..io.staging import OutputPaths, output_stem
from ..fit.targets import SphereView, TargetError


def read_exr_beauty(path: str | os.PathLike) -> np.ndarray:
    """The Combined pass (H, W, 3), row 0 at the top, of a Blender EXR (multilayer or not)."""
    try:
        import OpenEXR  # noqa: F401
    except ImportError:
        return _beauty_with_openimageio(path)
    return exr_beauty(path)[0]


def _beauty_with_openimageio(path) -> np.ndarray:
    try:
        import OpenImageIO as oiio
    except ImportError:
        raise TargetError("reading an EXR needs the OpenEXR or OpenImageIO Python module") from None
    image = oiio.ImageInput.open(str(path))
    if image is None:
        raise TargetError(f"{path}: {oiio.geterror() or 'not an image OpenImageIO can read'}")
    try:
        subimage = 0
        while image.seek_subimage(subimage, 0):  # a multilayer EXR: one part per pass
            names = list(image.spec().channelnames)
            for prefix in ("ViewLayer.Combined.", "Combined.", ""):
                keys = [prefix + c for c in "RGB"]
                if all(k in names for k in keys):
                    pixels = image.read_image(subimage, 0, 0, len(names), "float")
                    return np.asarray(pixels, dtype=np.float64)[..., [names.index(k) for k in keys]]
            subimage += 1
    finally:
        image.close()
    raise TargetError(f"{path} has no Combined RGB channels")


def _exr_of(sidecar: Path, data: dict) -> Path:
    """The sidecar's EXR: beside it under the same stem (the files travel together), else
    where the sidecar says it was written."""
    beside = sidecar.with_suffix(".exr")
    if beside.is_file():
        return beside
    recorded = (data.get("outputs") or {}).get("exr")
    if isinstance(recorded, str) and Path(recorded).is_file():
        return Path(recorded)
    raise TargetError(f"{sidecar.name}: its EXR is neither beside it ({beside.name}) nor at {recorded!r}")


def sidecar_views(path: str | os.PathLike, *, sphere: int = 0,
                  read_beauty: Callable[[Path], np.ndarray] | None = None) -> list[SphereView]:
    """The render whose sidecar is ``path`` (``STEM.json``, or any file of the set) as one
    view of sphere ``sphere`` (a gallery holds several; a render one).

    ``read_beauty(exr_path)`` reads the EXR's Combined pass (default :func:`read_exr_beauty`).
    A file that is not the sidecar of a reference-sphere render or gallery, a missing EXR or
    sphere is a :class:`~..fit.targets.TargetError` saying which.
    """
    p = Path(path)
    json_path = p if p.suffix.lower() == ".json" else OutputPaths(output_stem(p)).json
    try:
        data = read_sidecar(json_path)
        scene = scene_from_sidecar(data)
    except OSError as e:
        raise TargetError(f"{json_path}: {e.strerror or e}") from None
    except (ValueError, KeyError, TypeError) as e:
        reason = f"lacks {e}" if isinstance(e, KeyError) else str(e)
        if isinstance(e, json.JSONDecodeError):
            reason = f"not JSON ({e.msg}, line {e.lineno})"
        raise TargetError(reason if json_path.name in reason else f"{json_path.name}: {reason}") from None
    count = len(scene.centers)
    if isinstance(sphere, bool) or not isinstance(sphere, int) or not 0 <= sphere < count:
        raise TargetError(f"{json_path.name} holds {count} sphere(s): sphere {sphere!r} is not one of 0..{count - 1}")
    exr = _exr_of(json_path, data)
    try:
        image = (read_beauty or read_exr_beauty)(exr)
    except TargetError:
        raise
    except (OSError, KeyError, ValueError) as e:
        raise TargetError(f"{exr.name}: {e}") from None
    return [SphereView(np.asarray(image, dtype=np.float64), scene.camera, scene.sun, scene.centers, sphere)]
