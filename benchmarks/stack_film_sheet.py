"""Each structural colour next to the closest one film, rendered: what a stack of films adds to a look.

For every structural preset, three tiles of the look-dev scene (the shader ball under one of Blender's
bundled HDRIs and the look-dev sun, Cycles, the scene's view transform): the preset (node group), the same
material with its stack replaced by the closest one film, and Blender's Principled BSDF + Thin Film set up
for that film (``lookdev.thin_film_equivalent``, its base colour what the material diffuses: ``kd`` of its
base's).  The closest film is what ``layered-brdf fit --reflectance``
finds with no start for the stack's mirror reflectance at 0, 30 and 60 degrees (benchmarks/stack_vs_film.py:
every film structure the fit knows); the material keeps the preset's roughness, pattern, base and weights,
and its thickness range is the fitted thickness with the preset's relative spread.  Each label gives the
fit's mean CIEDE2000 from the stack's mirror colours.

Writes docs/images/stack-vs-film-<hdri>.png and a .json next to it (the values, the fits, the render times),
the two together or neither.  About a minute of fitting and two of rendering on two cores at the defaults.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

SIZE = 160
SAMPLES = 32
FILM_FIELDS = ("optics", "layer_index", "layer_ior", "layer_dispersion", "r1_r", "r1_g", "r1_b", "lower_medium",
               "r2_r", "r2_g", "r2_b", "k2_r", "k2_g", "k2_b", "e1")  # what the fit chose besides the thickness


def closest_film(name: str, folder: Path):
    """``(film params, fit record)``: the preset ``name`` with its stack replaced by the one film the fit finds
    closest to the stack's mirror colours (the fit's figure and record written in ``folder``); tilted lamellae's
    by one lamella in their crystal (``stack_vs_film.closest_lamella``)."""
    from layered_brdf_addon.cli import commands as cli
    from layered_brdf_addon.model.params import LayeredParams
    from layered_brdf_addon.model.presets import preset
    from stack_vs_film import closest_lamella, write_table

    if preset(name).normal_mode == "tilted":
        return closest_lamella(name)

    table = folder / f"{name}.csv"
    write_table(name, table)
    stem = folder / f"stack-vs-film-{name.replace('_', '-')}"
    if cli.main(["fit", "--reflectance", str(table), "--layer", "film", "--output", str(stem), "--no-progress"]) != 0:
        raise RuntimeError(f"the fit of {name}'s stack failed")
    record = json.loads(stem.with_suffix(".json").read_text())
    fitted = record["params"]
    p = preset(name)
    middle = 0.5 * (p.d_min + p.d_max)
    d = 0.5 * (fitted["d_min"] + fitted["d_max"])
    values = {**p.to_dict(), **{k: fitted[k] for k in FILM_FIELDS if k in fitted},
              "d_min": d * p.d_min / middle, "d_max": d * p.d_max / middle}
    values.pop("stack", None)
    return LayeredParams.from_dict(values).validate(), record["fit"]


def film_label(p) -> str:
    if p.stack is not None:  # one lamella in the crystal
        film = p.stack.films[0]
        return f"one lamella \u00b7 n {film.ior:.2f} \u00b7 {film.thickness_nm:.0f} nm \u00b7 in n {p.r1_g:.3f}"
    lower = p.lower_medium if p.lower_medium != "custom" else f"n {p.r2_g:.2f}"
    return f"n {p.r1_g:.2f} \u00b7 {0.5 * (p.d_min + p.d_max):.0f} nm \u00b7 over {lower} \u00b7 {p.optics} optics"


def main(argv=None) -> int:
    from layered_brdf_addon.cli.lookdev import check_sheet_output
    from layered_brdf_addon.cli.option_values import int_option
    from layered_brdf_addon.model.params import ParameterError

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hdri", default="forest", help="a bundled HDRI (default forest)")
    ap.add_argument("--output", default=None, help="the sheet (.png; default docs/images/stack-vs-film-HDRI.png)")
    ap.add_argument("--size", default=SIZE, help=f"pixels per tile, in [16, 2048] (default {SIZE})")
    ap.add_argument("--samples", default=SAMPLES, help=f"samples per pixel, in [1, 4096] (default {SAMPLES})")
    ap.add_argument("--no-progress", dest="progress", action="store_false")
    args = ap.parse_args(argv)
    try:
        size = int_option("size", args.size, 16, 2048)
        samples = int_option("samples", args.samples, 1, 4096)
        output = check_sheet_output(args.output or ROOT / "docs" / "images" / f"stack-vs-film-{args.hdri}.png")
        return render(output, size, samples, args.hdri, args.progress)
    except ParameterError as e:
        print(f"stack_film_sheet: error: {e}", file=sys.stderr)
        return 2


def render(output: Path, size: int, samples: int, hdri_name: str, progress: bool) -> int:
    import bpy
    from layered_brdf_addon.blender import lookdev
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.blender.scene import reset_blender, view_settings_record
    from layered_brdf_addon.cli.lookdev import timed_sheet
    from layered_brdf_addon.io.codecs import save_png
    from layered_brdf_addon.io.sidecar import write_json
    from layered_brdf_addon.io.staging import StagedOutputs
    from layered_brdf_addon.model.presets import STACK_PRESETS, preset, preset_label

    t0 = time.perf_counter()
    hdri = lookdev.hdri_path(hdri_name)
    films, fits = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in STACK_PRESETS:
            films[name], fits[name] = closest_film(name, Path(tmp))
    reset_blender()
    scene, ball = lookdev.build_lookdev_scene(size=size, samples=samples, hdri=hdri.name)
    tiles, labels_base, equivalents = [], [], {}
    for name in STACK_PRESETS:
        stack, film = preset(name), films[name]
        surface = film
        if film.stack is not None:  # Principled's film lies on the surface: the lamella's index and thickness there
            lamella = film.stack.films[0]
            surface = film.replace(stack=None, normal_mode="parallel", layer_index="ior", layer_ior=lamella.ior,
                                   layer_dispersion=0.0)
        kw = lookdev.thin_film_equivalent(name, surface)
        if film.base_layer == "none" and not kw["metallic"]:  # what diffuses under the film: kd of the base
            kw["base_color"] = tuple(film.kd * c for c in film.base_color)
        equivalents[name] = kw

        def layered(p=stack, name=name):
            ball.material_slots[0].material = None
            apply_layered_material(ball, p, "nodes", name=name)

        def one_film(p=film, name=name):
            ball.material_slots[0].material = None
            apply_layered_material(ball, p, "nodes", name=f"{name} one film")

        def principled(kw=kw, name=name):
            ball.material_slots[0].material = lookdev.principled_thin_film(f"{name} Principled + Thin Film", **kw)

        tiles += [(name, layered), (f"{name} (one film)", one_film), (f"{name} (Principled)", principled)]
        labels_base += [[preset_label(name), stack.stack.size_label],
                        ["closest one film", f"{film_label(film)} \u00b7 \u0394E {fits[name]['mean_delta_e_2000']:.1f}"],
                        ["Principled + Thin Film", "the same film"]]
    title = (f"stacks | the closest one film | Principled BSDF + Thin Film \u00b7 {hdri.stem} HDRI + sun "
             f"\u00b7 Cycles {samples} spp \u00b7 {scene.view_settings.view_transform}")
    pixels, seconds = timed_sheet(scene, tiles, labels_base, size, 3, title, "stacks", progress)
    data = {"title": title, "hdri": hdri.name, "size": size, "samples": samples,
            "view": view_settings_record(scene), "bpy_version": bpy.app.version_string,
            "stacks": [{"name": n, "params": preset(n).to_dict(), "closest_film": films[n].to_dict(), "fit": fits[n],
                        "principled_thin_film": equivalents[n],
                        "render_seconds": dict(zip(("stack", "film", "principled"), seconds[3 * k:3 * k + 3]))}
                       for k, n in enumerate(STACK_PRESETS)],
            "seconds": time.perf_counter() - t0}
    sidecar = output.with_suffix(".json")
    with StagedOutputs([output, sidecar]) as staged:
        save_png(staged.temp(output), pixels)
        write_json(staged.temp(sidecar), data)
    print(f"wrote {output} ({pixels.shape[1]}x{pixels.shape[0]}), {sidecar}; {data['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
