"""``fit --verify``: the fitted material rendered as the target was, and the two images compared.

The fit reports the mean CIEDE2000 over every pixel of the sphere between the target and the closure
form computed in numpy.  A user judges a fit by rendering it: here the fitted parameters go through
``layered-brdf render`` (a subprocess, the path every render takes) with the target's camera, sun,
samples, seed and backend, and every pixel of the sphere is compared in the same colour pipeline as the
fit's figure (CIELAB against the fit's white, CIEDE2000).  The render lives in a
temporary folder, removed afterwards; nothing of it is left beside the outputs.

A Principled BSDF target (``--principled``) was rendered in this process, on the reference sphere
under its suns and HDRIs: the fitted layered material is rendered by Cycles in the same scenes (same
suns, HDRIs, pixels and samples, :func:`layered_brdf_addon.blender.principled_target.layered_views`)
and compared over every pixel of the sphere in every view, each view's figure given too.

A gallery's tile (another camera) and a reflectance table (no render) cannot be re-rendered:
:func:`check_verifiable` says so before the fit, and :func:`check_camera` (a render with a camera
of its own) once the target is read, before the fit too.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..io.sidecar import camera_from_dict, read_sidecar
from ..io.staging import OutputPaths
from ..model.params import LayeredParams, ParameterError
from ..model.sphere import OrthoCamera
from .fit_targets import read_complete_beauty
from .options import blender_output

VERIFY_ALLOWED = ("no value but with TARGET, a render of the reference sphere ('layered-brdf render' without "
                  "--blend), or with --principled")


def check_verifiable(source, tile: Any) -> None:
    """ParameterError naming ``verify`` unless the target is a reference-sphere render or a Principled
    BSDF material (a gallery's tile has another camera; a table has no render to repeat)."""
    if source.kind not in ("render", "principled") or tile is not None:
        raise ParameterError("verify", True, VERIFY_ALLOWED)


def check_camera(loaded_record: dict) -> None:
    """ParameterError naming ``verify`` unless the loaded render's camera is the reference scene's
    (``render`` repeats no other): called once the target is read, before the fit.  A Principled
    target's renders are the reference scene's: nothing to check."""
    if loaded_record["kind"] != "render":
        return
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


def compare(target, images) -> dict:
    """Every pixel of the fitted sphere in every view of ``target`` against ``images`` (one per view), in
    the colour pipeline of the fit's figure (``SphereTarget.images_delta_e``):
    ``{"mean_delta_e_2000", "pixels", "per_view"}``."""
    per_view = target.images_delta_e(images)
    de = np.concatenate(per_view)
    return {"mean_delta_e_2000": float(np.mean(de)), "pixels": int(de.size),
            "per_view": [float(np.mean(d)) for d in per_view]}


def verify(target, loaded_record: dict, params: LayeredParams, guard=None, renders=None, verbose: bool = False) -> dict:
    """The fitted ``params`` rendered as the target was and compared over every pixel of the sphere
    (:func:`compare`, with ``render_seconds``): a reference-sphere render through ``render``, a Principled
    target (``renders``: its :class:`~.fit_request.PrincipledRenders`) in its own scenes.  A render that
    fails raises RuntimeError with its last message."""
    if loaded_record["kind"] == "principled":
        return verify_principled(target, params, renders, guard, verbose)
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
    return {**compare(target, [image]), "render_seconds": seconds}


def verify_principled(target, params: LayeredParams, renders, guard=None, verbose: bool = False) -> dict:
    """A Principled target's check: the layered material of ``params`` rendered by Cycles in the scenes
    the material was rendered in (the target's suns, then ``renders.hdris``; its pixels and samples)."""
    from ..blender.lookdev import hdri_path  # imports bpy: the target's renders loaded it already
    from ..blender.principled_target import layered_views

    suns = [v.sun for v in target.views if v.sun is not None]
    t0 = time.perf_counter()
    with blender_output(verbose):
        views = layered_views(params, size=renders.size, samples=renders.samples, suns=suns,
                              hdris=[hdri_path(name) for name in renders.hdris])
    if guard is not None:
        guard.arm()  # Blender may have replaced the handlers
        guard.check()
    return {**compare(target, [v.image for v in views]), "render_seconds": time.perf_counter() - t0}
