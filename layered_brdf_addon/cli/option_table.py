"""The command line's options, declared once: name, value, range, help, the commands that take them and the
group ``--help`` shows them in.  Every command's argument parser (``--help`` with each range), the options a
job file may hold, their validation, the arguments that reproduce a render and docs/options.md are made
from :func:`table`; the material's parameters are declared in :mod:`..model.params` and added beside them
(:func:`.options.add_param_options`).  An option whose range or meaning differs between commands (a tile's
size, an output) is declared once per meaning.

An option's ``parse`` checks what it can alone (a range, a name); what depends on other options or on the
file system (an output that must not replace an input, a path relative to a job file) the command's request
checks (:mod:`.requests`, :mod:`.batch_request`, :mod:`.fit_request`, the sheets' settings).

Nothing here imports bpy.
"""

from __future__ import annotations

import argparse
from typing import Any, Mapping

from ..model import policy
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS, PRESETS, STACK_PRESETS
from .fit_options import FIT_OPTIONS
from .fit_options import START as FIT_START
from .fit_options import TARGET as FIT_TARGET
from .option_spec import (HDRI_ALLOWED, OptionSpec, as_given, backend_name, floats, hdri_name, ints, plain_text,
                          preset_name, switch)
from .option_values import (NAME_ALLOWED, OPTION_ALLOWED, PRESETS_ALLOWED, RESOLUTION_ALLOWED, SUN_ALLOWED,
                            check_name, check_preset_names, parse_resolution, parse_sun)

MAX_SAMPLES = 1_000_000
MAX_SEED = 2**31 - 1
MAX_THREADS = 1024
MAX_SUN_STRENGTH = 1.0e6
MAX_COLUMNS = 64
GALLERY_SIZE, GALLERY_SIZES = 128, (16, 4096)  # pixels per tile: the default, the range
GALLERY_SAMPLES = 16
# The look-dev sheet, sized for about a minute on two cores (measured: docs/looks.md).
LOOKDEV_SIZE, LOOKDEV_SIZES = 192, (16, 2048)
LOOKDEV_SAMPLES, LOOKDEV_SAMPLING = 32, (1, 4096)
BATCH_JOBS = (1, 4096)  # parallel jobs of a local cluster
BATCH_TIMEOUT = (1.0, 1.0e7)  # seconds


# ---------------------------------------------------------------------------
# the table
MATERIAL, SCENE, OUTPUT = "material", "scene", "output"
RENDER_OPTIONS = (
    OptionSpec("preset", "a named material", "one of " + ", ".join(sorted(PRESETS)), preset_name, ("render",),
               metavar="NAME", group=MATERIAL),
    OptionSpec("params", "parameter values over the preset's (a render's sidecar works too)",
               "the path of a .json or .toml file of parameter values", as_given, ("render",), metavar="FILE",
               group=MATERIAL, field="params_file"),
    OptionSpec("blend", "render this .blend's camera instead of the reference sphere", "the path of a .blend file",
               as_given, ("render",), metavar="FILE", group=SCENE),
    OptionSpec("object", "with --blend",
               "the name of the object in the .blend that gets the material", as_given, ("render",),
               metavar="NAME", group=SCENE, text=True),
    OptionSpec("resolution", "image size", RESOLUTION_ALLOWED,
               lambda name, value: parse_resolution(value), ("render",),
               defaults={"render": "128 on the reference sphere; a .blend's own"}, metavar="N|WxH", group=SCENE,
               as_argument=lambda wh: f"{wh[0]}x{wh[1]}"),
)
SCENE_OPTIONS = (
    OptionSpec("backend", "shader backend: the generated node group or the OSL script",
               "one of " + ", ".join(policy.BACKENDS), backend_name, ("render", "gallery"),
               defaults={"render": "nodes", "gallery": "nodes"}, metavar="NAME", choices=policy.BACKENDS, group=SCENE),
    OptionSpec("samples", "samples per pixel", f"an integer in [1, {MAX_SAMPLES}]", ints(1, MAX_SAMPLES),
               ("render", "gallery"),
               defaults={"render": "1 on the reference sphere, exact under a zero-angle sun; a .blend's own",
                         "gallery": f"{GALLERY_SAMPLES}; one is exact under the sun, more anti-alias"}, group=SCENE),
    OptionSpec("sun", "direction from the scene towards the zero-angle sun", SUN_ALLOWED,
               lambda name, value: parse_sun(value),
               ("render", "gallery"), defaults={"render": "0.5 -1 0.6", "gallery": "0.5 -1 0.6"},
               metavar=("X", "Y", "Z"), nargs=3, reference_only=True, group=SCENE),
    OptionSpec("sun_strength", "sun irradiance (W/m^2)", f"a number in [0, {MAX_SUN_STRENGTH:g}]",
               floats(0.0, MAX_SUN_STRENGTH), ("render", "gallery"),
               defaults={"render": "3", "gallery": "3"}, metavar="W_PER_M2", reference_only=True, group=SCENE),
    OptionSpec("seed", "Cycles' sampling seed", f"an integer in [0, {MAX_SEED}]", ints(0, MAX_SEED),
               ("render", "gallery"), defaults={"render": "0", "gallery": "0"}, group=SCENE),
    OptionSpec("threads", "Cycles render threads", f"an integer in [1, {MAX_THREADS}]", ints(1, MAX_THREADS),
               ("render", "gallery"), defaults={"render": "2", "gallery": "2"}, group=SCENE),
)
SHEET_OPTIONS = (
    OptionSpec("presets", "other presets to show instead of the paper's", PRESETS_ALLOWED,
               lambda name, value: check_preset_names(value), ("gallery",), metavar="NAME", nargs="+",
               defaults={"gallery": "the paper's: " + ", ".join(PAPER_PRESETS)}, group=MATERIAL),
    OptionSpec("presets", "the presets to show", PRESETS_ALLOWED, lambda name, value: check_preset_names(value),
               ("lookdev",), metavar="NAME", nargs="+",
               defaults={"lookdev": "every artist preset, the structural colours, then the paper's figures: "
                         + ", ".join(list(ARTIST_PRESETS) + list(STACK_PRESETS) + list(PAPER_PRESETS))},
               group=MATERIAL),
    OptionSpec("hdri", "the HDRI of the sheet's world, one of Blender's bundled ones (forest, courtyard, studio, "
               "city, interior, night, sunrise, sunset)", HDRI_ALLOWED, hdri_name, ("lookdev",),
               defaults={"lookdev": "forest"}, metavar="NAME", group=SCENE),
    OptionSpec("size", "pixels per tile", f"an integer in [{GALLERY_SIZES[0]}, {GALLERY_SIZES[1]}]",
               ints(*GALLERY_SIZES), ("gallery",), defaults={"gallery": str(GALLERY_SIZE)}, metavar="PX",
               group=OUTPUT),
    OptionSpec("size", "pixels per tile", f"an integer in [{LOOKDEV_SIZES[0]}, {LOOKDEV_SIZES[1]}]",
               ints(*LOOKDEV_SIZES), ("lookdev",), defaults={"lookdev": str(LOOKDEV_SIZE)}, metavar="PX",
               group=OUTPUT),
    OptionSpec("samples", "samples per pixel", f"an integer in [{LOOKDEV_SAMPLING[0]}, {LOOKDEV_SAMPLING[1]}]",
               ints(*LOOKDEV_SAMPLING), ("lookdev",), defaults={"lookdev": str(LOOKDEV_SAMPLES)}, group=SCENE),
    OptionSpec("columns", "tiles per row", f"an integer in [1, {MAX_COLUMNS}]", ints(1, MAX_COLUMNS),
               ("gallery", "lookdev"), defaults={"gallery": "a square grid", "lookdev": "a square grid"},
               group=OUTPUT),
)
OUTPUT_OPTIONS = (
    OptionSpec("output", "output stem: writes PATH.png, PATH.exr and PATH.json",
               "a file path stem in a writable folder (STEM.png, STEM.exr and STEM.json are written)", as_given,
               ("render",), defaults={"render": "out/PRESET"}, metavar="PATH", group=OUTPUT),
    OptionSpec("output", "the contact sheet: writes STEM.png, STEM.exr and STEM.json",
               "a file path stem in a writable folder (STEM.png, STEM.exr and STEM.json are written)", as_given,
               ("gallery",), defaults={"gallery": "out/gallery.png"}, metavar="PATH", group=OUTPUT),
    OptionSpec("output", "the sheet: writes STEM.png and STEM.json", "a file path (.png, or a stem) in a writable "
               "folder", as_given, ("lookdev",), defaults={"lookdev": "out/lookdev.png"}, metavar="PATH",
               group=OUTPUT),
    OptionSpec("name", "a name recorded in the sidecar", NAME_ALLOWED, lambda name, value: check_name(value, name),
               ("render",),
               metavar="TEXT", group=OUTPUT, text=True),
)
BATCH_OPTIONS = (
    OptionSpec("jobfile", "the jobs: a .toml ([defaults] and [[job]] tables) or .json file", "the path of a "
               ".toml or .json job file", as_given, ("batch",), metavar="JOBFILE", positional=True, job=False),
    OptionSpec("jobs", "parallel jobs on a local Dask cluster of single-threaded workers",
               f"an integer in [{BATCH_JOBS[0]}, {BATCH_JOBS[1]}]; 1 with --scheduler", ints(*BATCH_JOBS),
               ("batch",), defaults={"batch": "1: serial"}, job=False),
    OptionSpec("scheduler", "run the jobs as tasks on a Dask scheduler's workers", "a scheduler's address, e.g. "
               "tcp://host:8786", plain_text, ("batch",), metavar="ADDRESS", job=False),
    OptionSpec("output_dir", "folder of relative job outputs; other paths in a job are relative to the job file",
               "a folder path", as_given, ("batch",), defaults={"batch": "out/batch"}, metavar="DIR", job=False,
               group=OUTPUT),
    OptionSpec("timeout", "stop a job after this long (seconds)", f"a number in [{BATCH_TIMEOUT[0]:g}, "
               f"{BATCH_TIMEOUT[1]:g}]", floats(*BATCH_TIMEOUT), ("batch",), defaults={"batch": "none"},
               metavar="SECONDS", job=False),
    OptionSpec("report", "also write the results as JSON", "the path of a .json file that is no job's input or "
               "output", as_given, ("batch",), metavar="FILE.json", job=False, group=OUTPUT),
)
RUN_OPTIONS = (
    OptionSpec("verbose", "show Blender's own log", "", switch, ("render", "gallery", "lookdev", "fit"),
               action="store_true", job=False, group=OUTPUT),
    OptionSpec("progress", "no progress bar", "", switch, ("lookdev", "batch", "fit"), action="store_false",
               flag_name="--no-progress", job=False, group=OUTPUT),
)


GROUP_ORDER = (None, MATERIAL, FIT_TARGET, FIT_START, SCENE, OUTPUT)  # --help's sections: ungrouped first


def table() -> tuple[OptionSpec, ...]:
    """Every option, in the order ``--help`` lists them within a group."""
    return RENDER_OPTIONS + SCENE_OPTIONS + SHEET_OPTIONS + OUTPUT_OPTIONS + BATCH_OPTIONS + FIT_OPTIONS + RUN_OPTIONS


def _join_allowed() -> None:
    """Every message names what an option allows (an option declared for two ranges: each command's own
    validator names its range; a value no option takes, the first declared)."""
    OPTION_ALLOWED.update({s.name: s.allowed for s in reversed(table()) if s.allowed})


_join_allowed()


def options_of(command: str, options: tuple[OptionSpec, ...] | None = None) -> tuple[OptionSpec, ...]:
    """The options that ``command`` takes (of ``options``; by default every option of the table), group by
    group as ``--help`` lists them (:data:`GROUP_ORDER`), in the table's order within a group."""
    taken = [s for s in (table() if options is None else options) if command in s.commands]
    return tuple(sorted(taken, key=lambda s: GROUP_ORDER.index(s.group)))


def scene_options_of(command: str) -> tuple[OptionSpec, ...]:
    """The scene's options (:data:`SCENE_OPTIONS`: backend, samples, sun...) that ``command`` takes."""
    return options_of(command, SCENE_OPTIONS)


def names_of(command: str) -> tuple[str, ...]:
    """The names of ``command``'s options (their ``dest`` on the command line, their keys elsewhere)."""
    return tuple(s.name for s in options_of(command))


def job_options() -> tuple[str, ...]:
    """The options a job of a job file (and ``render``'s request) may hold."""
    return tuple(s.name for s in options_of("render") if s.job)


def add_options(parser: argparse.ArgumentParser, command: str) -> dict[str, Any]:
    """``command``'s options of the table on ``parser``, each with its range (and default) in ``--help``,
    in their groups; returns the groups by name (a command adds its parameters' options to them)."""
    groups: dict[str, Any] = {}
    for s in options_of(command):
        where = parser if s.group is None else groups.get(s.group) or groups.setdefault(
            s.group, parser.add_argument_group(s.group))
        kwargs: dict[str, Any] = dict(help=s.help_for(command).replace("%", "%%"))
        if s.action is not None:
            where.add_argument(s.flag, dest=s.name, action=s.action, **kwargs)
            continue
        kwargs["default"] = None
        if s.choices is not None:
            kwargs["choices"] = s.choices
        elif not s.positional:
            kwargs["metavar"] = s.metavar
        if s.nargs is not None:
            kwargs["nargs"] = s.nargs
        if s.positional:
            where.add_argument(s.name, metavar=s.metavar, **kwargs)
        else:
            where.add_argument(s.flag, dest=s.name, **kwargs)
    return groups


def read_options(command: str, options: Mapping[str, Any]) -> dict[str, Any]:
    """``command``'s table options present in ``options``, each read (validated); ParameterError naming the
    first that is not."""
    return {s.name: s.read(options[s.name]) for s in options_of(command) if options.get(s.name) is not None}
