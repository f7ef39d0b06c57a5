"""What a fit matches: pixels of spheres under suns or an HDRI, or a reflectance table.

A target holds observed colours and predicts them from parameters with the numpy backend
of the shading program.  Both kinds give ``observed`` (N, 3) linear RGB and
``predict(params)`` of the same shape, and ``white_y``, the luminance their colours are
measured against (:mod:`.colour_space`): a sphere target's per sampled pixel, its view's.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..model import program
from ..model.ops_numpy import NoiseUnavailable, ShadingPoint
from ..model.params import LayeredParams, socket_values
from ..model.plan import EffectPlan
from ..model.policy import plan_effects
from ..model.sphere import OrthoCamera, Sun, sphere_geometry
from . import colour_space
from .cycles_closures import evaluate_closures, points_shape, shade_closures, stack_key, stacked_values
from .environment import Environment
from .mirror import mirror_reflectance
from .see_through import base_transmittance, far_side, see_through


# A sphere is black when fewer of its pixels than this are lit in every view.  Not "no pixel":
# under an HDRI, Cycles' samples that graze the silhouette see the world behind, and a black
# material's rim holds a few pixels of 1/256 of the background (measured: 10 of 7,200 at
# 96 px, 256 samples).  A lobe's tails light far more of the sphere than this.
LIT_FRACTION = 0.01
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
# Parameter sets shaded by one run of the program: each adds every sampled pixel to each of
# the run's temporaries (16 sets of 1,500 pixels: arrays of 600 kB, twice that through a
# transparent base, whose far side is shaded too).
STACK_SETS = 16
# Each view's colours are measured against its own white (one image, one exposure: as a render of
# the fit is judged), never below this share of the brightest view's, so that a view whose sphere
# is almost black (a sun behind it) does not make its noise the fit's largest differences.
DARKEST_WHITE = 0.1


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
    uniform_film: bool = False  # the target is a film of one thickness: the fit's d_max follows its d_min
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
        if max(p["lit"] for p in self._points) < LIT_FRACTION:
            raise TargetError("the target's sphere is black: there is nothing to fit")
        self.observed = obs
        whites = [colour_space.white_of(p["observed"]) for p in self._points]
        self.view_whites = [max(w, DARKEST_WHITE * max(whites)) for w in whites]
        self.white_y = np.concatenate([np.full(len(p["observed"]), w)
                                       for p, w in zip(self._points, self.view_whites)])
        self._batches = light_batches(self._points)

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
                "p_object": geo.p_object[r, c], "v": geo.view, "lit": float(np.mean(y > 0.0))}

    def predict(self, params: LayeredParams) -> np.ndarray:
        """The sampled pixels' colours (for a noise thickness: at the pattern's median)."""
        return self.predict_many([params])[0]

    def predict_many(self, params_list: Sequence[LayeredParams]) -> np.ndarray:
        """(K, N, 3): :meth:`predict` for each of ``K`` parameter sets, the sets that can share
        a run of the program (:func:`.cycles_closures.stack_key`) shaded together,
        :data:`STACK_SETS` at a time (a fit's slopes: one set per free parameter, each a step
        away from the same point)."""
        out = np.empty((len(params_list),) + self.observed.shape)
        for plan, indices in by_stack(params_list):
            for start in range(0, len(indices), STACK_SETS):
                chunk = indices[start:start + STACK_SETS]
                for batch in self._batches:
                    shaded = shade_points(batch, [params_list[i] for i in chunk], plan)
                    out[np.ix_(chunk, batch["rows"])] = np.broadcast_to(shaded, (len(chunk), len(batch["rows"]), 3))
        return out

    def matches_statistics(self, params: LayeredParams) -> bool:
        """Whether ``params`` put the thickness in a noise pattern: numpy does not evaluate
        Blender's noise, so the fit matches colour statistics of pixels seen alike instead
        of pixels (the noise's range through its value distribution, not its pattern).  The mode
        declared, not the plan's effect: a fit may pass through a range of zero width, which the plan
        renders as a uniform film, and its rows must stay those of the target's statistics."""
        return params.thickness_mode == "noise"

    def features(self, params: LayeredParams) -> np.ndarray:
        """What a fit compares, in CIELAB: every sampled pixel's colour, or for a noise
        thickness, per group of pixels seen alike, the mean colour and its spread (rows of
        means, then rows of standard deviations) over the group's pixels and the noise's
        thickness levels (:func:`noise_levels`)."""
        if not self.matches_statistics(params):
            return colour_space.lab(self.predict(params), self.white_y)
        return self._group_stats(self._levels_lab(params), np.full(NOISE_LEVELS, 1.0 / NOISE_LEVELS))

    def features_many(self, params_list: Sequence[LayeredParams]) -> np.ndarray:
        """(K, rows, 3): :meth:`features` for each of ``K`` parameter sets; the sets matched
        pixel by pixel shaded together (:meth:`predict_many`)."""
        if any(self.matches_statistics(p) for p in params_list):
            return np.stack([self.features(p) for p in params_list])
        return colour_space.lab(self.predict_many(params_list), self.white_y)

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

    def statistics_figure(self, params: LayeredParams) -> float:
        """How far ``params`` are from the target in the statistics a noise thickness is fitted by,
        whatever their thickness: the mean CIELAB distance between the target's and their pixel
        groups' mean colours and spreads, weighted as a noise fit weighs them.  A height and a noise
        thickness compared on the same rows."""
        rows = params.replace(thickness_mode="noise")  # the statistics' rows, whatever the thickness
        if self.matches_statistics(params):
            model = self.features(params)
        else:
            model = self._group_stats(colour_space.lab(self.predict(params), self.white_y)[:, None, :], np.ones(1))
        distance = np.linalg.norm(model - self.observed_features(rows), axis=-1)
        return float(np.average(distance, weights=self.feature_weights(rows)))

    def _levels_lab(self, params: LayeredParams) -> np.ndarray:
        """(N, levels, 3): the pixels' colours at each of the noise's thickness levels, the
        levels shaded together (a stack of thicknesses, one row per level)."""
        u = noise_levels(params.noise_detail)[:, None]
        rgb = np.empty((len(u),) + self.observed.shape)
        for batch in self._batches:
            rgb[:, batch["rows"]] = shade_points(batch, [params], plan_effects(params), noise_at=u)
        return np.swapaxes(colour_space.lab(rgb, self.white_y), 0, 1)

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

    def render(self, params: LayeredParams, view: int = 0) -> np.ndarray:
        """The whole image of view ``view`` for ``params`` (the fitted sphere only)."""
        v = self.views[view]
        geo = sphere_geometry(v.camera, v.centers)
        rows, cols = np.nonzero(geo.sphere == v.sphere)
        pts = {"view": v, "n0": geo.n0[rows, cols], "p_object": geo.p_object[rows, cols], "v": geo.view}
        out = np.zeros(geo.mask.shape + (3,))
        [batch] = light_batches([pts])
        out[rows, cols] = shade_points(batch, [params], plan_effects(params))
        return out

    def mask(self, view: int = 0) -> np.ndarray:
        v = self.views[view]
        return sphere_geometry(v.camera, v.centers).sphere == v.sphere

    def image_delta_e(self, params: LayeredParams) -> float | None:
        """Mean CIEDE2000 over every pixel of the fitted sphere in every view between the target's
        images and ``params`` (what comparing a render of the fit with the target gives; the fit
        itself reads a sample); None for a noise thickness, whose pattern numpy does not compute."""
        if self.matches_statistics(params):
            return None
        per_view = self.images_delta_e([self.render(params, k) for k in range(len(self.views))])
        return float(np.mean(np.concatenate(per_view)))

    def images_delta_e(self, images: Sequence[np.ndarray]) -> list[np.ndarray]:
        """Per view, the CIEDE2000 of every pixel of the fitted sphere between the target's image and
        ``images[k]`` (a render of the fit, or the closure form's :meth:`render`), on the view's
        white the fit reads it by: one scale for the sample the fit reads, its figure and a re-render's."""
        if len(images) != len(self.views):
            raise ValueError(f"{len(images)} images for {len(self.views)} views")
        return [self.view_delta_e(k, image) for k, image in enumerate(images)]

    def view_delta_e(self, view: int, image: np.ndarray) -> np.ndarray:
        """The CIEDE2000 of every pixel of the fitted sphere in view ``view`` between the target's
        image and ``image``, on the view's white (:data:`DARKEST_WHITE`)."""
        m, white = self.mask(view), self.view_whites[view]
        a, b = (colour_space.lab(np.maximum(np.asarray(x, dtype=float)[..., :3][m], 0.0), white)
                for x in (self.views[view].image, image))
        return colour_space.delta_e_2000(a, b)


def light_batches(points: Sequence[dict]) -> list[dict]:
    """The sampled pixels of the views as shading points, one set per light: every sun's views
    together (:func:`shading_points`), so that one run of the program shades them all (a run
    per view would repeat the Python work of its many small steps), and each environment's
    view on its own.  ``rows``: where a set's colours go among the target's; ``background``:
    the world straight behind its pixels (what a transparent base lets through)."""
    starts = np.cumsum([0] + [len(p["n0"]) for p in points])
    rows = [np.arange(a, b) for a, b in zip(starts[:-1], starts[1:])]
    suns = [k for k, p in enumerate(points) if p["view"].environment is None]
    batches = []
    if suns:
        batches.append(dict(shading_points([points[k] for k in suns]), rows=np.concatenate([rows[k] for k in suns]),
                            background=np.zeros(3)))
    return batches + [dict(shading_points([p]), rows=rows[k], environment=p["view"].environment,
                           background=p["view"].environment.radiance(-np.asarray(p["v"], dtype=float)))
                      for k, p in enumerate(points) if p["view"].environment is not None]


def shading_points(points: Sequence[dict]) -> dict:
    """Views' sampled pixels as one set of shading points: per point its normal, object-space
    position and view, and under a sun the sun's direction and strength."""
    def each(value, pts):
        return np.broadcast_to(np.asarray(value, dtype=float), pts["n0"].shape)

    out = {"n0": np.concatenate([p["n0"] for p in points]),
           "p_object": np.concatenate([p["p_object"] for p in points]),
           "v": np.concatenate([each(p["v"], p) for p in points])}
    if all(p["view"].sun is not None for p in points):
        out["l"] = np.concatenate([each(p["view"].sun.l, p) for p in points])
        out["strength"] = np.concatenate([np.full((len(p["n0"]), 1), float(p["view"].sun.strength)) for p in points])
    return out


def both_sides(points: dict) -> dict:
    """A set of shading points followed by the far side of the sphere behind each
    (:func:`.see_through.far_side`), seen along the same view under the same light: one run
    of the program shades the film where the camera ray enters and where it leaves."""
    p_far, n_far = far_side(points["n0"], points["v"])
    twice = {k: np.concatenate([points[k], points[k]]) for k in ("v", "l", "strength") if k in points}
    return {**points, **twice, "n0": np.concatenate([points["n0"], n_far]),
            "p_object": np.concatenate([points["p_object"], p_far])}


def by_stack(params_list: Sequence[LayeredParams]) -> list[tuple[EffectPlan, list[int]]]:
    """The parameter sets' indices grouped by what one run of the program needs them to share
    (:func:`.cycles_closures.stack_key`), in order of first appearance, with their plan."""
    groups: dict[tuple, list[int]] = {}
    for i, p in enumerate(params_list):
        groups.setdefault(stack_key(p), []).append(i)
    return [(key[0], indices) for key, indices in groups.items()]


def shade_points(points: dict, params_list: Sequence[LayeredParams], plan: EffectPlan,
                 noise_at=NOISE_MEDIAN) -> np.ndarray:
    """The colours of a set of :func:`light_batches` under its light for parameter sets of one
    stack (:func:`.cycles_closures.stacked_values`, their ``plan``): (N, 3) for one set,
    (K, N, 3) for K sets that differ.  A transparent base adds the far side of the sphere,
    shaded in the same run (:func:`both_sides`), and the background behind it."""
    values = stacked_values(params_list)
    if values["base_layer"] != "transparent":
        return shade_film(points, values, plan, noise_at)
    n = len(points["n0"])
    shaded, passed = shade_film(both_sides(points), values, plan, noise_at, transmittance=True)
    front, far = shaded[..., :n, :], shaded[..., n:, :]
    return front + see_through(passed[..., :n, :], passed[..., n:, :], far, points["background"])


def shade_film(points: dict, values: dict, plan: EffectPlan, noise_at=NOISE_MEDIAN, transmittance=False):
    """The film's colours at a set of shading points under its light (what it reflects, no
    see-through), in one run of the program for the stacked ``values``.  ``noise_at``: the
    noise's value where the thickness is a noise pattern, which numpy does not evaluate (its
    median; a column of levels makes a stack of its own, one row per level, for one set).
    With ``transmittance``, also what the film passes to a clear base per channel (same shape)."""
    pt = ShadingPoint(socket_values(values, ShadingPoint.SOCKETS), points["n0"], points["v"], points["p_object"])
    d = None
    if plan.thickness == "noise":
        u = np.broadcast_to(noise_at, np.broadcast_shapes(np.shape(noise_at), (len(points["n0"]),)))
        d = values["d_min"] + (values["d_max"] - values["d_min"]) * u
    try:
        _, _, _, _, _, d, _, n1 = program.surface_geometry(pt, plan, thickness=d)
    except NoiseUnavailable:
        raise ValueError("normal_mode 'correlated' with the noise pattern needs the render's lower normal") from None
    n0, v = points["n0"], points["v"]
    res = shade_closures(values, n0, n1, d, v, plan)
    if points.get("environment") is not None:
        colours = points["environment"].shade(res, n0, v, plan.lobe, ng=n0)
    else:
        every = np.broadcast_to(n0, points_shape(n0, n1, d, v, values) + (3,))
        colours = points["strength"] * evaluate_closures(res, every, v, points["l"], plan.lobe, every)
    if not transmittance:
        return colours
    passed = base_transmittance(values, res, np.broadcast_to(n0, np.shape(colours)), v, plan)
    return colours, np.broadcast_to(passed, colours.shape)


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
    film_only = True  # a mirror reflectance shows the film alone (:func:`.free.film_vary`)

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
            seen = by_angle.setdefault(angle, {})
            if slot in seen and seen[slot][0] != value:  # the same value twice is a repeat, two are a conflict
                what = f"channel {key}" if isinstance(slot, int) else f"wavelength {slot:g} nm"
                raise TargetError(f"row {i}: angle {angle:g}, {what} was given {seen[slot][0]:g} on row "
                                  f"{seen[slot][1]} and {value:g} here (one value per angle and "
                                  f"{'channel' if isinstance(slot, int) else 'wavelength'})")
            seen.setdefault(slot, (value, i))
        by_angle = {angle: {slot: v for slot, (v, _) in values.items()} for angle, values in by_angle.items()}
        angles, rgb = [], []
        for angle, values in sorted(by_angle.items()):
            rgb.append(_colour_of(angle, values))
            angles.append(angle)
        return cls(np.array(angles), np.array(rgb))

    def predict(self, params: LayeredParams) -> np.ndarray:
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
