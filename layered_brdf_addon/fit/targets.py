"""What a fit matches: pixels of spheres under suns or an HDRI, or a reflectance table.

A target holds observed colours and predicts them from parameters with the numpy backend
of the shading program.  Both kinds give ``observed`` (N, 3) linear RGB and
``predict(params)`` of the same shape, and ``white_y``, the luminance their colours are
measured against (:mod:`.colour_space`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..model.params import LayeredParams
from ..model.policy import plan_effects
from ..model.sphere import OrthoCamera, Sun, lower_normal, sphere_geometry, thickness_field
from . import colour_space
from .cycles_closures import closure_shading, shade_closures
from .environment import Environment
from .see_through import see_through


GROUP_BINS = 6  # pixels seen alike: sixths of the half-vector's angle and of the view's cosine

# Where Blender's Noise Texture (scale 4, roughness 0.5) puts its value over a sphere, measured
# from the thickness pass of renders with d from 0 to 1000 nm (42,520 pixels each): the 1st,
# 5th, 10th, 25th, 50th, 75th, 90th, 95th and 99th percentiles, by the noise's detail.
NOISE_PERCENTILES = (1, 5, 10, 25, 50, 75, 90, 95, 99)
NOISE_QUANTILES = {0.0: (0.238, 0.290, 0.325, 0.393, 0.471, 0.560, 0.641, 0.687, 0.742),
                   2.0: (0.320, 0.363, 0.387, 0.431, 0.485, 0.542, 0.593, 0.621, 0.667),
                   8.0: (0.340, 0.379, 0.401, 0.440, 0.487, 0.537, 0.581, 0.606, 0.648)}
NOISE_MEDIAN = 0.485
NOISE_LEVELS = 7  # thickness levels a noise's colours are averaged over


def noise_levels(detail: float) -> np.ndarray:
    """The noise's value at the middle of ``NOISE_LEVELS`` equal slices of its distribution,
    interpolated between the measured details."""
    details = np.array(sorted(NOISE_QUANTILES))
    table = np.array([NOISE_QUANTILES[k] for k in details])
    q = np.array([np.interp(detail, details, table[:, i]) for i in range(table.shape[1])])
    probs = (np.arange(NOISE_LEVELS) + 0.5) / NOISE_LEVELS * 100.0
    return np.interp(probs, NOISE_PERCENTILES, q)


class TargetError(ValueError):
    """A target that cannot be fitted: says why."""


@dataclass
class SphereView:
    """One image of spheres under one sun, or under an environment (``environment`` given:
    the world's HDRI is the only light, ``sun`` is None): the pixels of sphere ``sphere`` are
    fitted."""

    image: np.ndarray  # (H, W, 3) linear RGB, row 0 at the top
    camera: OrthoCamera
    sun: Sun | None
    centers: tuple = ((0.0, 0.0, 0.0),)
    sphere: int = 0
    environment: Environment | None = None

    def __post_init__(self):
        if (self.sun is None) == (self.environment is None):
            raise TargetError("a view is lit by one sun or by one environment")


@dataclass
class SphereTarget:
    """Spheres seen by orthographic cameras under suns (renders of the reference scene).

    ``pixels`` caps the pixels the optimiser looks at (every view together): the brightest
    tenth of each view's sphere, where the highlight and its colours are, then an even
    spread of the rest.
    """

    views: Sequence[SphereView]
    pixels: int = 1500
    _points: list = field(default_factory=list, repr=False)
    _group_of: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self):
        if not self.views:
            raise TargetError("no image to fit")
        per_view = max(64, self.pixels // len(self.views))
        self._points = [self._sample(v, per_view) for v in self.views]
        obs = np.concatenate([p["observed"] for p in self._points])
        if not np.all(np.isfinite(obs)):
            raise TargetError("the target's pixels hold NaN or infinite values")
        if float(colour_space.luminance(obs).max(initial=0.0)) <= 0.0:
            raise TargetError("the target's sphere is black: there is nothing to fit")
        self.observed = obs
        self.white_y = colour_space.white_of(obs)

    @staticmethod
    def _sample(view: SphereView, count: int) -> dict:
        geo = sphere_geometry(view.camera, view.centers)
        img = np.asarray(view.image, dtype=float)
        if img.shape[:2] != geo.mask.shape or img.ndim != 3 or img.shape[2] < 3:
            raise TargetError(f"an image of {img.shape[:2]} pixels where the camera sees {geo.mask.shape}")
        rows, cols = np.nonzero(geo.sphere == view.sphere)
        if rows.size == 0:
            raise TargetError(f"the camera sees no pixel of sphere {view.sphere}")
        rgb = img[rows, cols, :3]
        y = colour_space.luminance(rgb)
        order = np.argsort(-y, kind="stable")
        bright = order[: max(1, min(count // 2, rows.size // 10))]
        rest = np.setdiff1d(np.arange(rows.size), bright)
        step = max(1, rest.size // max(1, count - bright.size))
        pick = np.sort(np.concatenate([bright, rest[::step][: count - bright.size]]))
        r, c = rows[pick], cols[pick]
        return {"view": view, "rows": r, "cols": c, "observed": rgb[pick], "n0": geo.n0[r, c],
                "p_object": geo.p_object[r, c], "v": geo.view}

    def predict(self, params: LayeredParams) -> np.ndarray:
        """The sampled pixels' colours (for a noise thickness: at the pattern's median)."""
        return np.concatenate([self._predict_points(params, p) for p in self._points])

    def matches_statistics(self, params: LayeredParams) -> bool:
        """Whether ``params`` put the thickness in a noise pattern: numpy does not evaluate
        Blender's noise, so the fit matches colour statistics of pixels seen alike instead
        of pixels (the noise's range through its value distribution, not its pattern)."""
        return plan_effects(params).thickness == "noise"

    def features(self, params: LayeredParams) -> np.ndarray:
        """What a fit compares, in CIELAB: every sampled pixel's colour, or for a noise
        thickness, per group of pixels seen alike, the mean colour and its spread (rows of
        means, then rows of standard deviations) over the group's pixels and the noise's
        thickness levels (:func:`noise_levels`)."""
        if not self.matches_statistics(params):
            return colour_space.lab(self.predict(params), self.white_y)
        lab = np.concatenate([self._levels_lab(params, p) for p in self._points])
        return self._group_stats(lab, np.full(NOISE_LEVELS, 1.0 / NOISE_LEVELS))

    def observed_features(self, params: LayeredParams) -> np.ndarray:
        obs = colour_space.lab(self.observed, self.white_y)
        if not self.matches_statistics(params):
            return obs
        return self._group_stats(obs[:, None, :], np.ones(1))

    def feature_weights(self, params: LayeredParams) -> np.ndarray:
        """Each pixel alike; a group's statistics by the square root of its pixels."""
        if not self.matches_statistics(params):
            return np.ones(len(self.observed))
        w = np.sqrt(np.bincount(self._groups(), minlength=self._group_count()).astype(float))
        return np.concatenate([w, w])

    def colour_rows(self, params: LayeredParams) -> slice:
        """The rows of :meth:`features` that are colours (a CIEDE2000 reads them)."""
        return slice(None) if not self.matches_statistics(params) else slice(0, self._group_count())

    def _levels_lab(self, params: LayeredParams, pts: dict) -> np.ndarray:
        """(N, levels, 3): the pixels' colours at each of the noise's thickness levels."""
        out = []
        for u in noise_levels(params.noise_detail):
            d = np.full(len(pts["n0"]), params.d_min + (params.d_max - params.d_min) * u)
            out.append(colour_space.lab(self._shade(params, pts, d), self.white_y))
        return np.stack(out, axis=1)

    def _groups(self) -> np.ndarray:
        """Each sampled pixel's group: its view, and the sixths of the angle between its
        normal and the half-vector (under an environment: of the mirrored view's height) and
        of its view cosine."""
        if self._group_of is None:
            keys = []
            for k, p in enumerate(self._points):
                v = p["v"]
                nv = np.clip(p["n0"] @ v, 0.0, 1.0)
                if p["view"].sun is not None:
                    l = p["view"].sun.l
                    h = (v + l) / max(float(np.linalg.norm(v + l)), 1e-12)
                    nh = np.clip(p["n0"] @ h, 0.0, 1.0)
                    a = np.minimum((np.arccos(nh) / (np.pi / 2) * GROUP_BINS).astype(int), GROUP_BINS - 1)
                else:  # under an environment: the height of the mirrored view (sky, horizon, ground)
                    r = 2.0 * nv[:, None] * p["n0"] - v
                    a = np.minimum(((r[:, 2] + 1.0) / 2.0 * GROUP_BINS).astype(int), GROUP_BINS - 1)
                b = np.minimum((nv * GROUP_BINS).astype(int), GROUP_BINS - 1)
                keys.append((k * GROUP_BINS + a) * GROUP_BINS + b)
            _, group = np.unique(np.concatenate(keys), return_inverse=True)
            self._group_of = group.ravel()
        return self._group_of

    def _group_count(self) -> int:
        return int(self._groups().max()) + 1

    def _group_stats(self, lab: np.ndarray, level_weights: np.ndarray) -> np.ndarray:
        """Per group: the mean of each Lab coordinate and its standard deviation, over the
        group's pixels and (for the model) the thickness levels weighted by ``level_weights``."""
        g, n = self._groups(), self._group_count()
        w = np.broadcast_to(level_weights[None, :], lab.shape[:2])
        total = np.bincount(g, weights=w.sum(axis=1), minlength=n)[:, None]

        def moment(x):
            return np.stack([np.bincount(g, weights=(w * x[..., c]).sum(axis=1), minlength=n)
                             for c in range(3)], -1) / total

        mean = moment(lab)
        std = np.sqrt(np.maximum(moment(lab ** 2) - mean ** 2, 0.0))
        return np.concatenate([mean, std])

    @staticmethod
    def _predict_points(params: LayeredParams, pts: dict) -> np.ndarray:
        field_ = thickness_field(params)
        if field_ is None:  # a noise: its median thickness everywhere
            d = np.full(len(pts["n0"]), params.d_min + (params.d_max - params.d_min) * NOISE_MEDIAN)
        else:
            d = field_(pts["p_object"])
        return SphereTarget._shade(params, pts, d)

    @staticmethod
    def _shade(params: LayeredParams, pts: dict, d: np.ndarray) -> np.ndarray:
        view, plan, v = pts["view"], plan_effects(params), pts["v"]

        def side(n0, p_object, d):
            n1 = lower_normal(params, n0, p_object, d)
            if view.environment is not None:
                closures = shade_closures(params, n0, n1, d, v, plan)
                return view.environment.shade(closures, n0, v, plan.lobe, ng=n0)
            return view.sun.strength * closure_shading(params, n0, n1, d, view.sun.l, v, ng=n0, plan=plan)

        front = side(pts["n0"], pts["p_object"], d)
        if params.base_layer != "transparent":
            return front
        field_ = thickness_field(params)  # None for a noise: the far side at the same level

        def far(n_far, p_far):
            return side(n_far, p_far, d if field_ is None else field_(p_far))

        background = np.zeros(3) if view.environment is None else view.environment.radiance(-np.asarray(v))
        return front + see_through(params, plan, pts["n0"], v, far, background)

    def render(self, params: LayeredParams, view: int = 0) -> np.ndarray:
        """The whole image of view ``view`` for ``params`` (the fitted sphere only)."""
        v = self.views[view]
        geo = sphere_geometry(v.camera, v.centers)
        rows, cols = np.nonzero(geo.sphere == v.sphere)
        pts = {"view": v, "n0": geo.n0[rows, cols], "p_object": geo.p_object[rows, cols], "v": geo.view}
        out = np.zeros(geo.mask.shape + (3,))
        out[rows, cols] = self._predict_points(params, pts)
        return out

    def mask(self, view: int = 0) -> np.ndarray:
        v = self.views[view]
        return sphere_geometry(v.camera, v.centers).sphere == v.sphere


CHANNELS = {"r": 0, "g": 1, "b": 2, "red": 0, "green": 1, "blue": 2}
MIN_WAVELENGTHS = 8


@dataclass
class ReflectanceTarget:
    """A smooth film's mirror reflectance at angles of incidence, as linear RGB per angle.

    Built by :meth:`from_rows` from a table of (angle in degrees, channel or wavelength,
    reflectance): channels ``r``, ``g``, ``b`` give the colour directly; wavelengths (nm,
    at least 8 spanning 380-700 nm per angle) are seen under D65 by the CIE 1931 observer.
    The model's side is :func:`.mirror.mirror_reflectance` of a uniform film ``d_min`` thick.
    """

    angles: np.ndarray  # (A,) degrees
    rgb: np.ndarray  # (A, 3) linear Rec.709 reflectance
    uniform_film = True  # one thickness, d_min: the fit ties d_max to it

    def __post_init__(self):
        self.angles = np.asarray(self.angles, dtype=float)
        self.observed = np.asarray(self.rgb, dtype=float)
        self.white_y = 1.0

    @classmethod
    def from_rows(cls, rows: Sequence[tuple[float, object, float]]) -> "ReflectanceTarget":
        """From (angle, channel or wavelength, reflectance) rows; :class:`TargetError` says
        what is wrong with a table that cannot be fitted."""
        if not rows:
            raise TargetError("the reflectance table is empty")
        by_angle: dict[float, dict] = {}
        for i, (angle, where, value) in enumerate(rows, start=1):
            angle, value = _number(angle, "angle", i), _number(value, "reflectance", i)
            if not 0.0 <= angle < 90.0:
                raise TargetError(f"row {i}: angle {angle:g} is outside [0, 90) degrees")
            if not 0.0 <= value <= 1.0:
                raise TargetError(f"row {i}: reflectance {value:g} is outside [0, 1]")
            key = str(where).strip().lower()
            slot = CHANNELS.get(key)
            if slot is None:
                slot = _number(where, "channel or wavelength", i)
                if not 200.0 <= slot <= 2000.0:
                    raise TargetError(f"row {i}: wavelength {slot:g} nm is outside [200, 2000] nm")
            by_angle.setdefault(angle, {})[slot] = value
        angles, rgb = [], []
        for angle, values in sorted(by_angle.items()):
            rgb.append(_colour_of(angle, values))
            angles.append(angle)
        return cls(np.array(angles), np.array(rgb))

    def predict(self, params: LayeredParams) -> np.ndarray:
        from .mirror import mirror_reflectance

        return np.stack([mirror_reflectance(params, a) for a in self.angles])


def _number(value, name: str, row: int) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise TargetError(f"row {row}: {name} {value!r} is not a number") from None
    if not np.isfinite(x):
        raise TargetError(f"row {row}: {name} is {value!r}, not a finite number")
    return x


def _colour_of(angle: float, values: dict) -> np.ndarray:
    channels = [k for k in values if isinstance(k, int)]
    lams = sorted(k for k in values if isinstance(k, float))
    if channels and lams:
        raise TargetError(f"angle {angle:g}: rows of channels and of wavelengths mixed")
    if channels:
        if sorted(channels) != [0, 1, 2]:
            raise TargetError(f"angle {angle:g}: needs the channels r, g and b")
        return np.array([values[0], values[1], values[2]])
    lo, hi = colour_space.VISIBLE_NM
    if len(lams) < MIN_WAVELENGTHS or lams[0] > lo or lams[-1] < hi:
        raise TargetError(f"angle {angle:g}: {len(lams)} wavelengths from {lams[0]:g} to {lams[-1]:g} nm; "
                          f"needs at least {MIN_WAVELENGTHS} spanning {lo:g}-{hi:g} nm")
    return colour_space.spectrum_to_rgb(np.array(lams), np.array([values[k] for k in lams]))
