"""A reference-sphere render as a fitting target for the panel's *Fit to Render...*: its
sidecar ``STEM.json`` and beauty pass ``STEM.exr`` read back as a
:class:`~..fit.targets.SphereView`.

:func:`..io.sphere_render.read_sphere_render` reads and checks the render (``layered-brdf fit``
reads its targets with it too); its refusal is the panel's :class:`~..fit.targets.TargetError`.
The EXR is read with the OpenEXR module where it is installed (the project's own environment),
else with :mod:`..io.exr_reader` (numpy alone: Blender's Python, the installed extension).
Imports no bpy.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np

from ..io.codecs import exr_beauty
from ..io.exr_reader import read_exr
from ..io.sidecar import SidecarError, sidecar_path
from ..io.sphere_render import read_sphere_render
from ..fit.targets import SphereView, TargetError


def read_exr_beauty(path: str | os.PathLike) -> np.ndarray:
    """The Combined pass (H, W, 3), row 0 at the top, of a Blender EXR (multilayer or not)."""
    try:
        import OpenEXR  # noqa: F401
    except ImportError:
        return exr_beauty(path, read_exr(path))[0]  # ExrError says why a file cannot be read
    return exr_beauty(path)[0]


def sidecar_views(path: str | os.PathLike, *, sphere: int = 0,
                  read_beauty: Callable[[Path], np.ndarray] | None = None) -> list[SphereView]:
    """The render whose sidecar is ``path`` (``STEM.json``, or any file of the set) as one
    view of sphere ``sphere`` (a gallery holds several; a render one), read by
    :func:`..io.sphere_render.read_sphere_render`.

    ``read_beauty(exr_path)`` reads the EXR's Combined pass (default :func:`read_exr_beauty`).
    Returns a list of one :class:`~..fit.targets.SphereView`; raises
    :class:`~..fit.targets.TargetError` naming the sidecar and saying why when the render cannot
    be fitted (not the sidecar of a reference-sphere render or gallery, no such sphere, an EXR
    missing, unreadable, of another size than the camera's or with NaN pixels).
    """
    try:
        render = read_sphere_render(path, read_beauty or read_exr_beauty, sphere=sphere)
    except SidecarError as e:
        name = (e.path or sidecar_path(path)).name
        raise TargetError(f"{name}: {e.reason}") from None
    scene = render.scene
    return [SphereView(render.image, scene.camera, scene.sun, scene.centers, render.sphere)]
