"""The sidecar ``STEM.json`` of a render: its schema, writing and reading it, and the
scene it records (enough to predict a reference-sphere render's pixels).

Nothing here imports bpy.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..model.params import LayeredParams
from ..model.sphere import OrthoCamera, Sun
from .staging import OutputPaths, output_stem

SIDECAR_FORMAT = "layered-brdf render"
SIDECAR_VERSION = 1


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


def camera_from_dict(d: Mapping[str, Any]) -> OrthoCamera:
    return OrthoCamera(view=tuple(d["view"]), ortho_scale=float(d["ortho_scale"]), width=int(d["width"]),
                       height=int(d["height"]), target=tuple(d.get("target", (0.0, 0.0, 0.0))),
                       distance=float(d.get("distance", 10.0)))


def sun_to_dict(sun) -> dict[str, Any]:
    return {"direction": list(sun.direction), "l": sun.l, "strength": sun.strength, "angle": 0.0}


def sun_from_dict(d: Mapping[str, Any]) -> Sun:
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
    if data.get("scene") not in ("reference", "gallery"):
        raise ValueError("only reference-sphere renders and galleries can be predicted "
                         f"(this sidecar's scene is {data.get('scene')!r})")
    if "tiles" in data:
        params = [LayeredParams.from_dict(t["params"]) for t in data["tiles"]]
    else:
        params = [LayeredParams.from_dict(data["params"])]
    centers = tuple(tuple(c) for c in data["centers"])
    return SidecarScene(params, camera_from_dict(data["camera"]), sun_from_dict(data["sun"]), centers)
