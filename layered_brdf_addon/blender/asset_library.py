"""The asset library of looks, one material asset per preset for Blender's Asset Browser: its
entry points for scripts (:func:`write_asset_library`) and for the command line.

:func:`write_asset_library` writes two files into a folder:

* ``Layered BRDF Looks.blend``: a material per preset (the artist presets, the paper's
  figures, and on request user presets), named for people, each carrying its preset's
  values and node group, marked as an asset with description, author, tags, catalog and a
  rendered preview (:mod:`.assets`);
* ``blender_assets.cats.txt``: the catalogs (``Layered BRDF/Artist looks``, ``.../Paper
  figures``, ``.../User presets``) in Blender's catalog file format.  An existing catalog
  file is merged: its other catalogs and comments are kept.

It runs in the current session without saving it (``bpy.data.libraries.write``), so it
works inside an artist's file: the materials it makes for the library are removed again,
and the file's own data is as it was (:mod:`.looks_library`).  Files are written under
temporary names in the folder (``.layered_brdf_partial_PID_*``) and put in place together: a
failure puts the previous library back, and a later build removes the temporary files of a
build whose process is gone.  A ``.blend`` of the library's name that the library did not
write (recorded with its SHA-256 in ``.layered_brdf_library.json``) is never replaced
(:mod:`.library_folder`).  The add-on is registered for the duration when it is not (a
script or the command line in a bare Blender), through the package's ``register()``.

From a shell (or ``make assets``)::

    python -m layered_brdf_addon.blender.asset_library DIR [--presets NAME ...] [--user-presets]
        [--preview-size PX] [--samples N] [--hdri NAME]

There, as for ``render`` and ``lookdev``, SIGINT and SIGTERM end the build with exit code
130 and leave the library folder as it was (:class:`~layered_brdf_addon.io.staging.InterruptGuard`),
and Blender's temporary files live in the process's own temp folder (:mod:`.tempdirs`).
"""
from __future__ import annotations

import contextlib
import sys

from ..io.staging import InterruptGuard
from . import tempdirs

INTERRUPTED = "interrupted; the library folder was left as it was before this build"


def _start_command_line() -> InterruptGuard:
    """The command line's interrupt guard and temp folder, set up before Blender is loaded.

    From here on SIGINT and SIGTERM end the build with exit code 130 at any moment (Blender
    would otherwise swallow Ctrl-C during a preview render and go on), and Blender's session
    folder (``blender_*``) and the previews' folder are made in this process's own
    ``layered_brdf_run_PID_*``, which the interrupt's clean-up removes (and, after a kill, the
    next run's sweep).
    """
    guard = InterruptGuard(INTERRUPTED).arm()
    guard.add_cleanup(tempdirs.remove_process_tempdir)
    tempdirs.enter_process_tempdir()
    return guard


_command_line_guard = _start_command_line() if __name__ == "__main__" else None

import bpy  # noqa: E402  (after the command line's temp folder: Blender makes its session folder when loaded)

from .. import register as register_addon, unregister as unregister_addon
from ..model.params import ParameterError
from . import assets, looks_library, user_presets
from .catalogs import CATALOG_FILE, all_catalogs, read_catalogs
from .library_folder import LIBRARY_FILE, MANIFEST_FILE, read_manifest
from .looks_library import LIBRARY_NAME, LibraryResult, default_presets, register_library, registered_library
from .stored_keys import SETTINGS

__all__ = ["CATALOG_FILE", "LIBRARY_FILE", "LIBRARY_NAME", "MANIFEST_FILE", "LibraryResult", "all_catalogs",
           "default_presets", "main", "read_catalogs", "read_manifest", "register_library", "registered_library",
           "write_asset_library"]


@contextlib.contextmanager
def _addon_registered():
    """The add-on registered for the duration (the looks carry its settings); left as found."""
    registered = False
    if not hasattr(bpy.types.Material, SETTINGS):
        register_addon()
        registered = True
    try:
        yield
    finally:
        if registered:
            unregister_addon()


def write_asset_library(directory, presets=None, preview_size: int = assets.PREVIEW_SIZE,
                        samples: int = assets.PREVIEW_SAMPLES, hdri: str | None = None,
                        progress=None, guard: InterruptGuard | None = None) -> LibraryResult:
    """Write the looks library into ``directory`` (:func:`.looks_library.write_library`), with the
    add-on registered for the duration when it is not."""
    with _addon_registered():
        return looks_library.write_library(directory, presets, preview_size=preview_size, samples=samples,
                                           hdri=hdri, progress=progress, guard=guard)


# --- command line ---------------------------------------------------------------------------------
def _parser():
    import argparse

    p = argparse.ArgumentParser(
        prog="python -m layered_brdf_addon.blender.asset_library",
        description=f"Write the Layered BRDF looks library ('{LIBRARY_FILE}' and '{CATALOG_FILE}') into DIR; "
                    "add DIR in Blender's Preferences > File Paths > Asset Libraries to drag looks onto objects.")
    p.add_argument("directory", metavar="DIR", help="the library folder (made when only it is missing)")
    p.add_argument("--presets", nargs="+", metavar="NAME",
                   help="presets to include (built-in names or 'user:<name>'; default: every built-in preset)")
    p.add_argument("--user-presets", action="store_true", help="also include every saved user preset")
    lo, hi = assets.PREVIEW_SIZE_RANGE
    p.add_argument("--preview-size", type=int, default=assets.PREVIEW_SIZE, metavar="PX",
                   help=f"preview size in pixels, {lo} to {hi}, or 0 for no previews (default {assets.PREVIEW_SIZE})")
    lo, hi = assets.PREVIEW_SAMPLES_RANGE
    p.add_argument("--samples", type=int, default=assets.PREVIEW_SAMPLES, metavar="N",
                   help=f"Cycles samples per preview pixel, {lo} to {hi} (default {assets.PREVIEW_SAMPLES})")
    p.add_argument("--hdri", default=None, metavar="NAME", help="a bundled HDRI for the previews (default forest)")
    return p


def _print_progress(done: int, total: int) -> None:
    print(f"\r{done}/{total}", end="\n" if done == total else "", file=sys.stderr, flush=True)


def main(argv=None) -> int:
    """Exit codes: 0 written, 2 invalid input (the message names the parameter), 1 another failure,
    130 interrupted by SIGINT or SIGTERM (the library folder as it was before the build)."""
    args = _parser().parse_args(argv)
    guard = _command_line_guard if _command_line_guard is not None else InterruptGuard(INTERRUPTED)
    with guard:  # armed again: loading Blender may have replaced the handlers
        presets = args.presets or default_presets()
        if args.user_presets:
            presets = list(presets) + [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]
        try:
            result = write_asset_library(args.directory, presets, preview_size=args.preview_size,
                                         samples=args.samples, hdri=args.hdri, progress=_print_progress,
                                         guard=guard)
        except ParameterError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print(f"\n{INTERRUPTED}", file=sys.stderr)
            return InterruptGuard.EXIT_CODE
        except (OSError, RuntimeError) as e:
            print(f"error: {e}", file=sys.stderr)
            return 1
    print(f"{len(result.assets)} looks in {result.blend}")
    print(f"catalogs in {result.catalogs}")
    if result.preview_seconds:
        ps = result.preview_seconds
        print(f"previews: {args.preview_size} px, {args.samples} samples, {sum(ps):.1f} s "
              f"({max(ps):.2f} s the slowest)")
    print(f"{result.seconds:.1f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main())
