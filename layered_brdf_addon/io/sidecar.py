"""The sidecar ``STEM.json`` of a render: its schema, writing and reading it, and the
scene it records (enough to predict a reference-sphere render's pixels).

Nothing here imports bpy.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..model.errors import ParameterError
from ..model.params import LayeredParams
from ..model.sphere import OrthoCamera, Sun
from .messages import shown
from .regular_files import MAX_INPUT_BYTES, FileRefused, read_regular_bytes
from .staging import OutputPaths, output_stem

SIDECAR_FORMAT = "layered-brdf render"
SIDECAR_VERSION = 1
MAX_RESOLUTION = 16384  # pixels along an image's side, at most (a render's option, a sidecar's camera)


def to_jsonable(value: Any) -> Any:
    """numpy scalars and arrays, paths, tuples and values that give their own dict (a film stack) as plain
    JSON values."""
    if hasattr(value, "to_dict") and not isinstance(value, Mapping):
        return to_jsonable(value.to_dict())
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


_JSON_KINDS = {list: "array", str: "string", int: "number", float: "number", bool: "boolean", type(None): "null"}


class SidecarError(ValueError):
    """A render's sidecar (or the render it describes) that cannot be read as asked: ``reason``
    says why, ``field`` which input it concerns (``"target"``: the render's files; ``"tile"``: the
    sphere chosen of it), ``path`` the sidecar."""

    def __init__(self, reason: str, field: str = "target", path: str | os.PathLike | None = None):
        self.reason = reason
        self.field = field
        self.path = None if path is None else Path(path)
        super().__init__(reason if path is None else f"{path}: {reason}")


def sidecar_path(path: str | os.PathLike) -> Path:
    """The sidecar ``STEM.json`` of any path of a render's set (``STEM``, ``STEM.json``, ``STEM.exr``,
    ``STEM.png``)."""
    p = Path(path)
    return p if p.suffix.lower() == ".json" else OutputPaths(output_stem(p)).json


def read_sidecar(path: str | os.PathLike) -> dict[str, Any]:
    """A render's sidecar (``STEM.json`` or any path of the set) as a dict; :class:`SidecarError`
    saying why when it cannot be read (missing, not a regular file, over :data:`MAX_INPUT_BYTES`,
    not UTF-8 JSON) or is not the sidecar of a layered-brdf render."""
    p = sidecar_path(path)
    try:
        raw = read_regular_bytes(p, limit=MAX_INPUT_BYTES)
    except FileRefused as e:
        raise SidecarError(e.reason, path=p) from None
    try:
        data = json.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as e:
        raise SidecarError(f"not UTF-8 text ({e})", path=p) from None
    except json.JSONDecodeError as e:
        raise SidecarError(f"not JSON ({e.msg}, line {e.lineno} column {e.colno})", path=p) from None
    except RecursionError:
        raise SidecarError("values nested deeper than can be read", path=p) from None
    except ValueError:  # the parser's only other error: int() refuses a literal of over 4300 digits
        raise SidecarError("an integer too long to read", path=p) from None
    if not isinstance(data, dict) or data.get("format") != SIDECAR_FORMAT:
        what = (f"its format is {shown(data.get('format'))!r}, not {SIDECAR_FORMAT!r}" if isinstance(data, dict)
                else f"a JSON {_JSON_KINDS.get(type(data), 'value')}, not an object whose format is {SIDECAR_FORMAT!r}")
        raise SidecarError(f"not the sidecar of a layered-brdf render ({what})", path=p)
    return data


def camera_to_dict(camera) -> dict[str, Any]:
    """An :class:`~layered_brdf_addon.model.sphere.OrthoCamera` with its world matrix."""
    return {"type": "ORTHO", "view": list(camera.view), "ortho_scale": camera.ortho_scale,
            "width": camera.width, "height": camera.height, "target": list(camera.target),
            "distance": camera.distance, "matrix_world": camera.matrix_world()}


def _number(name: str, value: Any, allowed: str, ok=lambda x: True) -> float:
    """A finite JSON number of a sidecar's field ``name`` for which ``ok`` holds; ParameterError naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not ok(value):
        raise ParameterError(name, shown(value), allowed)
    return float(value)


def _direction(name: str, value: Any) -> tuple[float, float, float]:
    """Three finite numbers whose direction can be taken (length above 1e-9, its square finite)."""
    allowed = "three finite numbers, not all zero (a direction)"
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ParameterError(name, shown(value), allowed)
    xyz = tuple(_number(name, c, allowed) for c in value)
    n2 = math.fsum(c * c for c in xyz)
    if not math.isfinite(n2) or n2 < 1e-18:
        raise ParameterError(name, shown(value), allowed)
    return xyz  # type: ignore[return-value]


def _pixels(name: str, value: Any) -> int:
    allowed = f"a whole number of pixels in [1, {MAX_RESOLUTION}]"
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_RESOLUTION:
        raise ParameterError(name, shown(value), allowed)
    return value


def camera_from_dict(d: Mapping[str, Any]) -> OrthoCamera:
    """The recorded orthographic camera; ParameterError naming the field that no camera can have."""
    if not isinstance(d, Mapping):
        raise ParameterError("camera", shown(d), "a mapping (the sidecar's camera)")
    target = d.get("target", (0.0, 0.0, 0.0))
    if not isinstance(target, (list, tuple)) or len(target) != 3:
        raise ParameterError("camera.target", shown(target), "three finite numbers (a point)")
    return OrthoCamera(view=_direction("camera.view", d.get("view")),
                       ortho_scale=_number("camera.ortho_scale", d.get("ortho_scale"), "a finite number > 0",
                                           lambda x: x > 0),
                       width=_pixels("camera.width", d.get("width")), height=_pixels("camera.height", d.get("height")),
                       target=tuple(_number("camera.target", c, "three finite numbers (a point)") for c in target),
                       distance=_number("camera.distance", d.get("distance", 10.0), "a finite number > 0",
                                        lambda x: x > 0))


def sun_to_dict(sun) -> dict[str, Any]:
    return {"direction": list(sun.direction), "l": sun.l, "strength": sun.strength, "angle": 0.0}


def sun_from_dict(d: Mapping[str, Any]) -> Sun:
    """The recorded sun; ParameterError naming the field that no sun can have."""
    if not isinstance(d, Mapping):
        raise ParameterError("sun", shown(d), "a mapping (the sidecar's sun)")
    return Sun(direction=_direction("sun.direction", d.get("direction")),
               strength=_number("sun.strength", d.get("strength"), "a finite number > 0 (W/m^2)", lambda x: x > 0))


def _centers(value: Any) -> tuple:
    allowed = "a non-empty list of sphere centres, each three finite numbers"
    if not isinstance(value, (list, tuple)) or not value:
        raise ParameterError("centers", shown(value), allowed)
    for c in value:
        if not isinstance(c, (list, tuple)) or len(c) != 3:
            raise ParameterError("centers", shown(value), allowed)
    return tuple(tuple(_number("centers", x, allowed) for x in c) for c in value)


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
    centers = _centers(data.get("centers"))
    if len(centers) != len(params):
        raise ParameterError("centers", shown(data.get("centers")),
                             f"one centre per sphere ({len(params)} in this sidecar)")
    return SidecarScene(params, camera_from_dict(data["camera"]), sun_from_dict(data["sun"]), centers)
