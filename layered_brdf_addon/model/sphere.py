"""Expected pixels of unit spheres under one sun, seen by an orthographic camera.

This is the numpy side of the reference scene (docs/reference-scene.md): the render
of a sphere lit only by a zero-angle sun of irradiance ``E`` is, per pixel,
``E <l, n0> f(i, o)`` with ``l = -i`` the direction to the sun and ``o`` the view.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import program
from .geometry import Z_AXIS, dot, safe_normalize
from .ops_numpy import NoiseUnavailable, ShadingPoint
from .params import LayeredParams, iter_sockets, socket_values
from .policy import plan_effects


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


def shading_point(params: LayeredParams, n0, p_object, view=(0.0, 0.0, 1.0), matrix=None) -> ShadingPoint:
    """numpy ops at points of normal ``n0`` and object-space position ``p_object``, with the
    parameters' values as the shader's inputs (the node group's and OSL's socket values)."""
    inputs = socket_values({spec.name: getattr(params, spec.name) for spec in iter_sockets()}, ShadingPoint.SOCKETS)
    return ShadingPoint(inputs, n0, view, p_object, matrix)


def thickness_field(params: LayeredParams, matrix=None):
    """``d(p)`` as a function of object-space position (the shading program's thickness),
    or None for the noise pattern, which numpy does not evaluate."""
    plan = plan_effects(params)
    if plan.thickness == "noise":
        return None

    def field_(p):
        p = np.asarray(p, dtype=float)
        up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), p.shape)  # any normal: the thickness does not read it
        pt = shading_point(params, up, p, matrix=matrix)
        d = program.surface_geometry(pt, plan, lower=up)[5]  # the thickness (the lower normal not needed)
        return np.broadcast_to(np.asarray(d, dtype=float), p.shape[:-1]).copy()

    return field_


def lower_normal(params: LayeredParams, n0: np.ndarray, p_object: np.ndarray, d=None, matrix=None) -> np.ndarray:
    """``n1`` for the parameters' normal mode (the shading program's lower normal).

    ``d``: the thickness at the points (computed from the pattern when None).  The noise
    pattern with correlated normals needs the render's lower-normal pass instead.
    """
    plan = plan_effects(params)
    pt = shading_point(params, n0, p_object, matrix=matrix)
    if d is None:
        try:
            d = program.surface_geometry(pt, plan, lower=pt.shading_normal())[5]
        except NoiseUnavailable:
            d = np.zeros(np.shape(n0)[:-1])
    try:
        n1 = program.surface_geometry(pt, plan, thickness=d)[7]
    except NoiseUnavailable:
        raise ValueError("normal_mode 'correlated' with the noise pattern needs the render's lower normal "
                         "(pass lower_normals read from the render's AOV)") from None
    return np.asarray(np.broadcast_to(np.asarray(n1, dtype=float), np.shape(n0)))


def render_spheres(params_list, camera: OrthoCamera, sun: Sun, centers=((0.0, 0.0, 0.0),), *,
                   shading, normals=None, thickness=None, lower_normals=None, prefer_analytic=False, matrices=None):
    """Expected image (H, W, 3) of spheres, sphere ``k`` carrying ``params_list[k]``.

    ``normals``, ``thickness`` and ``lower_normals`` (per-pixel arrays, e.g. read from the
    render's passes) replace the analytic sphere normal, the thickness pattern and the lower
    normal where given; a noise pattern needs ``thickness`` (numpy does not evaluate Blender's
    noise).  ``shading(params, n0, n1, d, l, v)``: the outgoing radiance per unit sun irradiance,
    (..., 3), at the pixels' normals, thicknesses and lower normals, ``l`` the direction to the
    sun and ``v`` the view: the closure form (``layered_brdf_addon.fit.cycles_closures.
    closure_shading``, what the shaders render) or the exact model
    (``layered_brdf_reference.exact_spheres.exact_shading``).
    With ``prefer_analytic``, ``thickness`` is used only where numpy cannot compute ``d``.
    ``matrices``: per sphere, the 3x3 linear part of the object's transform (object to
    world) when it is not ``radius * identity`` — a rotated, non-uniformly scaled object
    whose mesh is a unit sphere in world space.
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
        matrix = None if matrices is None or matrices[k] is None else np.asarray(matrices[k], dtype=float)[:3, :3]
        p = geo.p_object[sel]
        if matrix is not None:
            p = (geo.p_world[sel] - np.asarray(centers, dtype=float).reshape(-1, 3)[k]) @ np.linalg.inv(matrix).T
        field_ = thickness_field(params, matrix)
        if thickness is not None and not (prefer_analytic and field_ is not None):
            d = np.asarray(thickness)[sel]
        elif field_ is not None:
            d = field_(p)
        else:
            raise ValueError("a noise thickness pattern needs the per-pixel thickness (the render's AOV)")
        if lower_normals is not None:
            n1 = safe_normalize(np.asarray(lower_normals)[sel], n0)
        else:
            n1 = lower_normal(params, n0, p, d, matrix)
        img[sel] = sun.strength * shading(params, n0, n1, d, sun.l, geo.view)
        d_all[sel] = d
        n1_all[sel] = n1
    geo.extra.update(d=d_all, n1=n1_all, n0_used=n0_all)
    return img, geo
