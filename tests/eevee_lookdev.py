"""Render the look-dev shader ball with Cycles, then with EEVEE, for a few presets.

Run as a subprocess by tests/test_eevee_lookdev.py and benchmarks (EEVEE needs a GL
context: headless, EGL with Mesa's software rasteriser).  Usage:

    python tests/eevee_lookdev.py OUT.npz SIZE CYCLES_SAMPLES EEVEE_SAMPLES PRESET [PRESET...] [--seed N]

EEVEE_SAMPLES 0 renders Cycles only (with ``--seed``: Cycles' own noise, for scale).
Writes, per preset, both renders as Blender encodes them for display with the scene's
view transform (AgX; 8-bit RGB, rows top to bottom), the ball's pixels (Cycles' object
index pass, shrunk by a pixel so that neither renderer's anti-aliased silhouette counts)
and each render's wall time.
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BALL_INDEX = 1


def delta_e2000(a8: np.ndarray, b8: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """CIEDE2000 between two 8-bit sRGB display images at the ``mask`` pixels (colour-science:
    sRGB decoded to XYZ, then CIE Lab under D65)."""
    import colour

    def lab(px):
        return colour.XYZ_to_Lab(colour.sRGB_to_XYZ(np.asarray(px, np.float64) / 255.0))

    return colour.delta_E(lab(a8[mask]), lab(b8[mask]), method="CIE 2000")


def run(out: Path, size: int, cycles_samples: int, eevee_samples: int, presets, timeout: float = 600.0,
        seed: int = 0, evaluation: str = "tables") -> dict:
    """Run this script in a subprocess; its results as a dict (raises with Blender's stderr
    when EEVEE could not render).  ``evaluation``: the presets' Evaluation (baked tables or
    arithmetic)."""
    import os
    import subprocess

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), str(out), str(size), str(cycles_samples),
                           str(eevee_samples), *presets, "--seed", str(seed), "--evaluation", evaluation], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)
    if proc.returncode != 0 or not Path(out).exists():
        raise RuntimeError("EEVEE could not render (it needs EGL and Mesa's software GL: see .ci/run):\n"
                           + proc.stderr[-3000:])
    with np.load(out) as r:
        return {k: r[k] for k in r.files}


def configure_eevee(scene, samples: int) -> None:
    """EEVEE with the scene's lights and world, ``samples`` anti-aliasing samples, shadows on;
    no screen-space ray tracing (the glossy reflections come from the world probe)."""
    from layered_brdf_addon.blender.lookdev import eevee_engine

    scene.render.engine = eevee_engine()
    e = scene.eevee
    e.taa_render_samples = samples
    e.use_shadows = True
    e.use_raytracing = False
    e.use_fast_gi = False
    scene.render.use_motion_blur = False


def ball_mask(path: Path, size: int) -> np.ndarray:
    """The ball's pixels from the object index pass, eroded by one pixel."""
    from layered_brdf_addon.blender.scene import read_exr

    ch = read_exr(path)
    key = next(k for k in ch if k.endswith(("Object Index.X", "IndexOB.X")))
    inside = np.abs(ch[key] - BALL_INDEX) < 0.5
    eroded = inside.copy()
    eroded[1:, :] &= inside[:-1, :]
    eroded[:-1, :] &= inside[1:, :]
    eroded[:, 1:] &= inside[:, :-1]
    eroded[:, :-1] &= inside[:, 1:]
    return eroded


def main(argv) -> None:
    import argparse

    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("size", type=int)
    ap.add_argument("cycles_samples", type=int)
    ap.add_argument("eevee_samples", type=int)
    ap.add_argument("presets", nargs="+")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--evaluation", default="tables")
    a = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    import bpy  # noqa: F401  (first: it makes mathutils importable)

    from layered_brdf_addon.blender.lookdev import build_lookdev_scene, eevee_engine, remove_scene
    from layered_brdf_addon.blender.scene import encode_view, passes_from_exr, render_to_exr, shader_failed
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.model.presets import preset

    size = a.size
    scene, ball = build_lookdev_scene(size=size, samples=a.cycles_samples)
    scene.cycles.seed = a.seed
    ball.pass_index = BALL_INDEX
    scene.view_layers[0].use_pass_object_index = True
    result: dict[str, np.ndarray] = {}
    with tempfile.TemporaryDirectory(prefix="eevee_lookdev_") as tmp:
        for name in a.presets:
            ball.material_slots[0].material = None
            apply_layered_material(ball, preset(name).replace(evaluation=a.evaluation), "nodes", name=name)
            scene.render.engine = "CYCLES"
            exr = Path(tmp) / f"{name}_cycles.exr"
            result[f"{name}/cycles_seconds"] = np.float64(render_to_exr(exr, scene))
            result[f"{name}/mask"] = ball_mask(exr, size)
            result[f"{name}/cycles"] = encode_view(passes_from_exr(exr).beauty, scene)
            if a.eevee_samples <= 0:
                continue
            configure_eevee(scene, a.eevee_samples)
            exr = Path(tmp) / f"{name}_eevee.exr"
            t0 = time.perf_counter()
            render_to_exr(exr, scene)
            result[f"{name}/eevee_seconds"] = np.float64(time.perf_counter() - t0)
            beauty = passes_from_exr(exr).beauty
            result[f"{name}/eevee_failed"] = shader_failed(beauty)
            result[f"{name}/eevee"] = encode_view(beauty, scene)
    result["view_transform"] = np.array(scene.view_settings.view_transform)
    result["eevee_engine"] = np.array(eevee_engine())
    remove_scene(scene)
    np.savez(a.out, **result)


if __name__ == "__main__":
    main(sys.argv[1:])
