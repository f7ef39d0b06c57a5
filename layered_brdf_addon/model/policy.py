"""Policy: which backend runs which lobe, and which effects a material's shader contains.

Every layer (panel, operators, command line, batch, gallery, ``apply_layered_material``)
asks this module; none repeats its rules.  bpy-free.

Planning is a pure function of the parameters and of the set of parameters that are
*animated* (keyframed, driven, or fed by a linked socket): an animated parameter may take
any value of its range on some frame, so every effect it could switch on stays in the
shader.  The planner never drops an effect that another frame needs.
"""
from __future__ import annotations

import cmath
import math

from dataclasses import replace
from typing import Iterable

from .params import LayeredParams, ParameterError, iter_sockets
from .plan import EffectPlan
from .shading.base_shader import CLEAR_K
from .shading.tables import tabulable, unread_by_tables
from .table_bake import fits
from .table_check import checked_bake

#: The shader backends: a node group of stock nodes, or an OSL shader (Cycles CPU / OptiX).
BACKENDS = ("nodes", "osl")


class OSLSceneWarning(UserWarning):
    """An OSL material applied where the scene cannot run it (Cycles renders it black)."""


#: The specular closures each backend can build.
LOBES_BY_BACKEND = {"nodes": ("beckmann",), "osl": ("beckmann", "phong")}

# Optical thickness r1 d beyond which, integrated over the visible band, the interference
# term changes the colour by less than 1 CIEDE2000 (docs/spectral.md; measured by
# spectral.interference_cutoff_optical_nm, which a test compares with this value).
INTERFERENCE_CUTOFF_OPTICAL_NM = 4146.0

# Physical optics: indices that differ by at most this across the channels place the channels' transmitted lobes
# as one: water (0.008), an oil (0.011), chitin (0.011) or glass (0.011) move a lobe by less than
# 0.1 degree, far less than its width; each channel keeps its own index in the interference.
DISPERSION_SPREAD = 0.015

# Physical optics: the second harmonic (light bouncing twice inside the layer) is simulated where
# its amplitude relative to the first, |r01 r12|, exceeds this at normal incidence or at the rim
# (MULTIBEAM_RIM_DEG): a film of high index on a metal (TiO2 on titanium 0.24 at normal incidence),
# and any film seen near grazing, where both boundaries reflect strongly (soap 0.02 at normal
# incidence, 0.45 at 80 degrees; docs/physical-optics.md).
MULTIBEAM_CONTRAST = 0.04
MULTIBEAM_RIM_DEG = 80.0

#: In the animated names: the shader's Thickness input is linked (its link replaces the pattern).
THICKNESS_LINKED = "Thickness"

#: The parameters whose value decides an effect, by the effect they decide.
DECIDING_PARAMETERS = {
    "specular": ("ks",),
    "diffuse": ("kd",),
    "thickness": ("d_min", "d_max"),
    "tilt": ("tilt",),
    "bump": ("bump_strength",),
    "dispersion": ("r1_r", "r1_g", "r1_b", "layer_ior", "layer_dispersion"),
    "interference": ("d_min", "r1_r", "r1_g", "r1_b", "layer_ior", "layer_dispersion", "r0"),
    "multibeam": ("r1_r", "r1_g", "r1_b", "layer_ior", "layer_dispersion", "r0", "r2_r", "r2_g", "r2_b", "k2_r",
                  "k2_g", "k2_b"),
    "passes": ("k2_r", "k2_g", "k2_b", "kd"),
}


def check_backend(backend: str, lobe: str | None = None) -> None:
    """Raise :class:`ParameterError` unless ``backend`` exists and can build ``lobe``."""
    if backend not in BACKENDS:
        raise ParameterError("backend", backend, "one of " + ", ".join(repr(b) for b in BACKENDS))
    if lobe is not None and lobe not in LOBES_BY_BACKEND[backend]:
        others = [b for b in BACKENDS if lobe in LOBES_BY_BACKEND[b]]
        hint = f" (choose the {' or '.join(others)} backend for {lobe!r})" if others else ""
        raise ParameterError("lobe", lobe, f"one of {', '.join(map(repr, LOBES_BY_BACKEND[backend]))} "
                                           f"with the {backend} backend{hint}")


def supports(backend: str, lobe: str) -> bool:
    return lobe in LOBES_BY_BACKEND.get(backend, ())


def plan_effects(p: LayeredParams, animated: Iterable[str] = (), backend: str = "nodes") -> EffectPlan:
    """The effects the shader must contain for ``p`` on every frame, and whether the shader (the node
    group or the OSL shader) reads its closures from baked tables: where ``p.evaluation`` is "tables",
    nothing the tables hold is animated (:func:`~.shading.tables.unread_by_tables` may be), the effects
    are planned and the plan's closures can be tabulated (:func:`~.shading.tables.tabulable`, and a tilted
    boundary's slices fit :data:`~.table_bake.MAX_TABLE_BYTES`).

    ``animated``: names of parameters that may change between frames (keyframes, drivers,
    linked sockets), and :data:`THICKNESS_LINKED` where the Thickness input is linked.  See docs/effect-planning.md.
    """
    animated = frozenset(animated)
    # Values the tables never hold may move (a flowing noise pattern); a tilted boundary's tables hold its tilt.
    tables = backend in BACKENDS and p.evaluation == "tables" and p.effects == "planned" and \
        not (animated - unread_by_tables(p.normal_mode))
    if p.effects == "all":  # every effect stays, as if every socket could take any value
        animated |= {spec.name for spec in iter_sockets()}

    def moving(effect: str) -> bool:
        return any(n in animated for n in DECIDING_PARAMETERS[effect])

    linked = THICKNESS_LINKED in animated
    varying = p.d_min != p.d_max or moving("thickness") or linked
    thickness = "input" if linked else p.thickness_mode if varying else "constant"
    normals = p.normal_mode
    if normals == "tilted" and p.tilt == 0.0 and not moving("tilt"):
        normals = "parallel"
    if normals == "correlated" and (not varying or (p.bump_strength == 0.0 and not moving("bump"))):
        normals = "parallel"  # a constant thickness has no gradient: n1 = n0
    # The paper's optics keep their rule: any difference between the indices is dispersion.
    spread = DISPERSION_SPREAD if p.optics == "physical" else 0.0
    dispersion = max(p.r1) - min(p.r1) > spread or moving("dispersion")
    spectral = spectral_count(p.accuracy)
    analytic = p.accuracy == "analytic"
    if p.stack is not None:  # its films' own indices: no layer index, interference or harmonics to decide
        return _stack_plan(p, moving, thickness, spectral, analytic)
    banded = bool(spectral) or analytic  # colour integrated over the band, where interference can average out
    # A linked thickness is not Thickness Min's: interference stays.
    interference = not (banded and not moving("interference") and not linked and interference_averages_out(p))
    physical = p.optics == "physical"
    multibeam = physical and interference and (moving("multibeam") or beam_contrast(p) > MULTIBEAM_CONTRAST)
    passes = not physical or moving("passes") or _passes(p)
    plan = EffectPlan(specular=p.ks > 0.0 or moving("specular"), diffuse=p.kd > 0.0 or moving("diffuse"),
                      thickness=thickness, normals=normals, dispersion=dispersion, lobe=p.lobe,
                      spectral=spectral, interference=interference, analytic=analytic, optics=p.optics,
                      multibeam=multibeam, passes=passes, index=p.layer_index)
    if not (tables and tabulable(plan, backend)):
        return plan
    if plan.normals == "tilted" and not fits(p, plan):
        return plan
    return replace(plan, tables=True)


def _passes(p: LayeredParams) -> bool:
    """Whether light reaches the Base Shader with thin-film optics: a clear lower medium (a metal keeps what
    enters it) under a diffuse part that does not take all of it (``kd`` below 1)."""
    return min(p.k2) < CLEAR_K and p.kd < 1.0


def _stack_plan(p: LayeredParams, moving, thickness: str, spectral: int, analytic: bool) -> EffectPlan:
    """A film stack's plan: one lobe of the stack's reflectance, always read from tables baked for the
    material's values (the stack has no per-point shader: its films are many), a linked thickness read
    within Thickness Min and Max."""
    passes = moving("passes") or _passes(p)
    return EffectPlan(specular=p.ks > 0.0 or moving("specular"), diffuse=p.kd > 0.0 or moving("diffuse"),
                      thickness=thickness, normals="tilted" if p.normal_mode == "tilted" else "parallel",
                      dispersion=False, lobe=p.lobe, spectral=spectral,
                      interference=True, analytic=analytic, optics="physical", multibeam=False, passes=passes,
                      index=p.layer_index, tables=True, stack=True)


def render_plan(p: LayeredParams, animated: Iterable[str] = (), backend: str = "nodes") -> EffectPlan:
    """The plan a material is built with: :func:`plan_effects`, computed per point where its baked tables would
    not hold the program (:mod:`.table_check`: total internal reflection in the layer, fringes finer than the
    tables resolve).  Baking checks itself once per set of values (kept for the bake that follows)."""
    plan = plan_effects(p, animated, backend)
    if plan.tables and not plan.stack and not checked_bake(p, plan)[2].holds:
        return replace(plan, tables=False)
    return plan


def tables_fallback(p: LayeredParams, animated: Iterable[str] = (), backend: str = "nodes") -> str:
    """Why a material that asks for baked tables computes per point because they would not hold the program
    (empty where it uses them, or its plan has none for another reason)."""
    plan = plan_effects(p, animated, backend)
    return checked_bake(p, plan)[2].why() if plan.tables and not plan.stack else ""


def beam_contrast(p: LayeredParams) -> float:
    """The largest ``|r01 r12|`` over the channels, at normal incidence and at the rim
    (:data:`MULTIBEAM_RIM_DEG`, s-polarised light, which both boundaries reflect most): how much
    of the light that crossed the layer bounces inside it again, the ratio of each harmonic to
    the last."""
    out = 0.0
    sin0 = math.sin(math.radians(MULTIBEAM_RIM_DEG))
    c0 = math.cos(math.radians(MULTIBEAM_RIM_DEG))
    for r1, n2, k2 in zip(p.r1, p.r2, p.k2):
        r01 = abs((p.r0 - r1) / (p.r0 + r1))
        r12 = abs(complex(r1 - n2, -k2) / complex(r1 + n2, k2))
        out = max(out, r01 * r12)
        # At the rim: cosines in the layer and below from Snell's law (complex below a metal, or
        # under total internal reflection).
        c1 = cmath.sqrt(1.0 - (p.r0 * sin0 / r1) ** 2)
        n2c = complex(n2, k2)
        c2 = cmath.sqrt(1.0 - (p.r0 * sin0 / n2c) ** 2)
        rs01 = (p.r0 * c0 - r1 * c1) / (p.r0 * c0 + r1 * c1)
        rs12 = (r1 * c1 - n2c * c2) / (r1 * c1 + n2c * c2) if abs(r1 * c1 + n2c * c2) > 1e-12 else 1.0
        out = max(out, abs(rs01 * rs12))
    return out


def spectral_count(accuracy: str) -> int:
    """Number of wavelengths of an accuracy mode (0: the paper's RGB and the analytic mode,
    which evaluate three channels)."""
    return int(accuracy[len("spectral"):]) if accuracy.startswith("spectral") else 0


def interference_averages_out(p: LayeredParams) -> bool:
    """Whether, integrated over the visible band, the interference term of every point is
    below 1 CIEDE2000.  The phase spread grows with the optical path: ``2 r1 d`` for the
    diffuse part, ``r1 d (s_i + s_o) >= 2 d sqrt(r1^2 - r0^2) / r0`` for the specular one
    (``s`` the refracted cosines, smallest at grazing), so the thinnest layer and smallest
    index decide.  In RGB (three wavelengths) nothing averages: the paper's model keeps it.
    """
    r1 = min(p.r1) / p.r0
    if r1 <= 1.0:
        return False
    return min(p.d_min, p.d_max) * (r1 * r1 - 1.0) ** 0.5 > INTERFERENCE_CUTOFF_OPTICAL_NM
