"""The options of ``layered-brdf fit`` and the start they name.

:func:`add_parser` adds the sub-command (its target, start, free parameters and output);
:func:`start_of` makes the parameters the fit starts from out of ``--start``, ``--params``
and the mode options.
"""
from __future__ import annotations

import argparse
from typing import Any

from ..model.params import PARAM_SPECS, LayeredParams, ParameterError
from ..model.presets import PRESETS, preset
from .fit_targets import PRINCIPLED_HDRIS, PRINCIPLED_SAMPLES, PRINCIPLED_SAMPLING, PRINCIPLED_SIZE, PRINCIPLED_SIZES
from .input_files import file_label, from_file, load_params_file, merged_values
from .option_values import option_flag, path_option, shown
from .options import param_metavar

# The start when neither --start nor --params is given, by the target's kind: the preset whose
# fits of test targets came closest (layered renders of physical and paper films; Principled
# BSDF materials: a dielectric with and without a thin film, a metal with one).  A Principled
# BSDF's film is uniform: its start's thickness goes by height, which a fit can make uniform.
DEFAULT_STARTS = {"render": ("soap_bubble", {}), "principled": ("glazed_clay", {"thickness_mode": "height"}),
                  "reflectance": ("anodised_titanium", {})}
# The start's modes an option may override (the options of ``render`` for them).
MODE_OPTIONS = ("thickness_mode", "normal_mode", "optics", "lower_medium", "base_layer", "accuracy")
STARTS_RANGE = (1, 10)


def add_parser(sub) -> argparse.ArgumentParser:
    """The ``fit`` sub-command of ``sub`` (the parser's sub-parsers)."""

    f = sub.add_parser(
        "fit", help="fit a layered material to a render, a reflectance table or a Principled BSDF material",
        description="Fit the parameters of a layered material to a target: a reference-sphere render "
        "(TARGET), a film's mirror reflectance (--reflectance) or a Principled BSDF material rendered on the "
        "reference sphere (--principled).  Writes OUT.json (the parameters, a user preset of the panel that "
        "'render --params' reads too, with a record of the fit) and OUT.png (target, fit and their CIEDE2000 "
        "difference), together and only once the fit is done.")
    tgt = f.add_argument_group("target (exactly one)")
    tgt.add_argument("target", nargs="?", default=None, metavar="TARGET",
                     help="a reference-sphere render: its sidecar STEM.json, or STEM, STEM.exr or STEM.png "
                     "(the sidecar and the EXR beside it); the EXR's Combined pass is fitted")
    tgt.add_argument("--tile", default=None, metavar="NAME|INDEX",
                     help="the sphere of a gallery render to fit: its preset name or its index from 0")
    tgt.add_argument("--reflectance", default=None, metavar="FILE.csv",
                     help="a film's mirror reflectance: a CSV whose header names angle (degrees), wavelength "
                     "(nm) or channel (r, g, b) and reflectance (0-1); e.g. 'angle_deg,wavelength_nm,reflectance'")
    tgt.add_argument("--principled", default=None, metavar="FILE.blend",
                     help="a .blend holding the Principled BSDF material --material, rendered by Cycles on the "
                     "reference sphere under three suns")
    tgt.add_argument("--material", default=None, metavar="NAME", help="the material of --principled")
    tgt.add_argument("--size", default=None, metavar="PX",
                     help=f"--principled: pixels of each render, an integer in [{PRINCIPLED_SIZES[0]}, "
                     f"{PRINCIPLED_SIZES[1]}] (default {PRINCIPLED_SIZE})")
    tgt.add_argument("--samples", default=None, metavar="N",
                     help=f"--principled: samples per pixel, an integer in [{PRINCIPLED_SAMPLING[0]}, "
                     f"{PRINCIPLED_SAMPLING[1]}] (default {PRINCIPLED_SAMPLES}, exact under a sun)")
    tgt.add_argument("--hdri", nargs="+", default=None, metavar="NAME",
                     help="--principled: Blender's bundled HDRIs the material is also rendered under and fitted "
                          f"to (default {' '.join(PRINCIPLED_HDRIS)}; 'none': the suns only)")
    st = f.add_argument_group("start and free parameters")
    st.add_argument("--start", default=None, metavar="PRESET",
                    help="the preset the fit starts from, whose modes (optics, lower medium, normals, thickness "
                    "pattern) it keeps: they decide what the fit can reach, so choose the preset of the target's "
                    f"kind of material. Default: {DEFAULT_STARTS['render'][0]} for TARGET, "
                    f"{DEFAULT_STARTS['principled'][0]} with --thickness-mode height for --principled, "
                    f"{DEFAULT_STARTS['reflectance'][0]} for --reflectance (the presets that came closest on test "
                    "targets of each kind). One of " + ", ".join(PRESETS))
    st.add_argument("--params", default=None, metavar="FILE",
                    help="start from the parameter values of a .json or .toml file (a render's sidecar or an "
                    "earlier fit's OUT.json work too), over --start when given")
    st.add_argument("--vary", nargs="+", default=None, metavar="NAME",
                    help="the parameters the fit may change (default: the continuous parameters the start's "
                    "modes use; for --reflectance the layer's indices and thickness)")
    st.add_argument("--starts", default=None, metavar="N",
                    help=f"thickness orders tried besides the start, an integer in [{STARTS_RANGE[0]}, "
                    f"{STARTS_RANGE[1]}] (default 3)")
    for spec in PARAM_SPECS:
        if spec.name in MODE_OPTIONS:
            st.add_argument(option_flag(spec.name), dest=spec.name, choices=spec.options, default=None,
                            metavar=param_metavar(spec), help=mode_help(spec))
    out = f.add_argument_group("output")
    out.add_argument("--output", default=None, metavar="OUT",
                     help="output stem: writes OUT.json and OUT.png (default out/NAME-fit, NAME the target's)")
    out.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    out.add_argument("--verbose", action="store_true", help="--principled: show Blender's own log")
    return f


def mode_help(spec) -> str:
    """Help of a mode option: what it overrides, the parameter's description."""
    text = f"the start's {spec.label.lower()}, instead of its own: {spec.description}"
    if spec.name == "thickness_mode":
        text += "; a noise is fitted through the colours' statistics, a height pixel by pixel"
    return text.replace("%", "%%")


# ---------------------------------------------------------------------------
# the start
def start_of(ns: argparse.Namespace, kind: str) -> tuple[LayeredParams, dict[str, Any]]:
    """The parameters the fit starts from, and the record of where they came from: ``--start``
    (default :data:`DEFAULT_STARTS` by the target's kind; none with only ``--params``), a
    ``--params`` file over it, the mode options over both."""
    name, defaults = ns.start, {}
    if name is not None and name not in PRESETS:
        raise ParameterError("start", shown(name), "one of " + ", ".join(PRESETS))
    if name is None and ns.params is None:
        name, defaults = DEFAULT_STARTS[kind]
    params = preset(name) if name is not None else LayeredParams()
    file_values, label, params_file = {}, "", None
    if ns.params is not None:
        params_file = path_option("params", ns.params,
                                  "the path of a .json or .toml file of parameter values").absolute()
        label = file_label(ns.params)
        file_values = load_params_file(params_file, label)
    overrides = {**defaults, **{k: getattr(ns, k) for k in MODE_OPTIONS if getattr(ns, k, None) is not None}}
    try:
        params = LayeredParams.from_dict(merged_values(file_values, overrides), base=params)
    except ParameterError as e:
        raise from_file(e, file_values, label, overridden=overrides) from None
    return params, {"preset": name, "params_file": params_file, "overrides": overrides}
