"""Materials a fit should find again: parameter sets never in the presets, their start, and
thin-film optics tables (tmm) of real films.  Shared by tests/test_fit.py and
benchmarks/fit_table.py."""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.fit.cycles_closures import closure_shading
from layered_brdf_addon.fit.targets import SphereTarget, SphereView
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.sphere import OrthoCamera, Sun, render_spheres

from . import thin_film
from .film_colours import complex_index

CAMERA = OrthoCamera(width=96, height=96)
SUNS = (Sun((0.64, -0.77, 0.0), 3.0), Sun((0.3, -0.8, 0.5), 3.0))


def held_out() -> dict:
    """name: (the material rendered, the preset the fit starts from)."""
    return {
        # physical films, thickness by height (numpy reproduces it)
        "soap_thick_rough": (preset("soap_bubble").replace(d_min=800, d_max=1600, e0=300, e1=600), "soap_bubble"),
        "titanium_blue": (preset("anodised_titanium").replace(
            d_min=40, d_max=90, e0=400, e1=900, r1_r=2.3, r1_g=2.4, r1_b=2.5, thickness_mode="height"),
            "anodised_titanium"),
        "oil_milky": (preset("oil_slick").replace(d_min=200, d_max=450, kd=0.5, thickness_mode="height"),
                      "oil_slick"),
        # the paper's optics, a tilted dispersive layer
        "paper_tilted": (preset("fig6_medium").replace(d_min=500, d_max=700, thickness_mode="height"),
                         "fig4_tilted"),
    }


def generated_targets() -> dict:
    """name: a material of no preset's values for a fit with no start (model selection), spanning the
    optics (paper, physical), the lower boundaries (parallel, tilted, correlated), the bases (none,
    see-through, metal, diffuse colour) and lower media (water, air, titanium, copper, gold, alumina, chitin,
    glass); thickness by height, which numpy reproduces pixel by pixel."""
    h = {"thickness_mode": "height"}
    return {
        "paper_tilted_diffuse": preset("fig6_medium").replace(d_min=350, d_max=520, tilt=6.0, kd=0.5, r1_r=1.45,
                                                              r1_g=1.5, r1_b=1.56, **h),
        "paper_parallel_blue_base": preset("fig4_parallel").replace(d_min=150, d_max=260, kd=0.6, base_r=0.2,
                                                                    base_g=0.5, base_b=0.7, **h),
        "paper_correlated": preset("fig5_correlated").replace(d_min=200, d_max=450, e0=200, e1=320, **h),
        "paper_tilted_sideways": preset("fig4_tilted").replace(d_min=300, d_max=420, tilt=9.0, tilt_azimuth=90.0,
                                                               kd=0.2, **h),
        "oil_on_water": preset("oil_slick").replace(d_min=300, d_max=520, kd=0.2, **h),
        "soap_see_through": preset("soap_bubble").replace(d_min=350, d_max=800, e0=600, e1=900),
        "titanium_gold_oxide": preset("anodised_titanium").replace(d_min=80, d_max=140, **h),
        "copper_oxide": preset("old_metal").replace(d_min=40, d_max=110, **h),
        "chitin_over_air": preset("beetle_shell").replace(d_min=420, d_max=620, kd=0.15, **h),
        "glaze_diffuse": preset("glazed_clay").replace(d_min=180, d_max=330, kd=0.6, base_r=0.6, base_g=0.3,
                                                       base_b=0.2, **h),
        "oxide_on_gold": preset("anodised_titanium").replace(lower_medium="gold", d_min=100, d_max=160, **h),
        "oil_on_glass_tilted": preset("oil_slick").replace(lower_medium="glass", normal_mode="tilted", tilt=5.0,
                                                           d_min=250, d_max=400, **h),
        "paper_uniform_clay": preset("fig3_clay").replace(d_min=260, d_max=260, ks=0.6, kd=0.8, **h),
    }


def views_of(params, suns=SUNS[:1]) -> list[SphereView]:
    """The closure form's images of ``params`` on the reference sphere, one per sun; with a
    transparent base, what the fit's model sees through the sphere too (its far side)."""
    views = [SphereView(render_spheres(params, CAMERA, sun, shading=closure_shading)[0], CAMERA, sun)
             for sun in suns]
    if params.base_layer != "transparent":
        return views
    target = SphereTarget(views)
    return [SphereView(target.render(params, k), CAMERA, view.sun) for k, view in enumerate(views)]


def image_delta_e(target, params) -> float:
    """Mean CIEDE2000 over every pixel of the sphere between a sphere target's images and the
    closure form of ``params`` (the fit samples the pixels; this reads them all)."""
    return target.image_delta_e(params)


FILMS = (("tio2_amorphous", "titanium", 120.0, "anodised_titanium"),
         ("water", "air", 420.0, "soap_bubble"),
         ("oil", "water", 300.0, "oil_slick"))


def tmm_rows(film: str, below: str, thickness: float, angles=(0.0, 30.0, 60.0)) -> list[tuple]:
    """(angle, wavelength, reflectance) rows of tmm's unpolarised reflectance, 380-780 nm."""
    lams = np.arange(380.0, 781.0, 10.0)
    rows = []
    for angle in angles:
        r = thin_film.film_reflectance(1.0, complex_index(film, lams), complex_index(below, lams), thickness, angle,
                                       lams)
        rows += [(angle, lam, float(x)) for lam, x in zip(lams, r)]
    return rows
