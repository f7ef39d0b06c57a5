"""The same film, two Blender materials: the physical optics mode against Principled BSDF + Thin Film
where both describe the same film (a uniform film, a dielectric below or a clear film in air, the same
Roughness), rendered on the same sphere by Cycles in a white furnace and under Blender's bundled HDRIs;
mean and rim CIEDE2000 per case and light, and the furnace's value at the centre and the rim.

    python benchmarks/same_film_principled.py [--size 64] [--samples 128] [--hdris forest courtyard interior]
        [--front-only] [--json OUT.json] [--image OUT.png]
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from layered_brdf_addon.model.params import LayeredParams

HDRIS = ("forest", "courtyard", "interior")
RIM_COS = 0.3  # pixels whose view cosine is below this are the rim


@dataclass(frozen=True)
class SameFilm:
    """A film that both materials describe: its index and thickness, the lower medium's index (``None``:
    a clear film in air, seen through), the boundaries' Roughness."""

    name: str
    film_ior: float
    thickness_nm: float
    below: str | None  # a named lower medium (its index for Principled: ``below_ior``), None: air
    below_ior: float
    roughness: float

    def layered(self) -> LayeredParams:
        """The physical mode's material: an even film of no dispersion, boundaries equally rough seen from
        outside (``e1 = e0 r1^2``), no diffuse part; a clear film in air is seen through (transparent base)."""
        e0 = (self.roughness ** -4 - 1.0) / 2.0
        return LayeredParams.from_dict(dict(
            layer_index="ior", layer_ior=self.film_ior, layer_dispersion=0.0, optics="physical",
            lower_medium=self.below or "air", d_min=self.thickness_nm, d_max=self.thickness_nm,
            thickness_mode="height", normal_mode="parallel", e0=e0, e1=min(e0 * self.film_ior ** 2, 1e5), ks=1.0, kd=0.0,
            base_layer="transparent" if self.below is None else "none", accuracy="analytic"))

    def principled(self, material) -> None:
        """Principled BSDF + Thin Film of the same film in ``material``: the lower medium's IOR below a film
        of ``thickness_nm`` and ``film_ior``; a clear film in air is IOR 1 with full transmission."""
        tree = material.node_tree
        tree.nodes.clear()
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
        tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
        values = {"Base Color": (0.0, 0.0, 0.0, 1.0), "Roughness": self.roughness,
                  "IOR": 1.0 if self.below is None else self.below_ior,
                  "Transmission Weight": 1.0 if self.below is None else 0.0,
                  "Thin Film Thickness": self.thickness_nm, "Thin Film IOR": self.film_ior}
        if self.below is None:
            values["Base Color"] = (1.0, 1.0, 1.0, 1.0)
        for name, value in values.items():
            bsdf.inputs[name].default_value = value


CASES = (
    SameFilm("oil 300 nm on water, Roughness 0.1", 1.47, 300.0, "water", 1.333, 0.1),
    SameFilm("oil 500 nm on water, Roughness 0.3", 1.47, 500.0, "water", 1.333, 0.3),
    SameFilm("soap 500 nm in air, Roughness 0.05", 1.334, 500.0, None, 1.0, 0.05),
    SameFilm("soap 250 nm in air, Roughness 0.05", 1.334, 250.0, None, 1.0, 0.05),
)


def _front_half(sphere) -> None:
    """Keep the half of ``sphere``'s mesh that faces the camera (which looks along +y): a film seen through
    shows its far wall too, whose inner side the two materials treat differently."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(sphere.data)
    far = [f for f in bm.faces if f.calc_center_median().y > 1e-6]
    bmesh.ops.delete(bm, geom=far, context="FACES")
    bm.to_mesh(sphere.data)
    bm.free()


def _render_pair(case: SameFilm, size: int, samples: int, lights: list[str], front_only: bool = False) -> dict:
    """Both materials on one sphere (or the half that faces the camera) under each light: linear RGB images
    and the sphere's view cosines."""
    import bpy

    from layered_brdf_addon.blender.lookdev import hdri_folder
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                                  set_hdri_environment, set_uniform_environment)
    from layered_brdf_addon.model.geometry import dot
    from layered_brdf_addon.model.sphere import sphere_geometry

    reset_blender()
    cam = camera_for(1, size)
    (sphere,) = build_scene(SceneSpec(camera=cam, centers=((0.0, 0.0, 0.0),), samples=samples))
    if front_only:
        _front_half(sphere)
    scene = bpy.context.scene
    scene.cycles.max_bounces = 8
    scene.cycles.transparent_max_bounces = 8
    layered = apply_layered_material(sphere, case.layered(), "nodes", name="Layered film")
    principled = bpy.data.materials.new("Principled film")
    case.principled(principled)
    geo = sphere_geometry(cam, ((0.0, 0.0, 0.0),))
    out = {"mask": geo.mask, "mu": dot(geo.n0, geo.view), "images": {}}
    for light in lights:
        if light == "furnace":
            set_uniform_environment(1.0)
        else:
            set_hdri_environment(hdri_folder() / f"{light}.exr")
        for label, mat in (("layered", layered), ("principled", principled)):
            sphere.material_slots[0].material = mat
            out["images"][(light, label)] = render_passes().beauty[..., :3].copy()
    return out


def measure(size: int = 64, samples: int = 128, hdris=HDRIS, cases=CASES, front_only: bool = False) -> list[dict]:
    """Per case and light: mean and rim CIEDE2000 between the two materials, and each one's mean at the
    centre (view cosine above 0.8) and the rim (below :data:`RIM_COS`)."""
    from layered_brdf_reference.film_colours import rgb_to_lab
    from layered_brdf_reference.thin_film import delta_e_2000

    lights = ["furnace", *hdris]
    rows = []
    for case in cases:
        got = _render_pair(case, size, samples, lights, front_only)
        mask, mu = got["mask"], got["mu"]
        centre, rim = mask & (mu > 0.8), mask & (mu < RIM_COS) & (mu > 0.02)
        for light in lights:
            a, b = got["images"][(light, "layered")], got["images"][(light, "principled")]
            de = delta_e_2000(rgb_to_lab(np.maximum(a, 0.0)), rgb_to_lab(np.maximum(b, 0.0)))
            rows.append(dict(case=case.name, light=light, mean_de=float(de[mask].mean()),
                             rim_de=float(de[rim].mean()),
                             layered_centre=a[centre].mean(0).round(4).tolist(),
                             layered_rim=a[rim].mean(0).round(4).tolist(),
                             principled_centre=b[centre].mean(0).round(4).tolist(),
                             principled_rim=b[rim].mean(0).round(4).tolist(),
                             images=(a, b)))
    return rows


def contact_sheet(rows: list[dict], path: Path) -> None:
    """Pairs of spheres, the layered material left of Principled BSDF + Thin Film, one row per light."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = list(dict.fromkeys(r["case"] for r in rows))
    lights = list(dict.fromkeys(r["light"] for r in rows))
    fig, axes = plt.subplots(len(lights), 2 * len(cases), figsize=(2.0 * len(cases) * 1.6, len(lights) * 1.8))
    for r in rows:
        i, j = lights.index(r["light"]), cases.index(r["case"])
        for k, img in enumerate(r["images"]):
            ax = axes[i, 2 * j + k]
            scale = 1.0 if r["light"] == "furnace" else 1.0 / max(float(np.percentile(r["images"][1], 99)), 1e-6)
            ax.imshow(np.clip(img * scale, 0.0, 1.0) ** (1.0 / 2.2))
            ax.set_axis_off()
            if i == 0:
                ax.set_title(("layered\n" if k == 0 else "Principled + Thin Film\n") + r["case"].split(",")[0],
                             fontsize=7)
        axes[i, 0].text(-0.1, 0.5, r["light"], transform=axes[i, 0].transAxes, ha="right", va="center", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    tmp.replace(path)


def main(argv=None) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from report import table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--samples", type=int, default=128)
    ap.add_argument("--hdris", nargs="*", default=list(HDRIS))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--image", type=Path, default=None)
    ap.add_argument("--markdown", action="store_true")
    ap.add_argument("--front-only", action="store_true", help="the half of the sphere that faces the camera: "
                    "no far wall seen through a clear film")
    args = ap.parse_args(argv)
    rows = measure(args.size, args.samples, args.hdris, front_only=args.front_only)
    head = ["case", "light", "mean ΔE2000", "rim ΔE2000", "layered centre", "layered rim", "Principled centre",
            "Principled rim"]
    print(table(head, [[r["case"], r["light"], f"{r['mean_de']:.2f}", f"{r['rim_de']:.2f}",
                        *(", ".join(f"{x:.3f}" for x in r[k]) for k in ("layered_centre", "layered_rim",
                                                                        "principled_centre", "principled_rim"))]
                       for r in rows], args.markdown))
    if args.image is not None:
        contact_sheet(rows, args.image)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps([{k: v for k, v in r.items() if k != "images"} for r in rows], indent=1))


if __name__ == "__main__":
    main()
