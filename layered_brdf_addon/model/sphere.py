"""Expected pixels of unit spheres under one sun, seen by an orthographic camera.

This is the numpy side of the reference scene (docs/reference-scene.md): the render
of a sphere lit only by a zero-angle sun of irradiance ``E`` is, per pixel,
``E <l, n0> f(i, o)`` with ``l = -i`` the direction to the sun and ``o`` the view.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .brdf import diffuse_rho, specular_brdf
from .geometry import X_AXIS, Z_AXIS, correlated_normal, dot, finite_difference_gradient, safe_normalize, tilted_normal
from .params import LayeredParams, WAVELENGTHS_NM

# Finite-difference step (object units) of the thickness gradient, shared by OSL and nodes.
GRADIENT_STEP = 1.0e-3


@dataclass(frozen=True)
class OrthoCamera:
    """Orthographic camera looking along ``-view``; ``view`` points from the scene to the camera."""

    view: tuple[float, float, float] = (0.0, -1.0, 0.0)
    ortho_scale: float = 2.2
    width: int = 64
    height: int = 64
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    distance: float = 10.0

    def basis(self) -> np.ndarray:
        """Rows: right, up, back (= view); camera local X, Y, Z in world space."""
        back = safe_normalize(np.asarray(self.view, dtype=float))
        up_hint = Z_AXIS if abs(back[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
        right = safe_normalize(np.cross(up_hint, back))
        up = np.cross(back, right)
        return np.stack([right, up, back])

    @property
    def location(self) -> np.ndarray:
        return np.asarray(self.target, dtype=float) + self.distance * self.basis()[2]

    def matrix_world(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.basis().T
        m[:3, 3] = self.location
        return m

    def pixel_rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Origins (H, W, 3) of the rays through the pixel centres, and their direction (3,)."""
        right, up, back = self.basis()
        scale = self.ortho_scale / max(self.width, self.height)
        x = (np.arange(self.width) + 0.5 - self.width / 2.0) * scale
        y = (self.height / 2.0 - (np.arange(self.height) + 0.5)) * scale
        origins = self.location + x[None, :, None] * right + y[:, None, None] * up
        return origins, -back


@dataclass(frozen=True)
class Sun:
    """A zero-angle sun: ``direction`` points from the scene towards the sun."""

    direction: tuple[float, float, float] = (0.5, -1.0, 0.6)
    strength: float = 3.0

    @property
    def l(self) -> np.ndarray:
        return safe_normalize(np.asarray(self.direction, dtype=float))


@dataclass
class SphereGeometry:
    mask: np.ndarray  # (H, W) pixel sees a sphere
    sphere: np.ndarray  # (H, W) index of the sphere, -1 where none
    p_world: np.ndarray  # (H, W, 3)
    p_object: np.ndarray  # (H, W, 3) position relative to the sphere's centre
    n0: np.ndarray  # (H, W, 3) unit normal (zero where no sphere)
    view: np.ndarray  # (3,) direction towards the camera
    extra: dict = field(default_factory=dict)


def sphere_geometry(camera: OrthoCamera, centers=((0.0, 0.0, 0.0),), radius: float = 1.0) -> SphereGeometry:
    """Intersect the camera's pixel rays with spheres of ``radius`` at ``centers``."""
    origins, direction = camera.pixel_rays()
    h, w = origins.shape[:2]
    best_t = np.full((h, w), np.inf)
    which = np.full((h, w), -1)
    for k, c in enumerate(np.asarray(centers, dtype=float).reshape(-1, 3)):
        oc = origins - c
        b = dot(oc, direction)
        disc = b * b - (dot(oc, oc) - radius * radius)
        hit = disc >= 0.0
        t = -b - np.sqrt(np.where(hit, disc, 0.0))
        closer = hit & (t > 0.0) & (t < best_t)
        best_t = np.where(closer, t, best_t)
        which = np.where(closer, k, which)
    mask = which >= 0
    t = np.where(mask, best_t, 0.0)
    p = origins + t[..., None] * direction
    cen = np.asarray(centers, dtype=float).reshape(-1, 3)[np.maximum(which, 0)]
    p_obj = np.where(mask[..., None], (p - cen) / radius, 0.0)
    n0 = np.where(mask[..., None], safe_normalize(p_obj), 0.0)
    return SphereGeometry(mask, which, p, p_obj, n0, -direction)


def noise_factor_height(p_object: np.ndarray) -> np.ndarray:
    """The 'height' pattern: ``clamp(0.5 - 0.5 z, 0, 1)`` (thicker downwards)."""
    return np.clip(0.5 - 0.5 * p_object[..., 2], 0.0, 1.0)


def thickness_from_factor(params: LayeredParams, factor: np.ndarray) -> np.ndarray:
    """``d = d_min + (d_max - d_min) * clamp(n, 0, 1)`` in nm (SPEC)."""
    return params.d_min + (params.d_max - params.d_min) * np.clip(factor, 0.0, 1.0)


def thickness_field(params: LayeredParams):
    """``d(p)`` as a function of object-space position, where numpy can compute it."""
    if params.d_min == params.d_max:
        return lambda p: np.full(np.shape(p)[:-1], params.d_min)
    if params.thickness_mode == "height":
        return lambda p: thickness_from_factor(params, noise_factor_height(p))
    return None


def lower_normal(params: LayeredParams, n0: np.ndarray, p_object: np.ndarray, d_field=None,
                 object_up=Z_AXIS, object_x=X_AXIS) -> np.ndarray:
    """``n1`` for the parameters' normal mode (SPEC conventions)."""
    if params.normal_mode == "parallel":
        return n0
    if params.normal_mode == "tilted":
        return tilted_normal(n0, params.tilt, params.tilt_azimuth, object_up, object_x)
    if d_field is None:
        raise ValueError("normal_mode 'correlated' needs a thickness field numpy can evaluate "
                         "(pass the lower normal read from the render's AOV instead)")
    grad = finite_difference_gradient(d_field, p_object, GRADIENT_STEP)
    return correlated_normal(n0, grad, params.bump_strength)


def exact_shading(params: LayeredParams, n0, n1, d, l, v, wavelengths=WAVELENGTHS_NM):
    """Outgoing radiance per unit sun irradiance: ``<l, n0> (ks rho + kd base rho_d / pi)``."""
    cos_l = np.maximum(dot(n0, l), 0.0)
    i = np.broadcast_to(-np.asarray(l), np.shape(n0))
    o = np.broadcast_to(np.asarray(v), np.shape(n0))
    fs = specular_brdf(i, o, n0, n1, params.r1, d, params.e0, params.e1, params.r0, wavelengths, ng=n0)
    fd = diffuse_rho(params.r1, d, params.r0, wavelengths) * np.asarray(params.base_color) / np.pi
    return cos_l[..., None] * (params.ks * fs + params.kd * fd)


def render_spheres(params_list, camera: OrthoCamera, sun: Sun, centers=((0.0, 0.0, 0.0),), *,
                   normals=None, thickness=None, lower_normals=None, shading=exact_shading,
                   prefer_analytic=False):
    """Expected image (H, W, 3) of spheres, sphere ``k`` carrying ``params_list[k]``.

    ``normals``, ``thickness`` and ``lower_normals`` (per-pixel arrays, e.g. read from the
    render's passes) replace the analytic sphere normal, the thickness pattern and the lower
    normal where given; a noise pattern needs ``thickness`` (numpy does not evaluate Blender's
    noise).  ``shading`` is :func:`exact_shading` or a closure form with the same signature.
    With ``prefer_analytic``, ``thickness`` is used only where numpy cannot compute ``d``.
    Returns ``(image, geometry)``; ``geometry.extra`` holds the ``d`` and ``n1`` used.
    """
    if isinstance(params_list, LayeredParams):
        params_list = [params_list]
    geo = sphere_geometry(camera, centers)
    n0_all = geo.n0 if normals is None else np.where(geo.mask[..., None], safe_normalize(normals, geo.n0), 0.0)
    img = np.zeros(geo.mask.shape + (3,))
    d_all = np.zeros(geo.mask.shape)
    n1_all = np.zeros(geo.mask.shape + (3,))
    for k, params in enumerate(params_list):
        sel = geo.sphere == k
        if not np.any(sel):
            continue
        n0 = n0_all[sel]
        p = geo.p_object[sel]
        field_ = thickness_field(params)
        if thickness is not None and not (prefer_analytic and field_ is not None):
            d = np.asarray(thickness)[sel]
        elif field_ is not None:
            d = field_(p)
        else:
            raise ValueError("a noise thickness pattern needs the per-pixel thickness (the render's AOV)")
        if lower_normals is not None:
            n1 = safe_normalize(np.asarray(lower_normals)[sel], n0)
        else:
            n1 = lower_normal(params, n0, p, field_)
        img[sel] = sun.strength * shading(params, n0, n1, d, sun.l, geo.view)
        d_all[sel] = d
        n1_all[sel] = n1
    geo.extra.update(d=d_all, n1=n1_all, n0_used=n0_all)
    return img, geo
