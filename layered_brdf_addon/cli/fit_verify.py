"""``fit --verify``: the fitted material rendered as the target was, and the two images compared.

The fit reports the mean CIEDE2000 over every pixel of the sphere between the target and the closure
form computed in numpy.  A user judges a fit by rendering it: here the fitted parameters go through
``layered-brdf render`` (a subprocess, the path every render takes) with the target's camera, sun,
samples, seed and backend, and every pixel of the sphere is compared in the same colour pipeline as the
fit's figure (CIELAB against the fit's white, CIEDE2000).  The render lives in a
temporary folder, removed afterwards; nothing of it is left beside the outputs.

A target that is not a render of the reference scene (a gallery's tile, a reflectance table, a
Principled BSDF material) cannot be re-rendered this way: :func:`check_verifiable` says so before
the fit, and :func:`check_camera` (a render with a camera of its own) once the target is read, before
the fit too.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..fit import colour_space
from ..io.sidecar import camera_from_dict, read_sidecar
from ..io.staging import OutputPaths
from ..model.params import LayeredParams, ParameterError
from ..model.sphere import OrthoCamera
from .fit_targets import read_complete_beauty

VERIFY_ALLOWED = "no value but with TARGET, a render of the reference sphere ('layered-brdf render' without --blend)"


def check_verifiable(source, tile: Any) -> None:
    """ParameterError naming ``verify`` unless the target is a reference-sphere render (a gallery's
    tile has another camera; a table or a Principled BSDF material has no render to repeat)."""
    if source.kind != "render" or tile is not None:
        raise ParameterError("verify", True, VERIFY_ALLOWED)


def check_camera(loaded_record: dict) -> None:
    """ParameterError naming ``verify`` unless the loaded render's camera is the reference scene's
    (``render`` repeats no other): called once the target is read, before the fit."""
    camera = read_sidecar(loaded_record["sidecar"])["camera"]
    if camera_from_dict(camera) != OrthoCamera(width=camera["width"], height=camera["height"]):
        raise ParameterError("verify", True, VERIFY_ALLOWED + " whose camera is the reference scene's")


def render_arguments(sidecar: dict, params_file: Path, stem: Path) -> list[str]:
    """``render``'s arguments that repeat the target's render with the parameters of ``params_file``."""
    camera, sun = sidecar["camera"], sidecar["sun"]
    return ["render", "--params", str(params_file), "--resolution", f"{camera['width']}x{camera['height']}",
            "--samples", str(sidecar.get("samples", 1)), "--seed", str(sidecar.get("seed", 0)),
            "--backend", str(sidecar.get("backend", "nodes")), "--sun", *(repr(float(c)) for c in sun["direction"]),
            "--sun-strength", repr(float(sun["strength"])), "--output", str(stem)]


def verify(target, loaded_record: dict, params: LayeredParams, guard=None) -> dict:
    """The fitted ``params`` rendered as the target was and compared over every pixel of the sphere:
    ``{"mean_delta_e_2000", "pixels", "render_seconds"}``.  A render that fails raises
    RuntimeError with its last message."""
    sidecar = read_sidecar(loaded_record["sidecar"])
    with tempfile.TemporaryDirectory(prefix="layered-brdf-verify-") as folder:
        params_file = Path(folder) / "fit.json"
        params_file.write_text(json.dumps({"params": params.to_dict()}), encoding="utf-8")
        stem = Path(folder) / "verify"
        run = subprocess.run([sys.executable, "-m", "layered_brdf_addon",
                              *render_arguments(sidecar, params_file, stem)],
                             capture_output=True, text=True)
        if guard is not None:
            guard.check()
        if run.returncode != 0:
            last = (run.stderr.strip().splitlines() or ["no message"])[-1]
            raise RuntimeError(f"--verify: the fit's render failed ({last})")
        image = read_complete_beauty(OutputPaths(stem).exr)
        seconds = read_sidecar(OutputPaths(stem).json).get("render_seconds")
    mask = target.mask(0)
    observed = np.asarray(target.views[0].image, dtype=float)[..., :3][mask]
    rendered = np.asarray(image, dtype=float)[..., :3][mask]
    white = target.white_y  # as the fit's reported figure (SphereTarget.image_delta_e)
    de = colour_space.delta_e_2000(colour_space.lab(np.maximum(observed, 0.0), white),
                                   colour_space.lab(np.maximum(rendered, 0.0), white))
    return {"mean_delta_e_2000": float(np.mean(de)), "pixels": int(mask.sum()), "render_seconds": seconds}
