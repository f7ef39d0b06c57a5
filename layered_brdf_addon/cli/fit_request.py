"""Validating a ``fit`` request without Blender: which target the options name, the start, the free
parameters, the outputs and the Principled BSDF target's renders, each checked before anything is read or
rendered.  :func:`fit_request_from_options` takes ``fit``'s options as a mapping (from the command line or a
script) and returns a :class:`FitRequest`, or raises :class:`ParameterError` naming the first invalid option.
Nothing here imports bpy.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from ..fit.structures import Candidate, structure_pool
from ..io.sidecar import sidecar_path
from ..io.staging import OutputPaths
from ..model.params import LayeredParams, ParameterError
from ..model.presets import preset
from .fit_options import TARGET
from .fit_options import (MATERIAL_ALLOWED, MODE_OPTIONS, PRINCIPLED_HDRIS, PRINCIPLED_SAMPLES,
                          PRINCIPLED_SIZE, REFLECTANCE_ALLOWED, SOURCE_ALLOWED, STARTS_DEFAULT, TARGET_ALLOWED)
from .fit_outputs import check_output, default_output
from .fit_targets import Source
from .fit_verify import check_verifiable
from .input_files import file_label, from_file, load_params_file, merged_values
from .option_table import options_of, read_options
from .option_values import path_option, shown


@dataclass(frozen=True)
class PrincipledRenders:
    """How a Principled BSDF target is rendered: pixels, samples and the HDRIs besides the suns."""

    size: int = PRINCIPLED_SIZE
    samples: int = PRINCIPLED_SAMPLES
    hdris: tuple[str, ...] = PRINCIPLED_HDRIS


@dataclass(frozen=True)
class FitRequest:
    """A validated fit: the target named (not yet read), the start and where it came from (or, with
    neither ``start`` nor ``params``, the structures the fit chooses among), the free parameters
    (``None``: the structure's modes decide), the thickness orders tried and the outputs."""

    source: Source
    start: LayeredParams | None  # None: the fit chooses the structure among ``pool``
    start_record: Mapping[str, Any]
    paths: OutputPaths
    vary: tuple[str, ...] | None = None
    starts: int = STARTS_DEFAULT
    tile: Any = None  # a gallery render's sphere: its preset name or index
    principled: PrincipledRenders | None = None  # a Principled BSDF target's renders
    progress: bool = True
    verbose: bool = False
    inputs: tuple[tuple[str, Path], ...] = field(default_factory=tuple)  # files no output may replace
    pool: tuple[Candidate, ...] = ()  # the structures the fit chooses among (none: the start's is kept)
    verify: bool = False  # render the fit as the target was and compare
    try_noise: bool = False  # the pool's height thickness may give way to a noise pattern (a render, not pinned)


def source_of(given: Mapping[str, Any]) -> Source:
    """The target the options name; :class:`ParameterError` unless exactly one is named and
    the options that go with it are given with it only."""
    options = options_of("fit")
    targets = [s.name for s in options if s.group == TARGET and s.goes_with is None]
    named = [k for k in targets if given.get(k) is not None]
    if len(named) != 1:
        raise ParameterError("target", shown([given[k] for k in named]) if named else None, SOURCE_ALLOWED)
    kind = named[0]
    for s in options:
        if s.goes_with is not None and s.goes_with != kind and s.is_set(given.get(s.name)):
            other = next(o for o in options if o.name == s.goes_with)
            why = " (a gallery render's sphere)" if s.goes_with == "target" else ""
            raise ParameterError(s.name, given[s.name], f"no value without {other.flag}{why}")
    if kind == "target":
        side = sidecar_path(path_option("target", given["target"], TARGET_ALLOWED))
        paths = OutputPaths(side.with_suffix(""))
        return Source("render", side, paths.stem.name,
                      [("the target's sidecar", paths.json), ("the target's EXR", paths.exr),
                       ("the target's PNG", paths.png)])
    if kind == "reflectance":
        p = path_option("reflectance", given["reflectance"], REFLECTANCE_ALLOWED)
        return Source("reflectance", p, p.stem, [("the reflectance table", p)])
    p = path_option("principled", given["principled"], "the path of a .blend file")
    material = given.get("material")
    if not isinstance(material, str) or not material.strip():
        raise ParameterError("material", material, MATERIAL_ALLOWED)
    return Source("principled", p, material, [("the .blend", p)])


def mode_overrides(given: Mapping[str, Any]) -> dict[str, Any]:
    """The mode options given (:data:`~.fit_options.MODE_OPTIONS`): over a start, or pinned on every structure."""
    return {k: given[k] for k in MODE_OPTIONS if given.get(k) is not None}


def start_of(given: Mapping[str, Any]) -> tuple[LayeredParams, dict[str, Any]]:
    """The parameters a fit of one structure starts from, and the record of where they came from:
    ``start`` (a preset; none with only ``params``), a ``params`` file over it, the mode options over
    both."""
    name = given.get("start")
    params = preset(name) if name is not None else LayeredParams()
    file_values, label, params_file = {}, "", None
    if given.get("params") is not None:
        params_file = path_option("params", given["params"],
                                  "the path of a .json or .toml file of parameter values").absolute()
        label = file_label(given["params"])
        file_values = load_params_file(params_file, label)
    overrides = mode_overrides(given)
    try:
        params = LayeredParams.from_dict(merged_values(file_values, overrides), base=params)
    except ParameterError as e:
        raise from_file(e, file_values, label, overridden=overrides) from None
    return params, {"preset": name, "params_file": params_file, "overrides": overrides}


def fit_request_from_options(options: Mapping[str, Any]) -> FitRequest:
    """Validate ``fit``'s options (names with ``_``): each value alone (the option table), then the target
    they name, the start, and the outputs (writable, replacing no input)."""
    given = read_options("fit", {k: v for k, v in options.items() if v is not None})
    source = source_of(given)
    select = given.get("start") is None and given.get("params") is None
    layer = given.get("layer")
    if layer is not None and not select:
        raise ParameterError("layer", layer, "no value with --start or --params (their layer is the fit's)")
    if layer == "stack" and source.kind != "reflectance":
        raise ParameterError("layer", layer, "'film' for a render or a Principled material (a stack is fitted to "
                             "a --reflectance table)")
    if select:
        pinned = mode_overrides(given)
        start, pool = None, tuple(structure_pool(source.kind == "reflectance", pinned, layer=layer))
        record = {"preset": None, "params_file": None, "chosen_by": "model selection", "overrides": pinned,
                  **({"layer": layer} if layer else {})}
    else:
        (start, record), pool = start_of(given), ()
        if source.kind == "reflectance" and start.stack is not None and start.normal_mode == "tilted":
            raise ParameterError("start", given.get("start") or given.get("params"),
                                 "a structure that reflects about the mirror direction a --reflectance table holds "
                                 "(tilted lamellae send their schiller away from it)")
    inputs = list(source.inputs)
    if record["params_file"] is not None:
        inputs.append(("the params file", record["params_file"]))
    paths = check_output(given.get("output", default_output(source)), inputs)
    principled = None
    if source.kind == "principled":
        hdris = given.get("hdri", PRINCIPLED_HDRIS)
        principled = PrincipledRenders(size=given.get("size", PRINCIPLED_SIZE),
                                       samples=given.get("samples", PRINCIPLED_SAMPLES),
                                       hdris=() if hdris == ("none",) else tuple(hdris))
    if given.get("verify"):
        check_verifiable(source, given.get("tile"))
    return FitRequest(source=source, start=start, start_record=record, paths=paths, vary=given.get("vary"),
                      starts=given.get("starts", STARTS_DEFAULT), tile=given.get("tile"), principled=principled,
                      progress=given.get("progress", True), verbose=given.get("verbose", False), inputs=tuple(inputs),
                      pool=pool, verify=given.get("verify", False),
                      try_noise=bool(pool) and source.kind == "render" and "thickness_mode" not in given)
