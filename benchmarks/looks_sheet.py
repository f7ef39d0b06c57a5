"""Every preset next to its nearest Principled BSDF + Thin Film, on the look-dev shader ball.

For each preset, two tiles of the same scene (layered_brdf_addon/blender/lookdev.py: the
shader ball under Blender's bundled forest HDRI and a soft sun, Cycles, AgX): the
layered material (node group) and Blender's Principled BSDF with Thin Film set up by
``lookdev.thin_film_equivalent`` (film thickness the middle of d_min..d_max, film IOR
r1_g, the base colour, metallic for metal and titanium presets, roughness from e0).
Each tile's label gives its render time.

Writes docs/images/presets-vs-principled-thin-film.png (and a .json next to it with the
values and timings), the two together or neither.  ``make looks-sheet``; about two
minutes on two cores at the defaults.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

OUT = ROOT / "docs" / "images" / "presets-vs-principled-thin-film.png"
SIZE = 192
SAMPLES = 64
PAIRS_PER_ROW = 3


def principled_label(kw: dict) -> str:
    return (f"d {kw['thickness_nm']:g} nm \u00b7 IOR {kw['ior']:g} \u00b7 rough {kw['roughness']:.2f}"
            + (" \u00b7 metal" if kw["metallic"] else ""))


def main(argv=None) -> int:
    from layered_brdf_addon.cli.lookdev import check_sheet_output
    from layered_brdf_addon.cli.option_values import int_option
    from layered_brdf_addon.model.params import ParameterError
    from layered_brdf_addon.model.presets import ARTIST_PRESETS, PAPER_PRESETS, PRESETS

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--output", default=str(OUT), help="the sheet (.png); a .json goes next to it")
    ap.add_argument("--size", default=SIZE, help=f"pixels per tile, in [16, 2048] (default {SIZE})")
    ap.add_argument("--samples", default=SAMPLES, help=f"samples per pixel, in [1, 4096] (default {SAMPLES})")
    ap.add_argument("--presets", nargs="+", default=None, help="presets (default: all, artist presets first)")
    ap.add_argument("--hdri", default=None, help="a bundled HDRI (default forest)")
    ap.add_argument("--no-progress", dest="progress", action="store_false")
    args = ap.parse_args(argv)
    try:
        size = int_option("size", args.size, 16, 2048)
        samples = int_option("samples", args.samples, 1, 4096)
        names = tuple(args.presets or (list(ARTIST_PRESETS) + list(PAPER_PRESETS)))
        for n in names:
            if n not in PRESETS:
                raise ParameterError("presets", n, "preset names among " + ", ".join(PRESETS))
        output = check_sheet_output(args.output)
        return render(output, size, samples, names, args.hdri, args.progress)
    except ParameterError as e:
        print(f"looks_sheet: error: {e}", file=sys.stderr)
        return 2


def render(output: Path, size: int, samples: int, names, hdri_name, progress: bool) -> int:
    import bpy
    from layered_brdf_addon.blender import lookdev
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.blender.scene import reset_blender, view_settings_record
    from layered_brdf_addon.io.codecs import save_png
    from layered_brdf_addon.cli.lookdev import timed_sheet
    from layered_brdf_addon.io.sidecar import write_json
    from layered_brdf_addon.io.staging import StagedOutputs
    from layered_brdf_addon.model.presets import preset, preset_label

    t0 = time.perf_counter()
    hdri = lookdev.hdri_path(hdri_name)
    reset_blender()
    scene, ball = lookdev.build_lookdev_scene(size=size, samples=samples, hdri=hdri.name)
    tiles, equivalents = [], {}
    for name in names:
        p = preset(name)
        kw = lookdev.thin_film_equivalent(name, p)
        equivalents[name] = kw

        def layered(name=name, p=p):
            ball.material_slots[0].material = None
            apply_layered_material(ball, p, "nodes", name=name)

        def principled(name=name, kw=kw):
            ball.material_slots[0].material = lookdev.principled_thin_film(f"{name} Principled + Thin Film", **kw)

        tiles += [(name, layered), (f"{name} (Principled)", principled)]
    labels_base = [[preset_label(n), "layered (node group)"] if k % 2 == 0 else
                   ["Principled + Thin Film", principled_label(equivalents[n])]
                   for n in names for k in (0, 1)]
    title = (f"presets (layered, node group) | Principled BSDF + Thin Film \u00b7 {hdri.stem} HDRI + sun "
             f"\u00b7 Cycles {samples} spp \u00b7 {scene.view_settings.view_transform}")
    pixels, seconds = timed_sheet(scene, tiles, labels_base, size, 2 * PAIRS_PER_ROW, title, "looks", progress)
    data = {"title": title, "hdri": hdri.name, "size": size, "samples": samples,
            "view": view_settings_record(scene), "bpy_version": bpy.app.version_string,
            "presets": [{"name": n, "params": preset(n).to_dict(), "principled_thin_film": equivalents[n],
                         "render_seconds": {"layered": seconds[2 * k], "principled": seconds[2 * k + 1]}}
                        for k, n in enumerate(names)],
            "seconds": time.perf_counter() - t0}
    sidecar = output.with_suffix(".json")
    with StagedOutputs([output, sidecar]) as staged:
        save_png(staged.temp(output), pixels)
        write_json(staged.temp(sidecar), data)
    print(f"wrote {output} ({pixels.shape[1]}x{pixels.shape[0]}), {sidecar}; {data['seconds']:.0f} s")
    for n in names:
        r = next(x for x in data["presets"] if x["name"] == n)["render_seconds"]
        print(f"  {n:18s} layered {r['layered']:5.1f} s   Principled + Thin Film {r['principled']:5.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
