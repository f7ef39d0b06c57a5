"""The effect plan: which parts of the shader a material's program contains.

The rules that choose a plan live in :mod:`.policy`.  The node group and the OSL
shader are built for one plan; ``EffectPlan.full()`` is the always-full shader.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class EffectPlan:
    specular: bool = True  # ks > 0
    diffuse: bool = True  # kd > 0
    thickness: str = "noise"  # "noise", "height", "input" (the Thickness socket's link) or "constant" (d_min == d_max)
    normals: str = "parallel"  # "parallel", "tilted" or "correlated"
    dispersion: bool = True  # one transmitted lobe per channel (else one shared)
    lobe: str = "beckmann"
    spectral: int = 0  # 0: the paper's RGB; N: N wavelengths
    interference: bool = True  # False: a spectral or analytic layer so thick that interference averages out
    analytic: bool = False  # RGB channels with the interference integrated over each channel's band
    footprint: bool = True  # analytic: also over the pixel's footprint, where the backend has derivatives (OSL)
    optics: str = "paper"  # "paper": the lower boundary a perfect mirror; "physical": thin-film optics
    multibeam: bool = False  # physical: the harmonics of the beams that bounce inside the layer (program.harmonic_count)
    passes: bool = True  # physical: light may reach the Base Shader (False: the lower medium absorbs it, a metal, or
    # the diffuse part takes all of it, kd = 1)
    index: str = "channels"  # the layer's index: "channels" (three sockets) or "ior" (IOR and Dispersion)
    tables: bool = False  # the closures read from the material's baked tables (.shading.tables), not computed
    stack: bool = False  # the layer is a stack of films (.stack): one lobe of the stack's reflectance, from tables

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
        if self.analytic:
            parts.append("A" if self.footprint else "Af")
        if not self.interference:
            parts.append("i")
        if self.optics == "physical":
            parts.append(("T2" if self.multibeam else "T") + ("" if self.passes else "o"))
        if self.index == "ior":
            parts.append("Ab")
        if self.tables:
            parts.append("Tb")
        if self.stack:
            parts.append("M")
        return "".join(parts)

    @property
    def title(self) -> str:
        """What the plan simulates, for people: "Physical film, analytic colour, noise thickness"."""
        optics = "Film stack" if self.stack else "Physical film" if self.optics == "physical" else "Paper film"
        colour = (f"{self.spectral} wavelengths" if self.spectral else
                  "analytic colour" if self.analytic else "RGB colour")
        thickness = {"noise": "noise thickness", "height": "height thickness", "input": "thickness from a link",
                     "constant": "even thickness"}[self.thickness]
        normals = {"parallel": "", "tilted": ", tilted boundary", "correlated": ", boundary follows thickness"}
        parts = [f"{optics}, {colour}, {thickness}{normals[self.normals]}"]
        if not self.specular:
            parts.append("diffuse only")
        elif not self.diffuse:
            parts.append("specular only")
        if self.lobe == "phong":
            parts.append("Phong lobes")
        if self.tables:
            parts.append("baked tables")
        return ", ".join(parts)

    def to_dict(self) -> dict:
        return asdict(self)

    def describe(self) -> list[str]:
        out = []
        out.append("specular lobes" if self.specular else "no specular part (ks = 0)")
        out.append("diffuse part" if self.diffuse else "no diffuse part (kd = 0)")
        out.append({"noise": "thickness from 4D noise", "height": "thickness from object height",
                    "input": "thickness from the Thickness input's link",
                    "constant": "constant thickness (no pattern evaluated)"}[self.thickness])
        out.append({"parallel": "parallel boundaries", "tilted": "constant tilt of the lower normal",
                    "correlated": "lower normal from the thickness gradient (3 extra pattern evaluations)"}[self.normals])
        if self.spectral:
            out.append(f"{self.spectral} wavelengths, summed into RGB lobes")
        if self.analytic:
            out.append("interference integrated over each colour channel's band (analytic spectral)"
                       + (", and over the pixel's footprint in OSL" if self.footprint else ""))
        if not self.interference:
            out.append("no interference: the layer is thick enough for it to average out over the band")
        if self.stack and self.normals == "tilted":
            out.append("a stack of films as tilted lamellae in a crystal: the crystal's gloss, the lamellae's "
                       "schiller through it" + (", what they pass to the base" if self.passes else ""))
        elif self.stack:
            out.append("a stack of films: its reflectance (every film, both polarisations) in one lobe"
                       + (", what it passes to the base" if self.passes else ""))
        elif self.optics == "physical":
            out.append("thin-film optics: exact Fresnel at both boundaries, reflection phases"
                       + (", and the beams that bounce inside the layer (more harmonics)" if self.multibeam else "")
                       + ("" if self.passes else "; nothing reaches the Base Shader (an absorbing lower medium, or "
                                                   "a diffuse part that takes all)"))
        if self.index == "ior":
            out.append("the layer's indices from its IOR and Dispersion (Abbe number)")
        if self.specular and not self.stack:
            out.append("per-channel transmitted lobes (dispersion)" if self.dispersion
                       else "one shared transmitted lobe (equal indices)")
        if self.tables and self.stack and self.normals == "tilted":
            out.append("the lamellae's optics (cosine to them x thickness) and geometry (view angle x azimuth from "
                       "them) read from tables baked for the material's values")
        elif self.tables:
            axes = "view angle x thickness" + (" x the lower normal's azimuth" if self.normals == "tilted" else "")
            out.append(f"closures read from tables baked for the material's values ({axes})")
        return out
