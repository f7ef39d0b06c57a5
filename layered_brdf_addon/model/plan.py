"""Effect planning: which parts of the shader a material's parameters make visible.

A pure function of the parameters.  The node-group builder and the OSL variants
include only the active parts; ``EffectPlan.full()`` is the always-full shader.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

from .params import LayeredParams

# Optical thickness r1 d beyond which, integrated over the visible band, the interference
# term changes the colour by less than 1 CIEDE2000 (docs/spectral.md; measured by
# spectral.interference_cutoff_optical_nm, which a test compares with this value).
INTERFERENCE_CUTOFF_OPTICAL_NM = 4146.0


@dataclass(frozen=True)
class EffectPlan:
    specular: bool = True  # ks > 0
    diffuse: bool = True  # kd > 0
    thickness: str = "noise"  # "noise", "height" or "constant" (d_min == d_max: no pattern to evaluate)
    normals: str = "parallel"  # "parallel", "tilted" or "correlated"
    dispersion: bool = True  # one transmitted and one interference lobe per channel (else shared)
    lobe: str = "beckmann"
    spectral: int = 0  # 0: the paper's RGB; N: N wavelengths
    interference: bool = True  # False: a spectral layer so thick that interference averages out

    @classmethod
    def full(cls, lobe: str = "beckmann", thickness: str = "noise", normals: str = "correlated",
             spectral: int = 0) -> "EffectPlan":
        return cls(True, True, thickness, normals, True, lobe, spectral)

    @property
    def key(self) -> str:
        """Short identifier, used in node-group names and OSL variant names."""
        parts = [
            "S" if self.specular else "s", "D" if self.diffuse else "d", self.thickness[0].upper(),
            self.normals[0].upper(), "X" if self.dispersion else "x", self.lobe[0].upper(),
        ]
        if self.spectral:
            parts.append(f"W{self.spectral}")
        if not self.interference:
            parts.append("i")
        return "".join(parts)

    def to_dict(self) -> dict:
        return asdict(self)

    def describe(self) -> list[str]:
        out = []
        out.append("specular lobes" if self.specular else "no specular part (ks = 0)")
        out.append("diffuse part" if self.diffuse else "no diffuse part (kd = 0)")
        out.append({"noise": "thickness from 4D noise", "height": "thickness from object height",
                    "constant": "constant thickness (no pattern evaluated)"}[self.thickness])
        out.append({"parallel": "parallel boundaries", "tilted": "constant tilt of the lower normal",
                    "correlated": "lower normal from the thickness gradient (3 extra pattern evaluations)"}[self.normals])
        if self.spectral:
            out.append(f"{self.spectral} wavelengths, summed into RGB lobes")
        if not self.interference:
            out.append("no interference: the layer is thick enough for it to average out over the band")
        if self.specular:
            out.append("per-channel transmitted and interference lobes (dispersion)" if self.dispersion
                       else "one shared transmitted and one shared interference lobe (equal indices)")
        return out


def plan_effects(p: LayeredParams) -> EffectPlan:
    """Decide the active effects from the parameters (see docs/effect-planning.md)."""
    varying = p.d_min != p.d_max
    thickness = p.thickness_mode if varying else "constant"
    normals = p.normal_mode
    if normals == "tilted" and p.tilt == 0.0:
        normals = "parallel"
    if normals == "correlated" and (not varying or p.bump_strength == 0.0):
        normals = "parallel"  # a constant thickness has no gradient: n1 = n0
    dispersion = not (p.r1_r == p.r1_g == p.r1_b)
    spectral = 0 if p.accuracy == "rgb" else int(p.accuracy[len("spectral"):])
    return EffectPlan(specular=p.ks > 0.0, diffuse=p.kd > 0.0, thickness=thickness, normals=normals,
                      dispersion=dispersion, lobe=p.lobe, spectral=spectral,
                      interference=not (spectral and interference_averages_out(p)))


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
    return p.d_min * (r1 * r1 - 1.0) ** 0.5 > INTERFERENCE_CUTOFF_OPTICAL_NM
