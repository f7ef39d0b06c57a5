"""The command line: ``python -m layered_brdf_addon [lookdev|gallery|render|batch|fit] ...``.

``lookdev`` (the default) renders every preset on a shader ball under a bundled HDRI,
one labelled look-development sheet; ``gallery`` renders the paper's Figs. 3-6 as one
contact sheet;
``render`` renders one material on the reference sphere or on an object of a .blend;
``batch`` renders the jobs of a TOML/JSON file, serially or on Dask; ``fit`` fits a
material to a render, a reflectance table or a Principled BSDF material
(:mod:`.fit_command`).  The options of
the material's parameters are derived from
:data:`~layered_brdf_addon.model.params.PARAM_SPECS`.

Exit codes: 0 success; 1 a render or a batch job failed, or an output could not be
written (a full disk: one line with the OS's reason, nothing written); 2 invalid input
(nothing written); 130 interrupted (no partial files left).
"""
from __future__ import annotations

import argparse
import sys
from typing import Any, Collection, Iterable, Sequence

from .. import __version__
from ..io.staging import FULL_DISK_ERRNOS, WriteError, os_reason, write_error
from ..model.params import PARAM_SPECS, ParameterError
from ..model.presets import PAPER_PRESETS
from .batch_request import batch_request_from_options
from .fit_command import run_fit
from .fit_request import fit_request_from_options
from .gallery import render_gallery, summary_rows
from .gallery import settings_from_options as gallery_settings
from .input_files import FileValueError
from .lookdev import render_lookdev
from .lookdev import settings_from_options as lookdev_settings
from .option_table import add_options, names_of, options_of, read_options
from .option_values import PARAM_NAMES, option_flag, unit_notes
from .options import (EXIT_FAILED, EXIT_INTERRUPTED, EXIT_INVALID, EXIT_OK, ArgumentParser, add_param_options,
                      blender_output)
from .render_job import execute_render
from .requests import request_from_options, run_options
from .runner import exit_code, follow_parent, run_batch, write_report

PROG = "layered-brdf"
COMMANDS = ("lookdev", "gallery", "render", "batch", "fit")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of all sub-commands."""
    parser = ArgumentParser(
        prog=PROG, description="Render iridescent layered materials (Granier & Heidrich 2003) with Blender. "
        "Without a command, renders the look-dev sheet.",
        epilog="exit codes: 0 ok, 1 a render or job failed, 2 invalid input (nothing written), 130 interrupted")
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{" + ",".join(COMMANDS) + "}")

    ld = sub.add_parser("lookdev", help="every preset on a shader ball under an HDRI, one labelled sheet (default)",
                        description="Render every preset (or --presets) on the look-dev shader ball under one of "
                        "Blender's bundled HDRIs and a soft sun, one Cycles render per preset, and compose a "
                        "labelled sheet encoded with the scene's AgX view transform: STEM.png and the sidecar "
                        "STEM.json, written together or not at all.")
    add_options(ld, "lookdev")  # every option of the table (.option_table), each with its range

    g = sub.add_parser("gallery", help="the paper's Figs. 3-6 in one labelled contact sheet",
                       description="Render every configuration of the paper's Figs. 3-6 (presets "
                       + ", ".join(PAPER_PRESETS) + ") as spheres in one scene, one render, and compose "
                       "a labelled contact sheet STEM.png, with STEM.exr and the sidecar STEM.json.")
    add_options(g, "gallery")

    r = sub.add_parser("render", help="one material on the reference sphere or on an object of a .blend",
                       description="Render one material; write STEM.png (8-bit sRGB: the reference sphere with the "
                       "Standard view transform, a --blend with its scene's view transform, look and exposure), "
                       "STEM.exr (float: beauty, normal, thickness, lower and upper normal) and STEM.json "
                       "(every parameter, camera, sun, timing: enough to predict the pixels).")
    add_options(r, "render")
    add_param_options(r)

    b = sub.add_parser("batch", help="render the jobs of a TOML or JSON job file",
                       description="Render every job of JOBFILE, each in a fresh subprocess. A job has the "
                       "options of 'render' (e.g. preset = \"fig4_tilted\", d_min = 80, samples = 4). "
                       "Failing jobs are reported; the others still run; the exit code is 1 if any failed.")
    add_options(b, "batch")

    f = sub.add_parser(
        "fit", help="fit a layered material to a render, a reflectance table or a Principled BSDF material",
        description="Fit the parameters of a layered material to a target: a reference-sphere render "
        "(TARGET), a film's mirror reflectance (--reflectance) or a Principled BSDF material rendered on the "
        "reference sphere (--principled).  Writes OUT.json (the parameters, a user preset of the panel that "
        "'render --params' reads too, with a record of the fit) and OUT.png (target, fit and their CIEDE2000 "
        "difference), together and only once the fit is done.")
    add_options(f, "fit")
    return parser


def format_table(headers: Sequence[str], rows: Iterable[Sequence[Any]], max_width: int | None = None) -> str:
    """A plain-text table; with ``max_width`` the last column is cut to keep lines that short."""
    rows = [[str(c) for c in r] for r in rows]
    widths = [max([len(h)] + [len(r[i]) for r in rows]) for i, h in enumerate(headers)]
    fixed = sum(widths[:-1]) + 2 * (len(headers) - 1)
    if max_width is not None:
        widths[-1] = max(len(headers[-1]), min(widths[-1], max_width - fixed))

    def line(cells):
        out = []
        for i, (c, w) in enumerate(zip(cells, widths)):
            if i == len(cells) - 1:
                out.append(c if len(c) <= w else c[: max(1, w - 1)] + "\u2026")
            else:
                out.append(c.rjust(w) if _numeric(c) else c.ljust(w))
        return "  ".join(out).rstrip()

    sep = "  ".join("-" * (w if i < len(widths) - 1 else min(w, 40)) for i, w in enumerate(widths))
    return "\n".join([line(list(headers)), sep] + [line(r) for r in rows])


def _numeric(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


# ---------------------------------------------------------------------------
def _options(ns: argparse.Namespace, names: Sequence[str]) -> dict[str, Any]:
    return {n: getattr(ns, n) for n in names if getattr(ns, n, None) is not None}


def cmd_render(ns: argparse.Namespace, argv: Sequence[str]) -> int:
    """``render``: validate, then render one request in this process."""
    follow_parent()
    own = _options(ns, tuple(n for n in names_of("render") if n not in run_options()))
    read_options("render", own)  # the command's own options (--verbose...); a job holds the others
    req = request_from_options(_options(ns, run_options() + PARAM_NAMES))
    for note in unit_notes(dict(req.overrides)):
        print(f"{PROG}: note: {note}", file=sys.stderr)
    with blender_output(ns.verbose):
        sidecar = execute_render(req, command=[sys.executable, "-m", "layered_brdf_addon", *argv])
    p = req.paths
    print(f"wrote {p.png}\n      {p.exr}\n      {p.json}\n"
          f"render {sidecar['render_seconds']:.2f} s, total {sidecar['total_seconds']:.2f} s "
          f"({req.backend}, {sidecar['samples']} spp, {sidecar['camera']['width']}x{sidecar['camera']['height']})")
    return EXIT_OK


def cmd_gallery(ns: argparse.Namespace, argv: Sequence[str]) -> int:
    """``gallery``: render the paper's configurations into one labelled contact sheet."""
    s = gallery_settings(_options(ns, names_of("gallery")))
    with blender_output(ns.verbose):
        res = render_gallery(s, command=[sys.executable, "-m", "layered_brdf_addon", *argv])
    headers, rows = summary_rows(res)
    print(format_table(headers, rows))
    w, h = res.layout.sheet_size
    print(f"\none render of {len(res.tiles)} spheres ({s.size} px, {s.samples} spp, {s.backend}): "
          f"{res.render_seconds:.1f} s; total {res.total_seconds:.1f} s")
    print(f"wrote {res.png} ({w}x{h}, {res.layout.columns}x{res.layout.rows} tiles), {res.exr}, {res.sidecar}")
    return EXIT_OK


def cmd_lookdev(ns: argparse.Namespace, argv: Sequence[str]) -> int:
    """``lookdev``: every preset on the shader ball, one labelled sheet."""
    s = lookdev_settings(_options(ns, names_of("lookdev")))
    with blender_output(ns.verbose):
        res = render_lookdev(s, command=[sys.executable, "-m", "layered_brdf_addon", *argv], progress=ns.progress)
    rows = [[t["name"], t["label"][0], f"{t['render_seconds']:.1f}"] for t in res.tiles]
    print(format_table(["preset", "label", "render s"], rows))
    w, h = res.layout.sheet_size
    print(f"\n{len(res.tiles)} tiles ({s.size} px, {s.samples} spp, {res.metadata['hdri']}, "
          f"{res.metadata['view']['view_transform']}): render {res.render_seconds:.1f} s; total {res.total_seconds:.1f} s")
    print(f"wrote {res.png} ({w}x{h}), {res.sidecar}")
    return EXIT_OK


def cmd_batch(ns: argparse.Namespace) -> int:
    """``batch``: run the jobs of a job file and print a summary table."""
    req = batch_request_from_options(_options(ns, names_of("batch")))
    results = run_batch(req.jobs, n_jobs=req.n_jobs, scheduler=req.scheduler, timeout=req.timeout,
                        progress=req.progress)
    rows = []
    for r in results:
        if r.ok:
            stem = r.outputs[0][: -len(".png")]
            detail = f"{stem}.{{png,exr,json}}"
        else:
            detail = r.error
        rows.append([r.name, r.status, f"{r.seconds:.1f}", detail])
    print(format_table(["job", "status", "seconds", "outputs / error"], rows))
    failed = sum(not r.ok for r in results)
    print(f"\n{len(results) - failed} of {len(results)} jobs rendered" + (f", {failed} failed" if failed else ""))
    if req.report is not None:
        try:
            write_report(req.report, {"jobfile": str(req.jobfile), "results": [r.to_dict() for r in results]})
        except OSError as e:
            print(f"{PROG}: error: could not write --report {req.report}: {os_reason(e)}", file=sys.stderr)
            return EXIT_FAILED
    return exit_code(results)


def _hint(e: ParameterError, command: str, options: Collection[str]) -> str:
    """`` (option --NAME)`` after the message of a value given on the command line.

    Only for an option of the command that runs (``options``: its dests): a job file's
    ``output`` is no ``batch --output``, and a value read from a file
    (:class:`~.input_files.FileValueError`) names that file and its key instead.
    """
    if isinstance(e, FileValueError) or e.name not in options:
        return ""
    for spec in options_of(command):
        if spec.name == e.name:
            return f" (option {spec.flag})" if not spec.positional else f" (argument {spec.flag})"
    return f" (option {option_flag(e.name)})" if any(s.name == e.name for s in PARAM_SPECS) else ""


def _write_failed(e: Exception) -> int:
    """Say that an output could not be written (a full disk, with the OS's reason), without a
    traceback: the staged outputs were removed, earlier files kept.  Returns the exit code."""
    print(f"{PROG}: error: {e}; no output was written", file=sys.stderr)
    return EXIT_FAILED


def normalise_argv(argv: Sequence[str]) -> list[str]:
    """``lookdev`` is the command when none is given (options alone go to the look-dev sheet)."""
    argv = list(argv)
    if not argv or (argv[0] not in COMMANDS and argv[0] not in ("-h", "--help", "--version")):
        argv = ["lookdev", *argv]
    return argv


def missing_module(e: ModuleNotFoundError) -> str:
    """What to do when this Python lacks a module the command needs (``bpy``: Blender's)."""
    what = "module 'bpy' (Blender as a Python module)" if e.name == "bpy" else f"module '{e.name}'"
    return (f"this Python ({sys.executable}, Python {sys.version.split()[0]}) has no {what}: run layered-brdf with "
            "the Python that 'make' sets up (.venv-5.2/bin/python -m layered_brdf_addon ..., or "
            ".venv-5.2/bin/layered-brdf; 'make which' names it), or install the package there with "
            "pip install -e . (bpy 5.2.3 needs Python 3.13, bpy 5.0.1 Python 3.11)")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``python -m layered_brdf_addon`` and ``layered-brdf``; returns the exit code."""
    argv = normalise_argv(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    ns = parser.parse_args(argv)
    try:
        if ns.command == "render":
            return cmd_render(ns, argv)
        if ns.command == "batch":
            return cmd_batch(ns)
        if ns.command == "gallery":
            return cmd_gallery(ns, argv)
        if ns.command == "fit":
            return run_fit(fit_request_from_options(_options(ns, names_of("fit"))), argv)
        return cmd_lookdev(ns, argv)
    except ParameterError as e:
        print(f"{PROG}: error: {e}{_hint(e, ns.command, vars(ns))}", file=sys.stderr)
        return EXIT_INVALID
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted; no partial output was left", file=sys.stderr)
        return EXIT_INTERRUPTED
    except WriteError as e:
        return _write_failed(e)
    except ModuleNotFoundError as e:  # run by a Python without Blender's module (the system's, say)
        print(f"{PROG}: error: {missing_module(e)}", file=sys.stderr)
        return EXIT_FAILED
    except Exception as e:  # a render that Blender could not do: report it, exit 1
        if isinstance(e, OSError) and e.errno in FULL_DISK_ERRNOS:
            return _write_failed(write_error(e))
        import traceback

        traceback.print_exc(file=sys.stderr)
        print(f"{PROG}: error: {e.__class__.__name__}: {e}", file=sys.stderr)
        return EXIT_FAILED


if __name__ == "__main__":
    sys.exit(main())
