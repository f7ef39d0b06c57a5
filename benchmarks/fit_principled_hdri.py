"""Principled BSDF + Thin Film converted by a fit, judged on the look-dev ball under HDRIs.

For a soap film, an oil film and anodised titanium made of Principled BSDF + Thin Film: the
fit to their reference-sphere renders (three suns, ``blender.principled_target``), then the
Principled material and the fitted layered material rendered by Cycles on the look-dev ball
under each bundled HDRI named (Standard view transform, linear EXR); the mean CIEDE2000
over the ball's pixels (those that differ from a render without the ball), colours on the
scale of the Principled render's 99th percentile luminance; and the fit's own views rendered again
with the fitted material, compared as ``fit --verify`` compares them.  ``--select``: the fit chooses the
structure (no start), as the command line and the panel do by default.  Prints a table
(``--markdown`` for docs/fitting.md).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from layered_brdf_addon.blender import lookdev  # noqa: E402
from layered_brdf_addon.blender import principled_target  # noqa: E402
from layered_brdf_addon.blender.fit_operator import run_fit, run_selection, sphere_target  # noqa: E402
from layered_brdf_addon.blender.material import apply_layered_material  # noqa: E402
from layered_brdf_addon.blender.scene import render_to_file, reset_blender  # noqa: E402
from layered_brdf_addon.fit import colour_space  # noqa: E402
from layered_brdf_addon.fit.environment import DEFAULT_HDRIS  # noqa: E402
from layered_brdf_addon.model.presets import preset  # noqa: E402
from report import table  # noqa: E402  (benchmarks/ is on sys.path when the script runs)

CONVERSIONS = {
    "soap": (lambda: lookdev.principled_soap_film("Soap"), "soap_bubble"),
    "oil": (lambda: lookdev.principled_thin_film("Oil", 350.0, 1.47, (0.01, 0.01, 0.012), 0.0, 0.15), "oil_slick"),
    "titanium": (lambda: lookdev.principled_thin_film("Titanium", 200.0, 2.4, (0.542, 0.497, 0.449), 1.0, 0.2),
                 "anodised_titanium"),
}


def render_ball(material, hdri: str, size: int, samples: int, folder: Path, name: str) -> np.ndarray:
    """The look-dev ball with ``material`` (None: no ball) under ``hdri``: linear RGB."""
    scene, ball = lookdev.build_lookdev_scene(size=size, samples=samples, hdri=hdri, view_transform="Standard")
    try:
        if material is None:
            ball.hide_render = True
        else:
            ball.data.materials[0] = material
        s = scene.render.image_settings
        s.media_type, s.file_format, s.color_mode, s.color_depth = "IMAGE", "OPEN_EXR", "RGB", "32"
        path = folder / f"{name}.exr"
        render_to_file(path, scene)
        return principled_target.read_float_image(path)
    finally:
        lookdev.remove_scene(scene)


def ball_delta_e(principled: np.ndarray, layered: np.ndarray, empty: np.ndarray) -> float:
    ball = (np.abs(principled - empty).max(axis=-1) > 1e-3) | (np.abs(layered - empty).max(axis=-1) > 1e-3)
    white = colour_space.white_of(principled[ball])
    a, b = (colour_space.lab(np.maximum(x[ball], 0.0), white) for x in (principled, layered))
    return float(np.mean(colour_space.delta_e_2000(a, b)))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hdris", nargs="+", default=["forest", "courtyard", "interior", "sunset", "city"])
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--fit-hdris", nargs="*", default=list(DEFAULT_HDRIS),
                    help="HDRIs whose reference-sphere renders join the three suns' in the fit (default: the "
                         "fit command's, " + " ".join(DEFAULT_HDRIS) + "; none: the suns only)")
    ap.add_argument("--only", nargs="*", default=list(CONVERSIONS))
    ap.add_argument("--select", action="store_true",
                    help="no start: the fit chooses the structure (as 'fit --principled' without --start)")
    ap.add_argument("--sheet", help="also write a PNG: per material, the Principled and the fitted ball "
                                    "under each HDRI")
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    reset_blender()
    rows, sheet_rows = [], []
    with tempfile.TemporaryDirectory(prefix="layered_brdf_fit_hdri_") as tmp:
        folder = Path(tmp)
        empties = {h: render_ball(None, h, args.size, args.samples, folder, f"empty-{h}") for h in args.hdris}
        for name in args.only:
            make, start = CONVERSIONS[name]
            material = make()
            hdris = [lookdev.hdri_path(h) for h in args.fit_hdris]
            views = principled_target.principled_views_of(material, hdris=hdris)
            t0, cpu0 = time.perf_counter(), time.process_time()
            uniform = principled_target.uniform_film(material)
            if args.select:
                selection = run_selection(views, surface=principled_target.surface_of(material), uniform_film=uniform)
                result, start = selection.result, selection.chosen.label
            else:
                result = run_fit(views, principled_target.start_for(preset(start), material), uniform_film=uniform)
            seconds, cpu = time.perf_counter() - t0, time.process_time() - cpu0
            # The fit's own views rendered again with the fitted material (what 'fit --verify' reports).
            target = sphere_target(views, uniform)
            fitted = target.image_delta_e(result.params)  # the figure 'fit' reports: every pixel, the closure form
            again = principled_target.layered_views(result.params, hdris=hdris)
            rerendered = np.mean(np.concatenate(target.images_delta_e([v.image for v in again])))
            import bpy

            layered = apply_layered_material(bpy.data.materials.new(f"{name} fitted"), result.params)
            errors, tiles = [], []
            for h in args.hdris:
                a = render_ball(material, h, args.size, args.samples, folder, f"{name}-p-{h}")
                b = render_ball(layered, h, args.size, args.samples, folder, f"{name}-l-{h}")
                errors.append(ball_delta_e(a, b, empties[h]))
                tiles += [a, b]
            sheet_rows.append(np.concatenate(tiles, axis=1))
            rows.append((name, start, f"{fitted:.2f}", f"{rerendered:.2f}", *(f"{e:.2f}" for e in errors),
                         f"{cpu:.0f} / {seconds:.0f}"))
    lights = "three suns" + "".join(f" + {h}" for h in args.fit_hdris)
    header = ("material", "structure chosen" if args.select else "start", f"ΔE00 fitted ({lights}, the sphere)",
              "ΔE00 re-rendered (the same views)", *(f"ΔE00 ball, {h}" for h in args.hdris), "fit CPU / wall s")
    print(table(header, rows, args.markdown))
    if args.sheet:
        save_sheet(Path(args.sheet), np.concatenate(sheet_rows, axis=0))


def save_sheet(path: Path, linear: np.ndarray) -> None:
    """``linear`` RGB as an sRGB PNG (the Standard view transform the balls were rendered for)."""
    import colour

    from layered_brdf_addon.io.codecs import save_png

    encoded = colour.cctf_encoding(np.clip(linear, 0.0, 1.0), function="sRGB")
    save_png(path, np.round(encoded * 255.0).astype(np.uint8))
    print(f"wrote {path}: per HDRI, Principled | fitted")


if __name__ == "__main__":
    main()
