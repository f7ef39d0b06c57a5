"""The outputs of ``layered-brdf fit``: ``OUT.json`` and ``OUT.png``.

:func:`check_output` checks them before the fit; :func:`output_document` is ``OUT.json`` (a
user preset of the panel with the record of the fit), :func:`sphere_figure` and
:func:`reflectance_figure` are ``OUT.png``, and :func:`write_outputs` writes both together.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .. import __version__
from ..fit import colour_space
from ..io.codecs import to_srgb8
from ..io.sidecar import write_json
from ..io.staging import OutputPaths, StagedOutputs, TargetError, check_targets, output_stem, writing
from ..model.params import LayeredParams, ParameterError
from .fit_targets import LoadedTarget, Source
from .input_files import same_file
from .option_values import MAX_STEM_BYTES, MAX_TEXT, shown

PRESET_FORMAT = "layered_brdf.preset"  # the panel's user presets (blender/user_presets.py)
PRESET_FORMAT_VERSION = 1
DEFAULT_OUTPUT_DIR = Path("out")
OUTPUT_ALLOWED = "a file path stem in a writable folder (STEM.json and STEM.png are written)"


def check_output(value: Any, inputs: Sequence[tuple[str, Path]]) -> OutputPaths:
    """The outputs ``OUT.json`` and ``OUT.png`` of the stem ``value``, checked before the fit: a
    stem whose name is not hidden nor too long, files that can be written (no folder in the way,
    a writable folder) and that replace none of ``inputs``; else :class:`ParameterError`
    naming ``output``."""
    if not isinstance(value, (str, Path)) or not str(value).strip() or "\x00" in str(value) \
            or len(str(value)) > MAX_TEXT:
        raise ParameterError("output", shown(value), OUTPUT_ALLOWED)
    stem = output_stem(Path(value).expanduser()).absolute()
    if stem.name in ("", ".", "..") or stem.name.startswith("."):
        raise ParameterError("output", str(value), OUTPUT_ALLOWED + "; a stem whose name does not start with '.'")
    if len(stem.name.encode("utf-8", "surrogateescape")) > MAX_STEM_BYTES:
        raise ParameterError("output", shown(str(value)), OUTPUT_ALLOWED + f"; a stem of at most {MAX_STEM_BYTES} "
                             "bytes")
    if stem.is_dir():
        raise ParameterError("output", str(value), OUTPUT_ALLOWED + "; it names a folder")
    paths = OutputPaths(stem)
    try:
        check_targets([paths.json, paths.png])
    except TargetError as e:
        raise ParameterError("output", str(value), f"{OUTPUT_ALLOWED}; {e}") from None
    for label, p in inputs:
        for f in (paths.json, paths.png):
            if same_file(f, p):
                raise ParameterError("output", str(value), f"{OUTPUT_ALLOWED}, none of them an input file "
                                     f"({f.name} would replace {label} {p})")
    return paths


def default_output(source: Source) -> Path:
    """``out/NAME-fit``, NAME the target's (its file's stem, the material's name)."""
    name = re.sub(r"[^A-Za-z0-9_.-]+", "_", source.name).strip("._") or "target"
    return DEFAULT_OUTPUT_DIR / f"{name}-fit"


def reported_delta_e(target, result, selection=None) -> float:
    """The figure a fit reports: the mean CIEDE2000 over every pixel of the sphere (what comparing a
    render of the fit with the target gives) where numpy computes them all, else over what the fit
    compared (a table's rows, a noise thickness's statistics).  A selection's chosen structure has it
    already."""
    if selection is not None:
        image = selection.chosen.image_delta_e
    else:
        image = target.image_delta_e(result.params) if hasattr(target, "image_delta_e") else None
    return float(result.mean_delta_e if image is None else image)


def fit_record(result, loaded: LoadedTarget, start_record: dict[str, Any], argv: Sequence[str] | None,
               selection=None) -> dict:
    """The ``fit`` table of ``OUT.json``: the figure over every pixel of the sphere
    (:func:`reported_delta_e`) and over the sample the fit compared; with a model selection, the
    structures tried (best first: each one's label, modes, screening figure and, for a finalist, its full
    fit's) and the one chosen."""
    chosen = {} if selection is None else {"structure": selection.chosen.label,
                                           "structures": selection.to_record()}
    return {"target": loaded.record, "start": start_record, **chosen, "vary": list(result.vary),
            "mean_delta_e_2000": reported_delta_e(loaded.target, result, selection),
            "sampled_mean_delta_e_2000": float(result.mean_delta_e), "evaluations": int(result.evaluations),
            "seconds": float(result.seconds),
            "starts": [{"d_min": float(a), "d_max": float(b), "mean_delta_e_2000": float(de)}
                       for a, b, de in result.starts],
            "layered_brdf_version": __version__,
            "command": [sys.executable, "-m", "layered_brdf_addon", *argv] if argv is not None else None}


def output_document(name: str, params: LayeredParams, record: dict[str, Any]) -> dict[str, Any]:
    """``OUT.json``: a user preset of the panel (its format, version, name and parameters) with
    the record of the fit beside the parameters."""
    return {"format": PRESET_FORMAT, "version": PRESET_FORMAT_VERSION, "name": name,
            "params": params.validate().to_dict(), "fit": record}


def sphere_figure(target, params: LayeredParams, mean_delta_e: float, structure: str | None = None):
    """Target | fit | CIEDE2000 per pixel, one row per view, each cropped to the fitted sphere; the
    structure a model selection chose under the title."""
    from matplotlib.figure import Figure

    rows = len(target.views)
    fig = Figure(figsize=(9.6, 3.0 * rows + 0.4), dpi=100, layout="constrained")
    fig.suptitle(f"layered-brdf fit: mean CIEDE2000 {mean_delta_e:.2f}"
                 + (f"\n{structure}" if structure else ""), fontsize=11)
    noise = getattr(target, "matches_statistics", lambda p: False)(params)
    for k, view in enumerate(target.views):
        mask = target.mask(k)
        r, c = np.nonzero(mask)
        box = (slice(max(r.min() - 2, 0), r.max() + 3), slice(max(c.min() - 2, 0), c.max() + 3))
        observed = np.where(mask[..., None], np.asarray(view.image, dtype=float)[..., :3], 0.0)
        fitted = target.render(params, k)
        de = np.full(mask.shape, np.nan)
        de[mask] = target.view_delta_e(k, fitted)
        suffix = f" (sun {k + 1})" if rows > 1 else ""
        panels = [(to_srgb8(observed[box]), "target" + suffix),
                  (to_srgb8(fitted[box]), "fit" + (" at the noise's median thickness" if noise else "")),
                  (de[box], f"CIEDE2000 per pixel, mean {np.nanmean(de):.2f}")]
        for j, (image, title) in enumerate(panels):
            ax = fig.add_subplot(rows, 3, 3 * k + j + 1)
            ax.set_axis_off()
            ax.set_title(title, fontsize=9)
            if j < 2:
                ax.imshow(image, interpolation="nearest")
            else:
                vmax = max(2.0, float(np.nanpercentile(image, 99)))
                shown_map = ax.imshow(image, cmap="magma", vmin=0.0, vmax=vmax, interpolation="nearest")
                fig.colorbar(shown_map, ax=ax, fraction=0.046, pad=0.04)
    return fig


def reflectance_figure(target, params: LayeredParams, mean_delta_e: float, structure: str | None = None):
    """A swatch per angle, target above fit (one exposure for both), with each angle's CIEDE2000,
    and the reflectance of each channel against the angle, target and fit."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    observed, fitted = np.asarray(target.observed, dtype=float), np.asarray(target.predict(params), dtype=float)
    de = colour_space.delta_e_2000(colour_space.lab(observed), colour_space.lab(np.maximum(fitted, 0.0)))
    brightest = float(colour_space.luminance(observed).max(initial=0.0))
    exposure = 1.0 if brightest >= 0.25 else 0.5 / max(brightest, 1e-6)
    fig = Figure(figsize=(max(6.0, 1.1 * len(observed) + 4.5), 4.2), dpi=100)
    fig.suptitle(f"layered-brdf fit: mean CIEDE2000 {mean_delta_e:.2f}" + (f"\n{structure}" if structure else ""),
                 fontsize=11)
    swatches = fig.add_axes((0.1, 0.16, 0.45, 0.66))
    for i, row in enumerate(to_srgb8(np.stack([observed, fitted]) * exposure) / 255.0):
        for j, colour in enumerate(row):
            swatches.add_patch(Rectangle((j + 0.06, i + 0.06), 0.88, 0.88, color=colour))
    swatches.set_xlim(0.0, len(observed))
    swatches.set_ylim(2.0, 0.0)
    swatches.set_xticks(np.arange(len(observed)) + 0.5,
                        [f"{a:g}\u00b0\n\u0394E {d:.2f}" for a, d in zip(target.angles, de)], fontsize=8)
    swatches.set_yticks([0.5, 1.5], ["target", "fit"], fontsize=9)
    swatches.tick_params(length=0)
    for side in swatches.spines.values():
        side.set_visible(False)
    swatches.set_title("mirror reflection" + (f" (shown \u00d7{exposure:.3g})" if exposure != 1.0 else ""),
                       fontsize=9)
    curves = fig.add_axes((0.64, 0.16, 0.33, 0.66))
    for i, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        curves.plot(target.angles, observed[:, i], "o-", color=colour, lw=1.2, ms=3)
        curves.plot(target.angles, fitted[:, i], "--", color=colour, lw=1.2)
    curves.set_xlabel("angle (degrees)", fontsize=8)
    curves.set_ylabel("reflectance (R, G, B)", fontsize=8)
    curves.set_title("target (solid), fit (dashed)", fontsize=9)
    curves.tick_params(labelsize=7)
    return fig


def write_outputs(paths: OutputPaths, document: dict[str, Any], figure, guard) -> None:
    """``OUT.png`` and ``OUT.json`` written under temporary names and renamed together."""
    with StagedOutputs([paths.png, paths.json], guard) as staged:
        with guard.io(), writing(paths.png):
            figure.savefig(staged.temp(paths.png), format="png")
        guard.check()
        with guard.io(), writing(paths.json):
            write_json(staged.temp(paths.json), document)
        guard.check()
