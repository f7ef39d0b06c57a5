"""Accuracy sweep: the closure form against the exact model, image by image.

Each configuration is one unit sphere seen by an orthographic camera and lit by a
zero-angle sun (:func:`layered_brdf_addon.model.sphere.render_spheres`), rendered twice:
with :func:`~layered_brdf_reference.closures.closure_shading` (what the shaders return,
as Cycles evaluates it) and with the exact model (:func:`~.exact_spheres.exact_shading`,
in the configuration's accuracy mode: a spectral mode's wavelengths and weights).  The
whole sphere image is compared, so every view angle out to the silhouette is covered.

The sun is set by its *elevation* ``eps``: the angle above the tangent plane at the mirror
highlight (where the upper normal bisects sun and view), so the sun is ``180 - 2 eps``
degrees off the view; 90 puts the sun behind the camera, 5 lights a thin crescent at the
silhouette almost from behind.  Its *azimuth* turns it about the view axis (90: above).

The design is a seeded Latin hypercube (:func:`design`) over the sun, ``e0``, ``e1``,
``r1`` (with and without dispersion), the lower normal (parallel, tilted 0-30 degrees,
correlated with a "height" thickness) and the thickness ``d`` (0-1000 nm), plus a small
spectral design (:func:`spectral_design`) whose configurations are run in every accuracy
mode.  Metrics (:func:`image_metrics`):

* ``l1``: ``sum |closure - exact| / sum exact`` over the highlight (pixels where the
  exact image, summed over channels, exceeds 5% of its maximum), all channels;
* ``energy``: ``sum closure / sum exact`` over the sphere, per channel and in total;
* ``de_lit`` / ``de_highlight``: mean CIEDE2000 over the lit pixels (``<n0, l> > 0``) and
  over the highlight, both images scaled so the exact image's brightest pixel has
  luminance ``Y = 1`` (white), then linear Rec.709 -> XYZ -> Lab (D65 white);
* ``holes``: highlight pixels where the closure form gives less than 20% of the exact
  value (channel sums);
* ``l1_sphere``: the relative L1 over the whole sphere, and ``ghosts``: pixels outside the
  highlight where the closure form exceeds 5% of the exact maximum and the exact value is
  below 20% of the closure's (light the closure form puts where the model has none, which
  the highlight's L1 does not see).

Used by ``benchmarks/accuracy_sweep.py`` (fine) and ``tests/test_accuracy_sweep.py`` (coarse).
"""
from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from typing import Callable, Iterable, Sequence

import numpy as np

from layered_brdf_addon.model.geometry import dot
from layered_brdf_addon.model.params import ACCURACY_MODES, LayeredParams
from layered_brdf_addon.model.presets import PRESETS
from layered_brdf_addon.model.stack_presets import STACK_PRESETS
from layered_brdf_addon.model.sphere import OrthoCamera, Sun, render_spheres

from . import spectral
from .closures import closure_shading
from .compare import highlight_mask, relative_l1
from .exact_spheres import exact_shading

HIGHLIGHT_FRACTION = 0.05  # highlight: exact above 5% of its maximum
HOLE_FRACTION = 0.20  # hole: closure below 20% of exact in the highlight
BAD_L1 = 0.20  # a configuration "over 20%"

# Ranges of the design.
ELEVATION_DEG = (5.0, 90.0)
EXPONENT = (10.0, 1000.0)  # e0, e1: log-uniform
INDEX = (1.05, 2.5)
DISPERSION_STEP = (0.02, 0.15)  # r1_g - r1_r; r1_b - r1_g is twice it
TILT_DEG = (0.0, 30.0)
THICKNESS_NM = (0.0, 1000.0)
CORRELATED_SPAN_NM = (50.0, 500.0)  # d_max - d_min of a correlated configuration
BUMP_STRENGTH = (1.0e-4, 2.0e-3)  # log-uniform; 2e-3 with a 500 nm span bends n1 by up to ~25 degrees
NORMAL_MODES = ("parallel", "tilted", "tilted", "correlated")  # tilted drawn twice as often

# A "standard sun" for the presets: 40 degrees off the view, above it (the render tests' SUN_40).
STANDARD_SUN_DEG = 40.0


@dataclass(frozen=True)
class SweepConfig:
    """One configuration: a sphere of :meth:`params` under :meth:`sun`."""

    elevation: float  # degrees above the tangent plane at the mirror highlight
    sun_azimuth: float  # degrees about the view axis (90: the sun is above the view)
    e0: float
    e1: float
    r1: tuple[float, float, float]
    normal_mode: str  # parallel, tilted or correlated
    tilt: float  # degrees (tilted)
    d_min: float
    d_max: float
    bump_strength: float = 0.0  # correlated
    accuracy: str = "rgb"
    name: str = ""  # a preset's name, or the design's index

    @property
    def dispersive(self) -> bool:
        return not (self.r1[0] == self.r1[1] == self.r1[2])

    def params(self) -> LayeredParams:
        return LayeredParams.from_dict(dict(
            r1_r=self.r1[0], r1_g=self.r1[1], r1_b=self.r1[2], r0=1.0, e0=self.e0, e1=self.e1, ks=1.0, kd=0.0,
            d_min=self.d_min, d_max=self.d_max, thickness_mode="height", normal_mode=self.normal_mode,
            tilt=self.tilt if self.normal_mode == "tilted" else 0.0,
            bump_strength=self.bump_strength if self.normal_mode == "correlated" else 0.0,
            accuracy=self.accuracy, lobe="beckmann"))

    def sun(self) -> Sun:
        return sun_at(self.elevation, self.sun_azimuth)

    def as_dict(self) -> dict:
        out = asdict(self)
        out["r1"] = list(self.r1)
        out["dispersive"] = self.dispersive
        return out


def sun_at(elevation: float, azimuth: float = 90.0, view=(0.0, -1.0, 0.0)) -> Sun:
    """Unit-strength sun ``180 - 2 elevation`` degrees off ``view``, turned by ``azimuth`` about it
    (0: towards +x, 90: towards +z for the default camera)."""
    g = math.radians(180.0 - 2.0 * elevation)
    a = math.radians(azimuth)
    v = np.asarray(view, dtype=float)
    v = v / np.linalg.norm(v)
    x = np.cross([0.0, 0.0, 1.0], v) if abs(v[2]) < 0.999 else np.array([1.0, 0.0, 0.0])
    x = x / np.linalg.norm(x)
    y = np.cross(v, x)
    s = math.cos(g) * v + math.sin(g) * (math.cos(a) * x + math.sin(a) * y)
    return Sun(direction=tuple(float(c) for c in s), strength=1.0)


# --------------------------------------------------------------------------
# The designs.
def _lhs(n: int, dims: int, rng: np.random.Generator) -> np.ndarray:
    """Latin hypercube in [0, 1)^dims: each column has one point in each of n strata."""
    u = (np.arange(n)[:, None] + rng.random((n, dims))) / n
    for k in range(dims):
        u[:, k] = u[rng.permutation(n), k]
    return u


def _log_uniform(u, lo, hi):
    return float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))


def _uniform(u, lo, hi):
    return float(lo + u * (hi - lo))


def _index_triple(u_index: float, u_step: float, dispersive: bool) -> tuple[float, float, float]:
    g = _uniform(u_index, *INDEX)
    if not dispersive:
        return (round(g, 4),) * 3
    s = _uniform(u_step, *DISPERSION_STEP)
    r, b = g - s, g + 2.0 * s
    shift = max(INDEX[0] - r, 0.0) - max(b - INDEX[1], 0.0)  # keep the triple inside the range
    return tuple(round(x + shift, 4) for x in (r, g, b))


def design(n: int, seed: int = 2003, accuracy: str = "rgb") -> list[SweepConfig]:
    """``n`` configurations of a seeded Latin hypercube over every dimension of the sweep.

    Categorical dimensions (dispersion, normal mode) take strata of their column, so each
    category gets its share; dimensions that a category does not use (tilt of a parallel
    configuration) are drawn but ignored.
    """
    rng = np.random.default_rng(seed)
    u = _lhs(n, 11, rng)
    out = []
    for k, row in enumerate(u):
        elev, azim, le0, le1, ui, ustep, udisp, umode, utilt, ud, uspan = row
        mode = NORMAL_MODES[min(int(umode * len(NORMAL_MODES)), len(NORMAL_MODES) - 1)]
        r1 = _index_triple(ui, ustep, udisp >= 0.5)
        d = _uniform(ud, *THICKNESS_NM)
        d_min = d_max = d
        bump = 0.0
        if mode == "correlated":
            span = _uniform(uspan, *CORRELATED_SPAN_NM)
            d_min = max(THICKNESS_NM[0], d - 0.5 * span)
            d_max = min(THICKNESS_NM[1], d_min + span)
            d_min = d_max - span
            bump = _log_uniform(utilt, *BUMP_STRENGTH)
        out.append(SweepConfig(
            elevation=round(_uniform(elev, *ELEVATION_DEG), 2), sun_azimuth=round(_uniform(azim, 0.0, 360.0), 1),
            e0=round(_log_uniform(le0, *EXPONENT), 1), e1=round(_log_uniform(le1, *EXPONENT), 1), r1=r1,
            normal_mode=mode, tilt=round(_uniform(utilt, *TILT_DEG), 2) if mode == "tilted" else 0.0,
            d_min=round(d_min, 1), d_max=round(d_max, 1), bump_strength=bump, accuracy=accuracy, name=f"#{k}"))
    return out


def spectral_design(n: int, seed: int = 2004, modes: Sequence[str] = ACCURACY_MODES) -> list[SweepConfig]:
    """A small design run in every accuracy mode (same configurations, so the modes compare)."""
    base = design(n, seed)
    return [SweepConfig(**{**asdict(c), "accuracy": m, "name": f"s{c.name}"}) for c in base for m in modes]


# --------------------------------------------------------------------------
# Rendering.
def camera(resolution: int) -> OrthoCamera:
    return OrthoCamera(width=resolution, height=resolution)


# --------------------------------------------------------------------------
# Metrics.
def _luminance(rgb) -> np.ndarray:
    return spectral.rgb_to_xyz(rgb)[..., 1]


def image_metrics(closure: np.ndarray, exact: np.ndarray, geo, l) -> dict:
    """Metrics of one closure-form image against the exact image (module docstring)."""
    sphere = geo.mask
    lit = sphere & (dot(geo.n0, np.asarray(l, dtype=float)) > 0.0)
    s_exact = exact.sum(axis=-1)
    peak = float(s_exact[sphere].max()) if np.any(sphere) else 0.0
    if not peak > 0.0:
        raise ValueError("the exact image is black: nothing to compare")
    hl = highlight_mask(exact, sphere, HIGHLIGHT_FRACTION)
    s_clo = closure.sum(axis=-1)
    holes = hl & (s_clo < HOLE_FRACTION * s_exact)
    ghosts = sphere & ~hl & (s_clo > HIGHLIGHT_FRACTION * peak) & (s_exact < HOLE_FRACTION * s_clo)
    e_tot = exact[sphere].sum(axis=0)
    c_tot = closure[sphere].sum(axis=0)
    floor = 1e-12 * max(float(e_tot.sum()), 1e-300)
    energy_rgb = c_tot / np.maximum(e_tot, floor)
    y_peak = float(_luminance(exact[sphere]).max())
    scale = 1.0 / y_peak if y_peak > 0.0 else 1.0 / peak
    de = spectral.delta_e_2000(closure * scale, exact * scale)
    return dict(
        l1=relative_l1(closure, exact, hl),
        l1_sphere=relative_l1(closure, exact, sphere),
        energy=float(c_tot.sum() / e_tot.sum()),
        energy_rgb=[float(x) for x in energy_rgb],
        de_lit=float(de[lit].mean()) if np.any(lit) else 0.0,
        de_highlight=float(de[hl].mean()),
        holes=int(holes.sum()),
        ghosts=int(ghosts.sum()),
        highlight_pixels=int(hl.sum()),
        lit_pixels=int(lit.sum()),
    )


Shading = Callable[..., np.ndarray]


def evaluate(config: SweepConfig, resolution: int, closure: Shading = closure_shading,
             params: LayeredParams | None = None) -> dict:
    """Render the configuration both ways at ``resolution`` pixels square; its metrics.

    ``closure``: the closure shading to measure (a deliberately wrong one tests the metrics).
    ``params``: overrides ``config.params()`` (the presets keep their own).
    """
    p = params if params is not None else config.params()
    cam, sun = camera(resolution), config.sun()
    t0 = time.perf_counter()
    exact, geo = render_spheres(p, cam, sun, shading=exact_shading)
    approx, _ = render_spheres(p, cam, sun, shading=closure)
    out = image_metrics(approx, exact, geo, sun.l)
    out["seconds"] = time.perf_counter() - t0
    return out


def run(configs: Iterable[SweepConfig], resolution: int, closure: Shading = closure_shading,
        progress: Callable[[int, SweepConfig, dict], None] | None = None) -> list[dict]:
    """Rows ``{"config": ..., "metrics": ...}`` of every configuration."""
    rows = []
    for k, c in enumerate(configs):
        m = evaluate(c, resolution, closure)
        rows.append(dict(config=c.as_dict(), metrics=m))
        if progress is not None:
            progress(k, c, m)
    return rows


# --------------------------------------------------------------------------
# Presets under a standard sun.
def preset_config(name: str, sun_deg: float = STANDARD_SUN_DEG) -> tuple[SweepConfig, LayeredParams]:
    """A preset as a sweep configuration: its own parameters, a noise thickness replaced by the
    "height" pattern over the same range (numpy does not evaluate Blender's noise)."""
    p = LayeredParams.from_dict(PRESETS[name])
    if p.thickness_mode == "noise":
        p = p.replace(thickness_mode="height")
    # the render tests' sun: sun_deg off the view, above it, i.e. elevation 90 - sun_deg / 2
    c = SweepConfig(elevation=90.0 - 0.5 * sun_deg, sun_azimuth=90.0, e0=p.e0, e1=p.e1, r1=p.r1,
                    normal_mode=p.normal_mode, tilt=p.tilt, d_min=p.d_min, d_max=p.d_max,
                    bump_strength=p.bump_strength, accuracy=p.accuracy, name=name)
    return c, p


def preset_rows(resolution: int, closure: Shading = closure_shading) -> list[dict]:
    """Per preset: the metrics as the preset renders (its ``ks``, ``kd``) and specular only
    (``ks = 1, kd = 0``), under the standard sun."""
    rows = []
    for name in PRESETS:
        if name in STACK_PRESETS:  # a stack's one lobe has no decomposition to measure (docs/stacks.md)
            continue
        c, p = preset_config(name)
        as_is = evaluate(c, resolution, closure, params=p)
        spec = evaluate(c, resolution, closure, params=p.replace(ks=1.0, kd=0.0))
        rows.append(dict(name=name, config=c.as_dict(), ks=p.ks, kd=p.kd, metrics=as_is, specular_only=spec))
    return rows


# --------------------------------------------------------------------------
# Summary.
@dataclass
class Summary:
    configurations: int
    l1_p50: float
    l1_p95: float
    l1_max: float
    over_20: int
    holes: int
    configurations_with_holes: int
    ghosts: int
    l1_sphere_p95: float
    energy_p5: float
    energy_p50: float
    energy_p95: float
    de_lit_p50: float
    de_lit_p95: float
    worst: list = field(default_factory=list)


def summarise(rows: Sequence[dict], worst: int = 10) -> Summary:
    l1 = np.array([r["metrics"]["l1"] for r in rows])
    en = np.array([r["metrics"]["energy"] for r in rows])
    de = np.array([r["metrics"]["de_lit"] for r in rows])
    holes = np.array([r["metrics"]["holes"] for r in rows])
    ghosts = np.array([r["metrics"]["ghosts"] for r in rows])
    l1s = np.array([r["metrics"]["l1_sphere"] for r in rows])
    order = np.argsort(-l1, kind="stable")[:worst]
    return Summary(
        configurations=len(rows), l1_p50=float(np.percentile(l1, 50)), l1_p95=float(np.percentile(l1, 95)),
        l1_max=float(l1.max()), over_20=int((l1 > BAD_L1).sum()), holes=int(holes.sum()),
        configurations_with_holes=int((holes > 0).sum()), ghosts=int(ghosts.sum()),
        l1_sphere_p95=float(np.percentile(l1s, 95)), energy_p5=float(np.percentile(en, 5)),
        energy_p50=float(np.percentile(en, 50)), energy_p95=float(np.percentile(en, 95)),
        de_lit_p50=float(np.percentile(de, 50)), de_lit_p95=float(np.percentile(de, 95)),
        worst=[rows[k] for k in order])


def groups(rows: Sequence[dict], key: Callable[[dict], str]) -> dict[str, Summary]:
    """Summaries of the rows grouped by ``key(config)``, in first-seen order."""
    out: dict[str, list] = {}
    for r in rows:
        out.setdefault(key(r["config"]), []).append(r)
    return {k: summarise(v, worst=0) for k, v in out.items()}


def elevation_band(c: dict) -> str:
    e = c["elevation"]
    return "5-15" if e < 15 else "15-30" if e < 30 else "30-60" if e < 60 else "60-90"


def exponent_band(c: dict) -> str:
    e = max(c["e0"], c["e1"])
    return "max(e0, e1) < 100" if e < 100 else "100-300" if e < 300 else ">= 300"


def describe(c: dict) -> str:
    """A configuration in one line of parameters."""
    r1 = "/".join(f"{x:g}" for x in c["r1"])
    nm = c["normal_mode"]
    if nm == "tilted":
        nm = f"tilted {c['tilt']:g}°"
    elif nm == "correlated":
        nm = f"correlated (bump {c['bump_strength']:.2g}/nm)"
    d = f"{c['d_min']:g}" if c["d_min"] == c["d_max"] else f"{c['d_min']:g}-{c['d_max']:g}"
    return (f"elev {c['elevation']:g}°, az {c['sun_azimuth']:g}°, e0 {c['e0']:g}, e1 {c['e1']:g}, r1 {r1}, "
            f"{nm}, d {d} nm, {c['accuracy']}")
