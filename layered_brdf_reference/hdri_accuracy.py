"""How far the closure form is from its exact model under an HDRI.

A sphere's pixels are lit by one of Blender's bundled HDRIs (equirectangular, mapped as
Blender's Environment Texture maps it); each pixel is integrated by Monte Carlo over light
directions, the exact model (:func:`.exact_model.layered_brdf`) and the
closure form (:func:`.closures.closure_shading`) on the *same* directions, so their
difference is the closure form's error, not noise.  The noise thickness pattern has no numpy
twin: thickness follows the height pattern over the preset's range.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from layered_brdf_addon.model.geometry import dot
from .look_bounds import equirect_lookup
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.sphere import OrthoCamera, lower_normal, sphere_geometry, thickness_field

from .closures import closure_shading
from .lighting import environment_shading

SIZE = 40  # pixels across the sphere
EVERY = 3  # every third pixel of the sphere
SAMPLES = 256  # light directions per pixel
ENV_WIDTH = 512  # the HDRI is averaged down to this width (its detail is finer than the lobes)


@lru_cache(maxsize=None)
def hdri_image(name: str) -> np.ndarray:
    """A bundled HDRI (``forest``, ``courtyard``...) as an (H, W, 3) array, bottom row first as
    Blender stores images, box-filtered down to :data:`ENV_WIDTH`."""
    import OpenEXR

    from layered_brdf_addon.blender.lookdev import hdri_path  # needs bpy, which the rest of this module does not

    with OpenEXR.File(str(hdri_path(name)), separate_channels=True) as f:
        ch = f.parts[0].channels
        rgb = np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB"], axis=-1)
    k = max(1, rgb.shape[1] // ENV_WIDTH)
    h, w = rgb.shape[0] // k * k, rgb.shape[1] // k * k
    small = rgb[:h, :w].reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))
    return small[::-1]


def sphere_points(params: LayeredParams):
    """The sampled pixels of one sphere: n0, n1, d and the view."""
    cam = OrthoCamera(ortho_scale=2.2, width=SIZE, height=SIZE)
    geo = sphere_geometry(cam)
    sel = geo.mask & (dot(geo.n0, geo.view) > 0.1)
    idx = np.argwhere(sel)[::EVERY]
    n0 = geo.n0[idx[:, 0], idx[:, 1]]
    p_obj = geo.p_object[idx[:, 0], idx[:, 1]]
    d = thickness_field(params)(p_obj)
    return n0, lower_normal(params, n0, p_obj, d), d, geo.view


def closure_error(params: LayeredParams, hdri: str, samples: int = SAMPLES, seed: int = 0,
                  shading=closure_shading) -> dict:
    """L1 distance of the closure form (or of another ``shading``, e.g. baked tables:
    :func:`.fitted_tables.table_shading`) from the exact model, relative to the exact model's L1,
    over a sphere under ``hdri`` (thickness by height); and both mean pixels."""
    params = params.replace(thickness_mode="height")
    n0, n1, d, view = sphere_points(params)
    image = hdri_image(hdri)

    def environment(l):
        return equirect_lookup(image, l)

    common = dict(samples=samples, seed=seed, environment=environment)
    exact = environment_shading(params, n0, n1, d, view, **common)
    closure = environment_shading(params, n0, n1, d, view, shading=shading, **common)
    return dict(l1=float(np.abs(closure - exact).sum() / max(np.abs(exact).sum(), 1e-12)),
                exact=exact.mean(0), closure=closure.mean(0))
