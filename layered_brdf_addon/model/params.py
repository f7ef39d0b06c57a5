"""The single definition of the material's parameters.

Every parameter is a field of :class:`LayeredParams`.  Its metadata (label, unit,
hard range, soft range, description, enum options, whether it is a shader input)
is the one place from which the Blender properties and panels, the node group's sockets
(names, subtypes, tooltips), the OSL shader's parameters, the command-line options, the
fit's free parameters and bounds, and :meth:`LayeredParams.validate` are derived.

Plain Python: it imports neither numpy nor bpy (only the standard library and the
measured media of :mod:`.media`).
"""
from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import Any, Iterator, Mapping

from .errors import ParameterError, checked_number
from .media import MEDIA, lower_medium_values, media_names
from .dispersion import WAVELENGTHS_NM, abbe_indices  # the channels' wavelengths (SPEC)
from .socket_units import ROUGHNESS, UNITS, socket_range, socket_units_of, to_socket
from .stack import FilmStack, stack_or_none



@dataclass(frozen=True)
class ParamSpec:
    """Metadata of one parameter (derived from a dataclass field)."""

    name: str
    label: str
    kind: str  # "float", "enum", "bool" or "stack" (a :class:`~.stack.FilmStack`, or None)
    default: Any
    description: str
    unit: str = ""
    min: float = -math.inf
    max: float = math.inf
    soft_min: float | None = None
    soft_max: float | None = None
    options: tuple[str, ...] = ()
    socket: bool = True  # an input socket of the shader (animatable)
    group: str = "Layer"
    socket_label: str = ""  # the node group's socket (a colour socket holds several parameters)
    subtype: str = "NONE"  # the socket's Blender subtype: "WAVELENGTH" (nm), "FACTOR" (0-1 slider)
    component: int | None = None  # the parameter's channel of a colour socket
    added: str = ""  # what brought the parameter in after the first version (older files lack its socket)
    socket_units: str = ""  # what the socket holds instead of the value (socket_units.py): "roughness"
    socket_description: str = ""  # the socket's tooltip when it holds something else than the parameter
    legacy_labels: tuple[str, ...] = ()  # the node group's names of the socket in older versions (parameter units)
    used_with: tuple[str, str] | tuple[()] = ()  # (enum parameter, option) under which the value is used

    @property
    def allowed(self) -> str:
        if self.kind == "enum":
            return "one of " + ", ".join(repr(o) for o in self.options)
        if self.kind == "bool":
            return "true or false"
        if self.kind == "stack":
            return "a film stack ({'kind': 'periodic' or 'list', 'films': [...], 'periods': ..., 'disorder': ...}, " \
                "docs/stacks.md) or none"
        unit = f" {self.unit}" if self.unit else ""
        return f"a number in [{_fmt(self.min)}, {_fmt(self.max)}]{unit}"

    def check(self, value: Any) -> Any:
        """Return ``value`` converted to the parameter's kind, or raise ParameterError."""
        if self.kind == "enum":
            if value not in self.options:
                raise ParameterError(self.name, value, self.allowed)
            return value
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise ParameterError(self.name, value, self.allowed)
            return value
        if self.kind == "stack":
            return stack_or_none(value, self.name)
        return checked_number(self.name, value, self.min, self.max, f" {self.unit}" if self.unit else "")


def _fmt(x: float) -> str:
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:g}"


def _p(default, label, description, *, unit="", range=(-math.inf, math.inf), soft=None,
       options=(), socket=True, group="Layer", socket_label="", subtype="NONE", component=None, added="",
       socket_units="", socket_description="", legacy_labels=(), used_with=(), kind=None):
    kind = kind or ("enum" if options else ("bool" if isinstance(default, bool) else "float"))
    assert socket_units in UNITS and (subtype == "ANGLE") <= (unit == "deg")
    meta = dict(label=label, description=description, unit=unit, min=range[0], max=range[1],
                soft_min=None if soft is None else soft[0], soft_max=None if soft is None else soft[1],
                options=tuple(options), socket=socket and kind == "float", group=group, kind=kind,
                socket_label=socket_label, subtype=subtype, component=component, added=added,
                socket_units=socket_units, socket_description=socket_description, legacy_labels=tuple(legacy_labels),
                used_with=tuple(used_with))
    return field(default=default, metadata={"layered": meta})


THICKNESS_MODES = ("noise", "height")
NORMAL_MODES = ("parallel", "tilted", "correlated")
LOBES = ("beckmann", "phong")
BASE_LAYERS = ("none", "transparent", "metal")
OPTICS_MODES = ("paper", "physical")
# "custom", then the named media of the measured table (model/data/media.json).
LOWER_MEDIA = ("custom",) + media_names()
# What added the lower medium's sockets (files saved before it lack all six).
PHYSICAL_OPTICS = "physical optics"
# The parameters a named lower medium fills: its n and k at R, G, B.
LOWER_MEDIUM_KEYS = ("r2_r", "r2_g", "r2_b", "k2_r", "k2_g", "k2_b")
LAYER_INDEX_MODES = ("channels", "ior")
EFFECTS_MODES = ("planned", "all")
EVALUATION_MODES = ("tables", "arithmetic")
IOR_AND_DISPERSION = "ior and dispersion"  # what added the IOR and Dispersion sockets
PER_CHANNEL = "Per-channel IOR"  # the group (node panel, sub-panel) of the paper's three indices
ACCURACY_MODES = ("rgb", "analytic", "spectral4", "spectral8", "spectral16", "spectral32")

# The node group's colour socket of the base colour (base_r, base_g, base_b), and its tooltip.
BASE_COLOR_SOCKET = "Base Color"
BASE_COLOR_DESCRIPTION = ("Colour of the diffuse part under the layer, and of a metal base: plug a texture here "
                          "(each channel is kept within 0-1)")

# The shader's Thickness input (nm, a link's; not a parameter: it varies over the surface), and its tooltip.
THICKNESS_SOCKET = "Thickness"
THICKNESS_DESCRIPTION = ("Layer thickness in nm from your own nodes (a painted map, a pattern): linked, it "
                         "replaces the thickness pattern, and where the lower boundary follows the thickness "
                         "its gradient bends it; not linked, the pattern (Noise or Height) between Thickness Min "
                         "and Max gives it")

# What an artist reads for each option of the enum parameters (menus, CLI help).
OPTION_LABELS = {
    "noise": "Noise", "height": "Height (thickens downwards)",
    "parallel": "Parallel", "tilted": "Tilted", "correlated": "Follows thickness",
    "beckmann": "Beckmann", "phong": "Phong (OSL only)",
    "none": "None (your Base Shader)", "transparent": "Transparent (soap film)",
    "metal": "Metal (base colour)",
    "paper": "Paper (lower boundary a mirror)", "physical": "Physical (thin-film optics)",
    "channels": "Per channel (the paper's three indices)", "ior": "IOR and Dispersion",
    "planned": "Planned (fastest)", "all": "All (edit without the add-on)",
    "tables": "Baked tables (fastest)", "arithmetic": "Arithmetic (animatable)",
    "rgb": "RGB (the paper's 3 wavelengths)", "analytic": "Analytic spectral",
    "spectral4": "Spectral, 4 wavelengths", "spectral8": "Spectral, 8 wavelengths",
    "spectral16": "Spectral, 16 wavelengths", "spectral32": "Spectral, 32 wavelengths",
}


OPTION_LABELS.update({"custom": "Custom (n and k below)", **{name: m.label for name, m in MEDIA.items()}})


def option_label(option: str) -> str:
    """The label of an enum option for people (:data:`OPTION_LABELS`)."""
    return OPTION_LABELS.get(option, option.replace("_", " ").capitalize())


@dataclass
class LayeredParams:
    """Parameters of the layered RGB BRDF (Granier & Heidrich 2003).

    Thickness ``d`` varies over the surface: ``d = d_min + (d_max - d_min) * n(p)``
    with ``n`` the noise factor (``thickness_mode="noise"``) or ``0.5 - 0.5 z``
    (``"height"``: a film that thickens downwards, like a draining soap film),
    ``p`` the object-space position.
    """

    # --- the layer -------------------------------------------------------
    layer_index: str = _p("channels", "Layer index",
                          "How the layer's refractive index is given: 'ior' (an IOR and a Dispersion, as Blender's "
                          "glTF materials and KHR_materials_dispersion define them) or 'channels' (the paper's three "
                          "indices at 645, 525 and 445 nm)", options=LAYER_INDEX_MODES)
    layer_ior: float = _p(1.45, "IOR", "Refractive index of the layer at 587.6 nm (the d line, as glass catalogues "
                          "give it)", range=(1.0, 5.0), soft=(1.0, 2.5), socket_label="IOR",
                          used_with=("layer_index", "ior"),
                          added=IOR_AND_DISPERSION)
    layer_dispersion: float = _p(0.0, "Dispersion", "How much the layer's index grows towards blue: 20 / V_d, V_d the "
                                 "Abbe number (glTF's KHR_materials_dispersion): 0 none, water 0.36, crown glass 0.31, "
                                 "flint glass 0.55, titanium dioxide 2", range=(0.0, 10.0), soft=(0.0, 2.0),
                                 socket_label="Dispersion", used_with=("layer_index", "ior"), added=IOR_AND_DISPERSION)
    r1_r: float = _p(1.4, "Index R", "Refractive index of the layer at 645 nm (red), with Layer index 'channels'",
                     range=(0.1, 5.0), soft=(1.0, 2.5), socket_label="IOR Red",
                     legacy_labels=("Layer IOR (Red)",), group=PER_CHANNEL,
                     used_with=("layer_index", "channels"))
    r1_g: float = _p(1.45, "Index G", "Refractive index of the layer at 525 nm (green), with Layer index 'channels'",
                     range=(0.1, 5.0), soft=(1.0, 2.5), socket_label="IOR Green",
                     legacy_labels=("Layer IOR (Green)",), group=PER_CHANNEL,
                     used_with=("layer_index", "channels"))
    r1_b: float = _p(1.6, "Index B", "Refractive index of the layer at 445 nm (blue), with Layer index 'channels'",
                     range=(0.1, 5.0), soft=(1.0, 2.5), socket_label="IOR Blue",
                     legacy_labels=("Layer IOR (Blue)",), group=PER_CHANNEL,
                     used_with=("layer_index", "channels"))
    r0: float = _p(1.0, "Outside index", "Refractive index of the medium above the layer (air is 1)",
                   range=(0.1, 5.0), soft=(1.0, 1.5), socket_label="Outside IOR")
    d_min: float = _p(66.0, "Thickness min", "Thinnest layer thickness", unit="nm",
                      range=(0.0, 1.0e6), soft=(0.0, 2000.0), socket_label="Thickness Min", subtype="WAVELENGTH")
    d_max: float = _p(76.0, "Thickness max", "Thickest layer thickness", unit="nm",
                      range=(0.0, 1.0e6), soft=(0.0, 2000.0), socket_label="Thickness Max", subtype="WAVELENGTH")
    thickness_mode: str = _p("noise", "Thickness pattern",
                             "How thickness varies: 'noise' (Perlin fBm) or 'height' (thicker downwards)",
                             options=THICKNESS_MODES)
    noise_scale: float = _p(4.0, "Noise scale", "Scale of the thickness noise in object space",
                            range=(1.0e-4, 1.0e4), soft=(0.1, 50.0), group="Noise", socket_label="Noise Scale")
    noise_detail: float = _p(2.0, "Noise detail", "Octaves of the thickness noise",
                             range=(0.0, 15.0), soft=(0.0, 8.0), group="Noise", socket_label="Noise Detail")
    noise_roughness: float = _p(0.5, "Noise roughness", "Amplitude ratio of successive octaves",
                                range=(0.0, 1.0), group="Noise", socket_label="Noise Roughness", subtype="FACTOR")
    noise_phase: float = _p(0.0, "Noise phase", "Fourth noise coordinate (W): animate it to make the pattern flow",
                            range=(-1.0e5, 1.0e5), soft=(-10.0, 10.0), group="Noise", socket_label="Noise Phase")
    # --- the lower boundary ---------------------------------------------
    normal_mode: str = _p("parallel", "Lower normal",
                          "Lower boundary normal: 'parallel', constant 'tilted', or 'correlated' with the thickness gradient",
                          options=NORMAL_MODES)
    tilt: float = _p(0.0, "Tilt", "Angle between the lower and upper boundary normals", unit="deg",
                     range=(0.0, 180.0), soft=(0.0, 30.0), group="Lower boundary", socket_label="Tilt",
                     subtype="ANGLE", legacy_labels=("Tilt (°)",))
    tilt_azimuth: float = _p(0.0, "Tilt azimuth", "Rotation of the tilt axis about the normal", unit="deg",
                             range=(-360.0, 360.0), group="Lower boundary", socket_label="Tilt Azimuth",
                             subtype="ANGLE", legacy_labels=("Tilt Azimuth (°)",))
    bump_strength: float = _p(5.0e-4, "Bump strength",
                              "How far the lower normal bends per unit of thickness gradient (object units)",
                              unit="1/nm", range=(0.0, 1.0e3), soft=(0.0, 0.01), group="Lower boundary",
                              socket_label="Bump Strength", legacy_labels=("Bump Strength (per nm)",))
    # --- what lies under the layer (physical optics) ---------------------
    optics: str = _p("paper", "Optics",
                     "How the layer's boundaries reflect: 'paper' (Granier & Heidrich: the lower boundary a perfect "
                     "mirror, no reflection phase) or 'physical' (thin-film optics: exact Fresnel reflectance at both "
                     "boundaries, the lower medium's complex index, the phase of each reflection, and only what the "
                     "layer neither reflects nor absorbs reaching the base)", options=OPTICS_MODES)
    lower_medium: str = _p("custom", "Lower medium",
                           "Named medium under the layer whose measured index fills the lower medium's n and k "
                           "(model/data/media.json); 'custom' keeps the values given", options=LOWER_MEDIA,
                           group="Lower boundary")
    r2_r: float = _p(1.5, "Lower index R", "Refractive index n of the medium under the layer at 645 nm (red); "
                     "physical optics only", range=(0.01, 10.0), soft=(1.0, 4.0), group="Lower boundary",
                     socket_label="Lower IOR Red", legacy_labels=("Lower IOR (Red)",), added=PHYSICAL_OPTICS)
    r2_g: float = _p(1.5, "Lower index G", "Refractive index n of the medium under the layer at 525 nm (green); "
                     "physical optics only", range=(0.01, 10.0), soft=(1.0, 4.0), group="Lower boundary",
                     socket_label="Lower IOR Green", legacy_labels=("Lower IOR (Green)",), added=PHYSICAL_OPTICS)
    r2_b: float = _p(1.5, "Lower index B", "Refractive index n of the medium under the layer at 445 nm (blue); "
                     "physical optics only", range=(0.01, 10.0), soft=(1.0, 4.0), group="Lower boundary",
                     socket_label="Lower IOR Blue", legacy_labels=("Lower IOR (Blue)",), added=PHYSICAL_OPTICS)
    k2_r: float = _p(0.0, "Lower extinction R", "Extinction coefficient k of the medium under the layer at 645 nm "
                     "(0 for a dielectric, 1-10 for a metal); physical optics only", range=(0.0, 20.0),
                     soft=(0.0, 10.0), group="Lower boundary", socket_label="Lower Extinction Red",
                     legacy_labels=("Lower Extinction (Red)",),
                     added=PHYSICAL_OPTICS)
    k2_g: float = _p(0.0, "Lower extinction G", "Extinction coefficient k of the medium under the layer at 525 nm "
                     "(0 for a dielectric, 1-10 for a metal); physical optics only", range=(0.0, 20.0),
                     soft=(0.0, 10.0), group="Lower boundary", socket_label="Lower Extinction Green",
                     legacy_labels=("Lower Extinction (Green)",),
                     added=PHYSICAL_OPTICS)
    k2_b: float = _p(0.0, "Lower extinction B", "Extinction coefficient k of the medium under the layer at 445 nm "
                     "(0 for a dielectric, 1-10 for a metal); physical optics only", range=(0.0, 20.0),
                     soft=(0.0, 10.0), group="Lower boundary", socket_label="Lower Extinction Blue",
                     legacy_labels=("Lower Extinction (Blue)",),
                     added=PHYSICAL_OPTICS)
    # --- specular and diffuse --------------------------------------------
    e0: float = _p(90.0, "Upper exponent", "Phong exponent of the upper boundary (higher is sharper)",
                   range=(0.0, 1.0e5), soft=(1.0, 2000.0), group="Specular", socket_label="Upper Roughness",
                   subtype="FACTOR", socket_units=ROUGHNESS, legacy_labels=("Upper Exponent",),
                   socket_description="Roughness of the layer's top surface, as the Principled BSDF's: 0 a mirror "
                   "(the sharpest the model allows, Roughness 0.047), 1 fully rough. It sets the Phong exponent "
                   "e0 = (Roughness^-4 - 1) / 2")
    e1: float = _p(170.0, "Lower exponent", "Phong exponent of the lower boundary, inside the layer",
                   range=(0.0, 1.0e5), soft=(1.0, 2000.0), group="Specular", socket_label="Lower Roughness",
                   subtype="FACTOR", socket_units=ROUGHNESS, legacy_labels=("Lower Exponent",),
                   socket_description="Roughness of the layer's lower boundary, as the Principled BSDF's, seen inside "
                   "the layer (from outside its lobe is sharper by the layer's index squared). It sets the Phong "
                   "exponent e1 = (Roughness^-4 - 1) / 2")
    ks: float = _p(1.0, "Specular weight", "Weight of the specular (Phong-like) part",
                   range=(0.0, 1.0), group="Specular", socket_label="Specular Weight", subtype="FACTOR")
    kd: float = _p(0.7, "Diffuse weight", "Weight of the diffuse part", range=(0.0, 1.0), group="Diffuse",
                   socket_label="Diffuse Weight", subtype="FACTOR")
    base_r: float = _p(0.8, "Base R", "Diffuse base colour, red", range=(0.0, 1.0), group="Diffuse",
                       socket_label=BASE_COLOR_SOCKET, component=0)
    base_g: float = _p(0.8, "Base G", "Diffuse base colour, green", range=(0.0, 1.0), group="Diffuse",
                       socket_label=BASE_COLOR_SOCKET, component=1)
    base_b: float = _p(0.8, "Base B", "Diffuse base colour, blue", range=(0.0, 1.0), group="Diffuse",
                       socket_label=BASE_COLOR_SOCKET, component=2)
    base_layer: str = _p("none", "Base shader",
                         "What lies under the layer besides the diffuse part: 'none' (leave the Base Shader "
                         "input to the artist), 'transparent' (a soap film) or 'metal' (a metal of the base "
                         "colour, as rough as the upper boundary)", options=BASE_LAYERS, group="Diffuse")
    accuracy: str = _p("analytic", "Accuracy",
                       "Colour model: 'rgb' (the paper's three wavelengths), 'analytic' (three channels, each "
                       "with the interference integrated over its band in closed form: thick layers fade to their "
                       "average colour instead of aliasing) or 'spectralN' (N wavelengths, r1 from a Cauchy fit, "
                       "integrated against the CIE 1931 observer under D65)",
                       options=ACCURACY_MODES, group="Accuracy")
    effects: str = _p("planned", "Effects",
                      "Which effects the shader contains: 'planned' (only those the values call for, the fastest "
                      "shader; the add-on rebuilds it when an edit calls for another) or 'all' (every effect the "
                      "modes allow stays on the node, so that any socket can be edited without the add-on, at a "
                      "cost per sample)", options=EFFECTS_MODES, group="Accuracy")
    evaluation: str = _p("tables", "Evaluation",
                         "How the shader finds its closures: 'tables' (read from small images baked for the "
                         "material's values, over the view's angle and the thickness: the cost of Blender's own "
                         "BSDFs; used where every value is a constant, the boundaries are parallel and the "
                         "thickness is the pattern's, and rebaked by the add-on when a value changes) or "
                         "'arithmetic' (computed at every shading point: any socket may be keyframed, driven or "
                         "linked). The OSL shader holds its tables in its own text", options=EVALUATION_MODES,
                         group="Accuracy")
    lobe: str = _p("beckmann", "Lobe",
                   "Closure used for the specular lobes: 'beckmann' (both backends) or 'phong' (OSL only)",
                   options=LOBES, group="Accuracy")
    # --- a stack of films (structural colour) ----------------------------
    stack: FilmStack | None = _p(None, "Film stack",
                                 "The layer as a stack of films (a Bragg mirror, a beetle's cuticle, nacre, a "
                                 "coating) over the lower medium, with thin-film optics: a period of films repeated, "
                                 "or a list of films, each a named medium or an IOR, with its thickness in nm; the "
                                 "layer's thickness (Thickness Min / Max, its pattern or its input) is the stack's "
                                 "total and scales every film alike. None: one film of the layer's index",
                                 kind="stack", group="Stack")

    # ------------------------------------------------------------------
    @classmethod
    def specs(cls) -> tuple[ParamSpec, ...]:
        return PARAM_SPECS

    @classmethod
    def spec(cls, name: str) -> ParamSpec:
        try:
            return _SPEC_BY_NAME[name]
        except KeyError:
            raise ParameterError(name, None, "a known parameter name: " + ", ".join(_SPEC_BY_NAME)) from None

    def validate(self) -> "LayeredParams":
        """Check every value; raise :class:`ParameterError` naming the first bad one."""
        for s in PARAM_SPECS:
            object.__setattr__(self, s.name, s.check(getattr(self, s.name)))
        if self.layer_index == "ior":  # the three indices follow from the IOR and the Dispersion
            for name, n in zip(("r1_r", "r1_g", "r1_b"), abbe_indices(self.layer_ior, self.layer_dispersion)):
                object.__setattr__(self, name, min(max(n, _SPEC_BY_NAME[name].min), _SPEC_BY_NAME[name].max))
        if self.d_min > self.d_max:
            raise ParameterError("d_min", self.d_min, f"at most d_max = {self.d_max:g} nm")
        if self.stack is not None:
            self._check_stack()
        return self

    def _check_stack(self) -> None:
        """What a film stack needs of the other settings: thin-film optics, Beckmann lobes (its tables are
        read by both backends) and a lower boundary parallel to the top (the films' boundaries are) or tilted
        (lamellae in a crystal of the layer's index, along the lower normal)."""
        needs = (("optics", ("physical",), "thin-film optics: a stack's films have their own indices"),
                 ("lobe", ("beckmann",), "the lobe its baked tables are read with"),
                 ("normal_mode", ("parallel", "tilted"), "the films lie parallel to the top, or to a tilted "
                  "lower boundary as lamellae in a crystal"))
        for name, wanted, why in needs:
            if getattr(self, name) not in wanted:
                raise ParameterError(name, getattr(self, name),
                                     f"{' or '.join(map(repr, wanted))} with a film stack ({why})")
        if self.stack.domains > 1 and self.normal_mode != "tilted":
            raise ParameterError("stack.domains", self.stack.domains, "1 unless Lower normal is 'tilted' (domains "
                                 "lie one under the other in the crystal around tilted lamellae)")

    def check_used(self, given) -> None:
        """ParameterError naming the first of ``given`` (values a user gave, by name) that this material does not
        use: one used only under another option of an enum parameter (the three indices with Layer index 'ior')."""
        for name, value in given.items():
            spec = self.spec(name)
            if spec.used_with and getattr(self, spec.used_with[0]) != spec.used_with[1]:
                enum, option = spec.used_with
                raise ParameterError(name, value,
                                     f"a value this material uses: {name} is used only with {enum} '{option}', "
                                     f"and its {enum} is '{getattr(self, enum)}' (give {enum} '{option}' too)")

    # convenience views ---------------------------------------------------
    @property
    def r1(self) -> tuple[float, float, float]:
        return (self.r1_r, self.r1_g, self.r1_b)

    @property
    def r2(self) -> tuple[float, float, float]:
        return (self.r2_r, self.r2_g, self.r2_b)

    @property
    def k2(self) -> tuple[float, float, float]:
        return (self.k2_r, self.k2_g, self.k2_b)

    @property
    def base_color(self) -> tuple[float, float, float]:
        return (self.base_r, self.base_g, self.base_b)

    def to_dict(self) -> dict[str, Any]:
        """Every value by name, as JSON holds it (a stack as :meth:`.stack.FilmStack.to_dict`)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["stack"] = None if self.stack is None else self.stack.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, base: "LayeredParams | None" = None) -> "LayeredParams":
        """Build from a mapping (e.g. JSON); unknown keys are an error; the result is validated."""
        unknown = set(data) - set(_SPEC_BY_NAME)
        if unknown:
            name = sorted(unknown)[0]
            raise ParameterError(name, data[name], "a known parameter name: " + ", ".join(_SPEC_BY_NAME))
        values = base.to_dict() if base is not None else {}
        values.update(data)
        medium = data.get("lower_medium")
        if medium in LOWER_MEDIA and medium != "custom":
            # A named medium fills the lower medium's n and k, unless they are given too.
            values.update({k: v for k, v in lower_medium_values(medium).items() if k not in data})
        return cls(**values).validate()

    def replace(self, **changes: Any) -> "LayeredParams":
        return LayeredParams.from_dict(changes, base=self)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, sort_keys=True)


def _spec_of(f: dataclasses.Field) -> ParamSpec:
    m = dict(f.metadata["layered"])
    return ParamSpec(name=f.name, default=f.default, **m)


PARAM_SPECS: tuple[ParamSpec, ...] = tuple(_spec_of(f) for f in dataclasses.fields(LayeredParams))
_SPEC_BY_NAME = {s.name: s for s in PARAM_SPECS}


def iter_sockets() -> Iterator[ParamSpec]:
    """The parameters that are shader inputs, in socket order."""
    return (s for s in PARAM_SPECS if s.socket)


def socket_name(spec: ParamSpec) -> str:
    """Name of the OSL shader's parameter of a parameter (an identifier): the parameter's name, or
    the socket's label as an identifier when the socket holds something else ("upper_roughness")."""
    return spec.socket_label.lower().replace(" ", "_") if spec.socket_units else spec.name


socket_units = socket_units_of  # what a backend's socket of a parameter holds (socket_units.py)


def socket_values(values: Mapping[str, Any], backend: str = "osl") -> dict:
    """``values`` (parameter values by name, numbers or numpy arrays) as ``backend``'s sockets hold
    them; entries that are not shader inputs pass through."""
    out = dict(values)
    for spec in PARAM_SPECS:
        if spec.socket and spec.name in out:
            out[spec.name] = to_socket(socket_units(spec, backend), out[spec.name])
    return out


def socket_default(spec: ParamSpec, backend: str) -> float:
    """The default value of ``backend``'s socket of ``spec``."""
    return to_socket(socket_units(spec, backend), spec.default)


def socket_limits(spec: ParamSpec, backend: str) -> tuple[float, float]:
    """The range of ``backend``'s socket of ``spec`` (the shader clamps its value to it)."""
    return socket_range(socket_units(spec, backend), spec.min, spec.max)


def socket_tooltip(spec: ParamSpec) -> str:
    """The tooltip of a parameter's socket: what it holds and its allowed range."""
    if spec.socket_units == ROUGHNESS:
        return f"{spec.socket_description}. A number in [0, 1]"
    unit = f" ({spec.unit})" if spec.unit else ""
    return f"{spec.description}{unit}. {spec.allowed[0].upper()}{spec.allowed[1:]}"


def group_socket_name(spec: ParamSpec) -> str:
    """Name of the node group's input socket of a parameter, for people ("Thickness Min")."""
    return spec.socket_label or spec.name


@dataclass(frozen=True)
class SocketSpec:
    """One input socket of the shader: a float parameter, or a colour holding several."""

    name: str  # the node group's socket name
    specs: tuple[ParamSpec, ...]
    group: str

    @property
    def is_color(self) -> bool:
        return self.specs[0].component is not None


def iter_group_sockets() -> Iterator[SocketSpec]:
    """The shader's parameter sockets in order, a colour's channels together."""
    seen: dict[str, list[ParamSpec]] = {}
    for spec in iter_sockets():
        seen.setdefault(group_socket_name(spec), []).append(spec)
    return (SocketSpec(name, tuple(specs), specs[0].group) for name, specs in seen.items())
