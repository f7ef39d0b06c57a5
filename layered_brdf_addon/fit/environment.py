"""The closure form lit by an environment: what Cycles renders of a material under an HDRI.

A sun lights a shading point from one direction, so each closure is evaluated once
(:func:`.cycles_closures.evaluate_closures`).  An environment lights it from everywhere:
each closure's pixel is ``int L(l) f_c(v, l) dl`` (cosine included).  Neither the shaders
nor this module know the light when the closures are made, so the closures come from the
shading program as for a sun, and only their integration against the environment is new:

* **glossy closures** by filtered importance sampling (Colbert & Krivanek 2007): a fixed,
  stratified set of microfacet normals drawn from the closure's own Beckmann distribution
  (anisotropic about its tangent, as Cycles samples it), each light direction weighted by
  ``f cos / pdf`` (for Cycles' Beckmann closure ``<v, h> / (<n, v> <n, h> (1 + Lambda_v +
  Lambda_l))``) and read from the environment's mip level whose texels are about as large as
  the sample's share of the lobe.  The same normals serve every evaluation, so the pixel is a
  smooth function of the parameters (a fit's slopes are not noise);
* **the diffuse closure** from the environment's irradiance (its cosine convolution,
  computed once), divided by pi.

Mapping and units follow Blender's Environment Texture on the world's Background: the image
equirectangular, bottom row first as Blender stores it, ``u = -atan2(y, x) / 2 pi + 0.5``,
``v = atan2(z, hypot(x, y)) / pi + 0.5``, radiance = pixel x strength.  The sphere does not
shadow itself (a convex shape), so the reference scene's direct light is the whole pixel.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model.geometry import dot, safe_normalize
from .cycles_closures import CLOSURE_WEIGHT_CUTOFF, _lambda_from, ensure_valid_specular_reflection, glossy_alphas

# Blender's bundled HDRIs a Principled material is rendered under by default when it is a fit's
# target, besides the suns (``fit --principled``, the panel's Fit to Render...): fitted under
# suns alone, a conversion leaves what a wide environment lights unconstrained (a clear
# film's see-through, the lobes' tails); docs/fitting.md has the measurements.
DEFAULT_HDRIS = ("forest",)
BASE_WIDTH = 512  # the finest mip level's width: the bundled HDRIs' detail is finer than any lobe but a mirror's
IRRADIANCE_SIZE = (16, 32)  # rows, columns of the irradiance map (the cosine lobe is wide)
SAMPLE_GRID = 6  # microfacet normals per glossy closure: SAMPLE_GRID^2, stratified
SAMPLE_SEED = 7


def direction_to_uv(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Blender's equirectangular mapping of world directions (..., 3) to (u, v) in [0, 1]."""
    u = -np.arctan2(d[..., 1], d[..., 0]) / (2.0 * np.pi) + 0.5
    v = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1])) / np.pi + 0.5
    return u, v


def uv_to_direction(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    phi = (0.5 - u) * 2.0 * np.pi
    lat = (v - 0.5) * np.pi
    return np.stack([np.cos(lat) * np.cos(phi), np.cos(lat) * np.sin(phi), np.sin(lat)], axis=-1)


def _halve(image: np.ndarray) -> np.ndarray:
    h, w = image.shape[0] // 2 * 2, image.shape[1] // 2 * 2
    return image[:h, :w].reshape(h // 2, 2, w // 2, 2, -1).mean(axis=(1, 3))


def _bilinear(image: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup at texel centres, wrapping in u, clamped in v."""
    h, w = image.shape[:2]
    x = u * w - 0.5
    y = np.clip(v * h - 0.5, 0.0, h - 1.0)
    x0 = np.floor(x)
    y0 = np.minimum(np.floor(y), h - 2 if h > 1 else 0)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    x0 = x0.astype(int) % w
    x1 = (x0 + 1) % w
    y0 = y0.astype(int)
    y1 = np.minimum(y0 + 1, h - 1)
    top = image[y0, x0] * (1.0 - fx) + image[y0, x1] * fx
    bottom = image[y1, x0] * (1.0 - fx) + image[y1, x1] * fx
    return top * (1.0 - fy) + bottom * fy


def _stratified(count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(count), np.arange(count), indexing="ij")
    u1 = (i.ravel() + rng.random(count * count)) / count
    u2 = (j.ravel() + rng.random(count * count)) / count
    return np.clip(u1, 1e-6, 1.0 - 1e-6), u2


def closures_shape(result, n0: np.ndarray) -> tuple:
    """The shape of the closures' points, the vector axis left out: the normals' (P,), grown
    by a stack's leading axis where a closure's values have one."""
    shapes = [n0.shape[:-1]]
    for cl in result.glossy:
        shapes += [np.shape(x) for x in (*cl.weight, cl.exponent, cl.alpha, cl.anisotropy)]
        shapes += [np.shape(x)[:-1] for x in (cl.normal, cl.tangent)]
    shapes += [np.shape(x) for x in result.diffuse or ()]
    return np.broadcast_shapes(*shapes)


def lobe_of(closure, shape: tuple, lobe_kind: str) -> tuple:
    """What a glossy closure's integral depends on besides the view, broadcast to the points'
    ``shape``: its normal and exponent (Phong), or its normal, alpha, anisotropy and tangent
    (Beckmann; the tangent None when it has none)."""
    def each(x, vector=False):
        return None if x is None else np.broadcast_to(np.asarray(x, dtype=float), shape + ((3,) if vector else ()))

    if lobe_kind == "phong":
        return each(closure.normal, True), each(closure.exponent)
    return each(closure.normal, True), each(closure.alpha), each(closure.anisotropy), each(closure.tangent, True)


@dataclass
class Environment:
    """An equirectangular HDRI as the world's only light; ``image`` (H, W, 3) linear, bottom
    row first (as Blender stores it), radiance = pixel x ``strength``."""

    image: np.ndarray
    strength: float = 1.0
    name: str = "environment"
    _mips: list = field(default_factory=list, repr=False)
    _irradiance: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        img = np.asarray(self.image, dtype=float)[..., :3]
        if img.ndim != 3 or img.shape[0] < 2 or img.shape[1] < 4:
            raise ValueError(f"an environment image of shape {img.shape}: needs (H, W, 3)")
        if not np.all(np.isfinite(img)):
            raise ValueError("the environment image holds NaN or infinite values")
        # Bundled HDRIs hold a few slightly negative texels (forest.exr: 826, down to -0.002);
        # no light is negative.
        img = np.maximum(img, 0.0) * float(self.strength)
        while img.shape[1] > BASE_WIDTH:
            img = _halve(img)
        self._mips = [img]
        while self._mips[-1].shape[0] > 1:
            self._mips.append(_halve(self._mips[-1]))
        self._irradiance = self._irradiance_map()

    # -- lookups ---------------------------------------------------------------
    def radiance(self, directions: np.ndarray, solid_angle: np.ndarray | float = 0.0) -> np.ndarray:
        """Radiance (..., 3) from ``directions``, averaged over about ``solid_angle``
        steradians (trilinear between mip levels; 0: the finest level)."""
        u, v = direction_to_uv(np.asarray(directions, dtype=float))
        h0, w0 = self._mips[0].shape[:2]
        texel = 2.0 * np.pi * np.pi / (w0 * h0)  # a texel's solid angle at the equator
        level = np.clip(0.5 * np.log2(np.maximum(np.asarray(solid_angle, dtype=float), 1e-30) / texel),
                        0.0, len(self._mips) - 1.0)
        level = np.broadcast_to(level, u.shape)
        lo = np.floor(level).astype(int)
        t = (level - lo)[..., None]
        out = np.zeros(u.shape + (3,))
        for k in np.unique(lo):
            sel = lo == k
            a = _bilinear(self._mips[k], u[sel], v[sel])
            b = _bilinear(self._mips[min(k + 1, len(self._mips) - 1)], u[sel], v[sel])
            out[sel] = a * (1.0 - t[sel]) + b * t[sel]
        return out

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """``int L(l) max(<n, l>, 0) dl`` (..., 3) for unit ``normals``."""
        u, v = direction_to_uv(np.asarray(normals, dtype=float))
        return _bilinear(self._irradiance, u, v)

    def _irradiance_map(self) -> np.ndarray:
        src = self._mips[0]
        while src.shape[1] > 128:
            src = _halve(src)
        h, w = src.shape[:2]
        sv, su = (np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w
        dirs = uv_to_direction(*np.meshgrid(su, sv)).reshape(-1, 3)
        lat = (sv - 0.5) * np.pi
        d_omega = np.repeat(np.cos(lat) * (np.pi / h) * (2.0 * np.pi / w), w)
        rows, cols = IRRADIANCE_SIZE
        ov, ou = (np.arange(rows) + 0.5) / rows, (np.arange(cols) + 0.5) / cols
        normals = uv_to_direction(*np.meshgrid(ou, ov)).reshape(-1, 3)
        cos = np.maximum(normals @ dirs.T, 0.0) * d_omega[None, :]
        return (cos @ src.reshape(-1, 3)).reshape(rows, cols, 3)

    # -- closures ---------------------------------------------------------------
    def shade(self, result, n0: np.ndarray, v: np.ndarray, lobe_kind: str = "beckmann", ng=None,
              bump_correction: bool = True) -> np.ndarray:
        """The pixels (P, 3) of the closures ``result`` (the shading program's, at normals
        ``n0`` (P, 3) and views ``v``) under this environment, as Cycles integrates them.  The
        closures of a stack of K parameter sets (:func:`.cycles_closures.stacked_values`:
        values with a leading axis K) give (K, P, 3), each lobe integrated once however many
        sets share it (:meth:`_stacked_lobe`)."""
        n0 = np.asarray(n0, dtype=float)
        v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
        shape = closures_shape(result, n0)
        out = np.zeros(shape + (3,))
        for cl in result.glossy:
            w = np.maximum(np.stack([np.broadcast_to(x, shape) for x in cl.weight], axis=-1), 0.0)
            keep = w.mean(axis=-1) >= CLOSURE_WEIGHT_CUTOFF
            if not np.any(keep):
                continue
            val = self._stacked_lobe(lobe_kind, lobe_of(cl, shape, lobe_kind), n0, v, ng if bump_correction else None)
            out += np.where(keep[..., None], w * val, 0.0)
        if result.diffuse is not None:
            col = np.maximum(np.stack([np.broadcast_to(x, shape) for x in result.diffuse], axis=-1), 0.0)
            col = np.where((col.mean(axis=-1) >= CLOSURE_WEIGHT_CUTOFF)[..., None], col, 0.0)
            out += col * self.irradiance(n0) / np.pi
        return out

    def _stacked_lobe(self, lobe_kind: str, lobe: tuple, n0, v, ng) -> np.ndarray:
        """A glossy closure's integral, its weight left out, (P, 3) or for a stack (K, P, 3):
        once per distinct row of its lobe (:func:`lobe_of`).  Most of a fit's slopes step a
        parameter that changes a closure's weight alone (a thickness, a base colour), and the
        integral is most of the work of shading under an environment."""
        if lobe[0].ndim == 2:
            return self._lobe(lobe_kind, lobe, n0, v, ng)
        out = np.empty(lobe[0].shape)
        first: dict[bytes, int] = {}
        for k in range(len(out)):
            row = tuple(None if a is None else a[k] for a in lobe)
            key = b"".join(np.ascontiguousarray(a).tobytes() for a in row if a is not None)
            out[k] = out[first[key]] if key in first else self._lobe(lobe_kind, row, n0, v, ng)
            first.setdefault(key, k)
        return out

    def _lobe(self, lobe_kind: str, lobe: tuple, n0, v, ng) -> np.ndarray:
        """One closure's lobe (:func:`lobe_of`, arrays over the points) integrated against the
        environment, its normal bent as Cycles bends it when ``ng`` is given."""
        N = safe_normalize(lobe[0], n0)
        if ng is not None:
            N = np.where(np.all(N == ng, axis=-1, keepdims=True), N, ensure_valid_specular_reflection(ng, v, N))
        if lobe_kind == "phong":
            return self._phong(N, v, lobe[1], n0)
        return self._beckmann(N, v, lobe[1], lobe[2], lobe[3], n0)

    def _beckmann(self, N, v, alpha, aniso, T, n0) -> np.ndarray:
        """Cycles' Beckmann closure (no Fresnel) integrated against the environment."""
        ax, ay = glossy_alphas(alpha, aniso)
        ax, ay = np.maximum(ax, 1e-4)[..., None], np.maximum(ay, 1e-4)[..., None]
        if T is None:
            T = np.broadcast_to(np.array([1.0, 0.0, 0.0]), N.shape)
        iso = np.abs(np.clip(aniso, -0.99, 0.99)) <= 1e-4
        # Cycles' frame: the tangent when anisotropic, any perpendicular when not.
        helper = np.where(np.abs(N[..., :1]) > 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
        T = np.where(iso[..., None], helper, T)
        Y = safe_normalize(np.cross(N, T), np.cross(N, helper))
        X = np.cross(Y, N)
        u1, u2 = _stratified(SAMPLE_GRID, SAMPLE_SEED)
        r = np.sqrt(-np.log(1.0 - u1))  # tan(theta_h) / alpha: Beckmann's slope distribution
        phi = 2.0 * np.pi * u2
        sx, sy = ax * (r * np.cos(phi)), ay * (r * np.sin(phi))  # (P, S) slopes
        h = safe_normalize(-sx[..., None] * X[:, None] - sy[..., None] * Y[:, None] + N[:, None])
        vv = v[:, None]
        vh = dot(vv, h)
        l = 2.0 * vh[..., None] * h - vv
        nv = dot(N, v)[:, None]
        nl = dot(N[:, None], l)
        nh = dot(N[:, None], h)

        def lam(w):
            wz, wx, wy = dot(w, N[:, None]), dot(w, X[:, None]), dot(w, Y[:, None])
            return _lambda_from(((ax * wx) ** 2 + (ay * wy) ** 2) / np.maximum(wz * wz, 1e-30))

        with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
            weight = vh / (np.maximum(nv, 1e-30) * np.maximum(nh, 1e-30) * (1.0 + lam(vv) + lam(l)))
            # pdf of l: D <n,h> / (4 <v,h>), D = exp(-slope^2) / (pi ax ay <n,h>^4)
            pdf = np.exp(-(r * r)) / (np.pi * ax * ay * np.maximum(nh, 1e-30) ** 3) / (4.0 * np.maximum(vh, 1e-30))
        ok = (vh > 0.0) & (nl >= 0.0) & (nv > 0.0) & np.isfinite(weight) & np.isfinite(pdf) & (pdf > 0.0)
        # Bump shadowing, as for a sun: a closure normal and n0 on either side of the light.
        ok &= ~(dot(n0[:, None], l) * dot(n0, N)[:, None] * nl < 0.0)
        count = u1.size
        solid = 1.0 / (count * np.where(ok, pdf, 1.0))
        L = self.radiance(l, solid)
        return np.sum(np.where(ok[..., None], weight[..., None] * L, 0.0), axis=1) / count

    def _phong(self, N, v, e, n0) -> np.ndarray:
        """Cycles' ``phong_ramp`` (eight equal colours) integrated against the environment."""
        u1, u2 = _stratified(SAMPLE_GRID, SAMPLE_SEED)
        e = np.maximum(e, 0.0)[..., None]
        R = 2.0 * dot(N, v)[..., None] * N - v
        helper = np.where(np.abs(R[..., :1]) > 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
        t = safe_normalize(np.cross(helper, R))
        b = np.cross(R, t)
        cos_t = u1 ** (1.0 / (e + 1.0))
        sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
        ph = 2.0 * np.pi * u2
        l = (t[:, None] * (sin_t * np.cos(ph))[..., None] + b[:, None] * (sin_t * np.sin(ph))[..., None]
             + R[:, None] * cos_t[..., None])
        nl = dot(N[:, None], l)
        weight = nl * (e + 2.0) / (e + 1.0)  # f cos / pdf, pdf = (e + 1)/(2 pi) cos^e
        pdf = (e + 1.0) / (2.0 * np.pi) * cos_t ** e
        ok = (nl > 0.0) & (dot(N, v)[:, None] > 0.0) & (pdf > 0.0)
        ok &= ~(dot(n0[:, None], l) * dot(n0, N)[:, None] * nl < 0.0)
        count = u1.size
        L = self.radiance(l, 1.0 / (count * np.where(ok, pdf, 1.0)))
        return np.sum(np.where(ok[..., None], weight[..., None] * L, 0.0), axis=1) / count
