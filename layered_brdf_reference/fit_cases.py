"""Materials a fit should find again: parameter sets never in the presets, their start, and
thin-film optics tables (tmm) of real films.  Shared by tests/test_fit.py and
benchmarks/fit_table.py."""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.fit import colour_space
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
    out = []
    for k, view in enumerate(target.views):
        m = target.mask(k)
        a = colour_space.lab(view.image[m], target.white_y)
        b = colour_space.lab(target.render(params, k)[m], target.white_y)
        out.append(colour_space.delta_e_2000(a, b))
    return float(np.mean(np.concatenate(out)))


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
