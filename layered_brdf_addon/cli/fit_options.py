"""The options of ``layered-brdf fit``, declared once (:class:`~.option_spec.OptionSpec`, joined to the
command line's table by :mod:`.option_table`): its target, the start and the free parameters, its output.
The start's defaults by the target's kind and the ranges of the Principled BSDF target's renders live here.

Nothing here imports bpy.
"""
from __future__ import annotations

from typing import Any

from ..fit.environment import DEFAULT_HDRIS
from ..fit.free import CONTINUOUS, check_vary
from ..model.params import PARAM_SPECS, ParameterError
from ..model.presets import PRESETS
from .option_spec import OptionSpec, as_given, ints, preset_name, switch
from .option_values import check_plain, shown
from .options import param_metavar

# The start's modes an option may override (the options of ``render`` for them).
MODE_OPTIONS = ("thickness_mode", "normal_mode", "optics", "lower_medium", "base_layer", "accuracy")
STARTS_RANGE, STARTS_DEFAULT = (1, 10), 3
PRINCIPLED_SIZE, PRINCIPLED_SIZES = 96, (8, 4096)  # pixels of each render
PRINCIPLED_SAMPLES, PRINCIPLED_SAMPLING = 1, (1, 65536)  # samples per pixel
PRINCIPLED_HDRIS = DEFAULT_HDRIS

TARGET_ALLOWED = ("a reference-sphere render of 'layered-brdf render': its sidecar STEM.json, or STEM, "
                  "STEM.exr or STEM.png with the sidecar and the EXR beside it")
SOURCE_ALLOWED = ("exactly one target: TARGET (a render's sidecar), --reflectance FILE.csv or "
                  "--principled FILE.blend")
REFLECTANCE_ALLOWED = ("a readable CSV file (at most 1 MiB) whose header names the columns angle (degrees from "
                       "the normal, in [0, 90)), wavelength (nm) or channel (r, g, b), and reflectance (a "
                       "fraction in [0, 1]), one row per angle and wavelength or channel")
TILE_ALLOWED = "a tile of a gallery render, by its name or index; no value for a reference render"
MATERIAL_ALLOWED = "the name of a material of the .blend holding a Principled BSDF (with --principled)"
HDRIS_ALLOWED = "names of Blender's bundled HDRIs (forest, courtyard, ...), or 'none' (the suns only)"
OUTPUT_ALLOWED = "a file path stem in a writable folder (STEM.json and STEM.png are written)"
TARGET, START = "target (exactly one)", "start and free parameters"  # fit's own sections of --help
OUTPUT = "output"


def mode_help(spec) -> str:
    """Help of a mode option: what it overrides, the parameter's description."""
    text = f"the start's {spec.label.lower()}, instead of its own: {spec.description}"
    if spec.name == "thickness_mode":
        text += "; a noise is fitted through the colours' statistics, a height pixel by pixel"
    return text


def _hdri_names(name: str, value: Any) -> tuple[str, ...]:
    """HDRI names (checked against Blender's when it is loaded), or ``('none',)`` alone."""
    names = [value] if isinstance(value, str) else value
    if not isinstance(names, (list, tuple)) or not names or not all(isinstance(n, str) and n.strip() and "/" not in n
                                                                       for n in names):
        raise ParameterError(name, shown(value), HDRIS_ALLOWED)
    if "none" in names and len(names) > 1:
        raise ParameterError(name, shown(value), HDRIS_ALLOWED + " ('none' alone)")
    return tuple(check_plain(name, n) for n in names)


LAYERS = ("film", "stack")
LAYER_ALLOWED = "one of " + ", ".join(LAYERS)


def _layer(name: str, value: Any) -> str:
    if value not in LAYERS:
        raise ParameterError(name, shown(value), LAYER_ALLOWED)
    return value


def _mode(spec):
    def read(name: str, value: Any) -> str:
        if value not in spec.options:
            raise ParameterError(name, shown(value), spec.allowed)
        return value
    return read


FIT_OPTIONS = (
    OptionSpec("target", "a reference-sphere render, fitted through its EXR's Combined pass", TARGET_ALLOWED,
               as_given, ("fit",), metavar="TARGET", nargs="?", positional=True, group=TARGET, job=False),
    OptionSpec("tile", "the sphere of a gallery render to fit", TILE_ALLOWED, as_given,
               ("fit",), metavar="NAME|INDEX", group=TARGET, job=False, goes_with="target"),
    OptionSpec("reflectance", "a film's mirror reflectance; e.g. a header 'angle_deg,wavelength_nm,reflectance'",
               REFLECTANCE_ALLOWED, as_given, ("fit",), metavar="FILE.csv", group=TARGET, job=False),
    OptionSpec("principled", "a .blend holding the Principled BSDF material --material, rendered by Cycles on the "
               "reference sphere under three suns", "the path of a .blend file", as_given, ("fit",),
               metavar="FILE.blend", group=TARGET, job=False),
    OptionSpec("material", "the material of --principled", MATERIAL_ALLOWED, as_given, ("fit",), metavar="NAME",
               group=TARGET, job=False, goes_with="principled"),
    OptionSpec("size", "--principled: pixels of each render", f"an integer in [{PRINCIPLED_SIZES[0]}, "
               f"{PRINCIPLED_SIZES[1]}]", ints(*PRINCIPLED_SIZES), ("fit",), defaults={"fit": str(PRINCIPLED_SIZE)},
               metavar="PX", group=TARGET, job=False, goes_with="principled"),
    OptionSpec("samples", "--principled: samples per pixel", f"an integer in [{PRINCIPLED_SAMPLING[0]}, "
               f"{PRINCIPLED_SAMPLING[1]}]", ints(*PRINCIPLED_SAMPLING), ("fit",),
               defaults={"fit": f"{PRINCIPLED_SAMPLES}, exact under a sun"}, group=TARGET, job=False,
               goes_with="principled"),
    OptionSpec("hdri", "--principled: Blender's bundled HDRIs the material is also rendered under and fitted to",
               HDRIS_ALLOWED, _hdri_names, ("fit",), defaults={"fit": " ".join(PRINCIPLED_HDRIS)}, metavar="NAME",
               nargs="+", group=TARGET, job=False, goes_with="principled"),
    OptionSpec("start", "the preset the fit starts from, whose modes (optics, lower medium, normals, thickness "
               "pattern) it keeps: they decide what the fit can reach", "one of " + ", ".join(sorted(PRESETS)),
               preset_name, ("fit",),
               defaults={"fit": "none: the fit chooses the structure among every preset's (docs/fitting.md)"},
               metavar="PRESET", group=START, job=False),
    OptionSpec("params", "start from the parameter values of a file (a render's sidecar or an earlier fit's "
               "OUT.json work too), over --start when given", "the path of a .json or .toml file of parameter "
               "values", as_given, ("fit",), metavar="FILE", group=START, job=False),
    OptionSpec("vary", "the parameters the fit may change", "names of continuous parameters: "
               + ", ".join(CONTINUOUS), lambda name, value: check_vary([value] if isinstance(value, str) else value),
               ("fit",), defaults={"fit": "the continuous parameters the start's modes use; for --reflectance the "
                                   "layer's indices and thickness"}, metavar="NAME", nargs="+", group=START,
               job=False),
    OptionSpec("starts", "thickness orders tried besides the start", f"an integer in [{STARTS_RANGE[0]}, "
               f"{STARTS_RANGE[1]}]", ints(*STARTS_RANGE), ("fit",), defaults={"fit": str(STARTS_DEFAULT)},
               group=START, job=False),
    OptionSpec("layer", "a fit with no start: whether its layer is one film or a stack of films (the structural "
               "colours' structures, their period fitted)", LAYER_ALLOWED, _layer, ("fit",),
               defaults={"fit": "either for --reflectance, one film otherwise"}, metavar="film|stack", group=START,
               job=False),
    *(OptionSpec(spec.name, mode_help(spec), spec.allowed, _mode(spec), ("fit",), metavar=param_metavar(spec),
                 choices=spec.options, group=START, job=False) for spec in PARAM_SPECS if spec.name in MODE_OPTIONS),
    OptionSpec("output", "output stem: writes OUT.json and OUT.png", OUTPUT_ALLOWED, as_given, ("fit",),
               defaults={"fit": "out/NAME-fit, NAME the target's"}, metavar="OUT", group=OUTPUT, job=False),
    OptionSpec("verify", "render the fit as the target was rendered (Cycles) and compare every pixel of the sphere; "
               "OUT.json and the summary give both figures (a reference-sphere render's target or --principled)", "",
               switch, ("fit",), action="store_true", group=OUTPUT, job=False),
)
