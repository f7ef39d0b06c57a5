"""The asset library of looks: one material asset per preset, for Blender's Asset Browser.

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
and the file's own data is as it was.  Files are written under temporary names in the
folder (``.layered_brdf_partial_PID_*``) and put in place together: a failure puts the
previous library back, and a later build removes the temporary files of a build whose
process is gone.  A ``.blend`` of the library's name that the library did not write
(recorded with its SHA-256 in ``.layered_brdf_library.json``) is never replaced.

From a shell (or ``make assets``)::

    python -m layered_brdf_addon.blender.asset_library DIR [--presets NAME ...] [--user-presets]
        [--preview-size PX] [--samples N] [--hdri NAME]

There, as for ``render`` and ``lookdev``, SIGINT and SIGTERM end the build with exit code
130 and leave the library folder as it was (:class:`~layered_brdf_addon.cli.staging.InterruptGuard`),
and Blender's temporary files live in the process's own temp folder (:mod:`.tempdirs`).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import secrets
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..cli.staging import InterruptGuard
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

from ..model.params import ParameterError
from ..model.policy import plan_effects
from ..model.presets import ARTIST_PRESETS, PAPER_PRESETS
from . import assets
from . import material as M
from . import user_presets

LIBRARY_FILE = "Layered BRDF Looks.blend"
CATALOG_FILE = "blender_assets.cats.txt"
MANIFEST_FILE = ".layered_brdf_library.json"  # what the library wrote: file names and their SHA-256
MANIFEST_FORMAT = "layered_brdf.asset_library"
MANIFEST_VERSION = 1
LIBRARY_NAME = "Layered BRDF Looks"  # its name in Preferences > File Paths > Asset Libraries
CATALOG_HEADER = """\
# This is an Asset Catalog Definition file for Blender.
#
# Empty lines and lines starting with `#` will be ignored.
# The first non-ignored line should be the version indicator.
# Other lines are of the format "UUID:catalog/path/for/assets:simple catalog name"

VERSION 1

"""
_TEMP_PREFIX = ".layered_brdf_partial_"
_PREVIOUS_MARK = ".previous"  # the earlier version of a library file, kept while the new one is put in place
# A build's temporary files: .layered_brdf_partial_PID_TOKEN[.previous]SUFFIX, and the file Blender writes
# first when it saves a .blend (that name and '@').
_PARTIAL = re.compile(re.escape(_TEMP_PREFIX) + r"(\d+)_[0-9a-f]{12}(" + re.escape(_PREVIOUS_MARK)
                      + r")?(\.blend|\.cats\.txt|\.json)@?")


@dataclass
class LibraryResult:
    """What :func:`write_asset_library` wrote."""

    directory: Path
    blend: Path
    catalogs: Path
    assets: dict[str, str] = field(default_factory=dict)  # asset name -> preset identifier
    preview_seconds: list[float] = field(default_factory=list)
    seconds: float = 0.0


def default_presets(include_user: bool = False) -> list[str]:
    """The presets a library holds by default: the artist presets, the paper's figures and, with
    ``include_user``, the saved user presets (``user:<name>``)."""
    names = [*ARTIST_PRESETS, *PAPER_PRESETS]
    if include_user:
        names += [user_presets.USER_PREFIX + n for n in user_presets.user_preset_names()]
    return names


def all_catalogs() -> list[assets.Catalog]:
    return [assets.ROOT_CATALOG, *assets.CATALOGS.values()]


# --- checks ---------------------------------------------------------------------------------------
def _check_presets(presets) -> list[str]:
    if presets is None:
        return default_presets()
    if isinstance(presets, (str, bytes)) or not hasattr(presets, "__iter__"):
        raise ParameterError("presets", presets, "a list of preset names (built-in names or 'user:<name>')")
    names = list(dict.fromkeys(presets))
    if not names:
        raise ParameterError("presets", presets, "at least one preset name")
    for name in names:
        if not isinstance(name, str):
            raise ParameterError("presets", name, "preset names as strings")
        assets.kind_of(name)  # a built-in preset or user:<name>, else ParameterError naming 'preset'
        user_presets.preset_params(name)  # a user preset that exists and is valid
    return names


def _check_directory(directory) -> Path:
    if isinstance(directory, bytes) or not isinstance(directory, (str, os.PathLike)) or not str(directory):
        raise ParameterError("directory", directory, "a folder path (str or os.PathLike)")
    path = Path(directory).expanduser().absolute()
    if path.exists() and not path.is_dir():
        raise ParameterError("directory", str(directory), "a folder (this path is a file)")
    if not path.exists() and not path.parent.is_dir():
        raise ParameterError("directory", str(directory), "a folder that exists, or whose parent folder exists")
    target = path if path.exists() else path.parent
    if not os.access(target, os.W_OK | os.X_OK):
        raise ParameterError("directory", str(directory), "a folder you may write to")
    return path


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def read_manifest(directory: Path) -> dict | None:
    """The library's record in ``directory`` (None when there is none); ParameterError when a file
    of that name is not one the library wrote."""
    path = directory / MANIFEST_FILE
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        data = None
    if not isinstance(data, dict) or data.get("format") != MANIFEST_FORMAT \
            or not isinstance(data.get("files"), dict):
        raise ParameterError("directory", str(directory), f"a folder whose {MANIFEST_FILE} was written by the "
                             "Layered BRDF asset library (this one was not; move it or choose another folder)")
    return data


def _owned_hashes(directory: Path) -> list[str]:
    """The SHA-256 of the library .blend that may be replaced: [] when there is none; ParameterError
    when the one there is not the library's (or was changed since the library wrote it)."""
    blend = directory / LIBRARY_FILE
    if not blend.exists() and not blend.is_symlink():
        return []
    manifest = read_manifest(directory)
    accepted = manifest["files"].get(LIBRARY_FILE, []) if manifest else []
    current = _sha256(blend) if blend.is_file() and not blend.is_symlink() else None
    if current is None or current not in accepted:
        why = "it was changed since" if manifest else "there is no record of it"
        raise ParameterError("directory", str(directory), f"a folder without a '{LIBRARY_FILE}' that the "
                             f"Layered BRDF asset library did not write (the one there is not its own: {why}); "
                             "move that file or choose another folder")
    return [current]


# --- the catalog file -----------------------------------------------------------------------------
def parse_catalogs(text: str) -> dict[str, tuple[str, str]]:
    """The catalogs of a ``blender_assets.cats.txt`` text: UUID -> (path, simple name).

    ParameterError (naming ``directory``) when the text is not a catalog file of VERSION 1."""
    catalogs: dict[str, tuple[str, str]] = {}
    version = None
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if version is None:
            if line != "VERSION 1":
                raise ParameterError("directory", line[:60], f"a folder whose {CATALOG_FILE} is a Blender "
                                     "catalog file of 'VERSION 1'")
            version = 1
            continue
        parts = line.split(":", 2)
        if len(parts) < 2:
            raise ParameterError("directory", line[:60], f"a folder whose {CATALOG_FILE} has lines "
                                 "'UUID:catalog/path:simple name'")
        catalogs[parts[0].strip()] = (parts[1].strip(), parts[2].strip() if len(parts) > 2 else "")
    return catalogs


def read_catalogs(path) -> dict[str, tuple[str, str]]:
    """The catalogs of the catalog file ``path``: UUID -> (path, simple name)."""
    return parse_catalogs(Path(path).read_text(encoding="utf-8"))


def catalog_text(existing: str | None) -> str:
    """The catalog file: ``existing`` (another tool's catalogs and comments kept as they are,
    lines with the library's UUIDs replaced) with the library's catalogs."""
    ours = all_catalogs()
    if existing is None:
        return CATALOG_HEADER + "".join(c.line() + "\n" for c in ours)
    parse_catalogs(existing)  # a VERSION 1 catalog file, else ParameterError
    uuids = {c.uuid for c in ours}
    kept = [line for line in existing.splitlines() if line.split(":", 1)[0].strip() not in uuids]
    while kept and not kept[-1].strip():
        kept.pop()
    return "\n".join(kept) + "\n" + "".join(c.line() + "\n" for c in ours)


# --- writing ------------------------------------------------------------------------------------
def _partial_name(directory: Path, suffix: str) -> Path:
    """A temporary name in ``directory`` carrying this process's id, so that a later build can
    tell the files of a build that died from those of one still running."""
    return directory / f"{_TEMP_PREFIX}{os.getpid()}_{secrets.token_hex(6)}{suffix}"


def _temp_path(directory: Path, suffix: str) -> Path:
    """A new empty file in ``directory`` under a temporary name (permissions as the umask gives)."""
    while True:
        path = _partial_name(directory, suffix)
        try:
            with open(path, "x"):
                return path
        except FileExistsError:
            continue


def stale_partials(directory) -> list[Path]:
    """The temporary files in ``directory`` of builds whose process no longer runs (killed while
    writing, a crash): regular files named as a build names them, never anything else."""
    try:
        entries = list(Path(directory).iterdir())
    except OSError:
        return []
    out = []
    for p in entries:
        m = _PARTIAL.fullmatch(p.name)
        if m is None or p.is_symlink() or not p.is_file():
            continue
        pid = int(m.group(1))
        if pid != os.getpid() and not tempdirs.pid_running(pid):
            out.append(p)
    return sorted(out)


def remove_stale_partials(directory) -> list[Path]:
    """Remove :func:`stale_partials`; returns what was removed (errors are ignored)."""
    removed = []
    for p in stale_partials(directory):
        with contextlib.suppress(OSError):
            p.unlink()
            removed.append(p)
    return removed


def _manifest_text(hashes: list[str], names: dict[str, str]) -> str:
    return json.dumps({"format": MANIFEST_FORMAT, "version": MANIFEST_VERSION, "files": {LIBRARY_FILE: hashes},
                       "assets": names, "catalogs": {c.uuid: c.path for c in all_catalogs()}},
                      indent=2, sort_keys=True) + "\n"


class _Staging:
    """The build's own files in the library folder while it writes: its temporary files, and the
    folder itself when the build made it.

    Each temporary file is registered as it is created, before anything is written to it, so a
    failed write (a full disk) leaves nothing: :meth:`discard` removes them all after a failure,
    and from the interrupt guard's clean-up when a signal ends the process.  Every step holds
    the guard's I/O lock, so that clean-up never finds a file half made or half renamed.
    """

    def __init__(self, directory: Path, guard: InterruptGuard | None = None):
        self.directory = directory
        self.guard = guard
        self.files: list[Path] = []
        self.made_folder = False

    def io(self):
        """The guard's I/O lock (nothing without a guard): held while files are made or renamed."""
        return self.guard.io() if self.guard is not None else contextlib.nullcontext()

    def check(self) -> None:
        """KeyboardInterrupt when the guard has received a signal."""
        if self.guard is not None:
            self.guard.check()

    def make_folder(self) -> None:
        with self.io():
            if not self.directory.exists():
                self.directory.mkdir()
                self.made_folder = True

    def new(self, suffix: str) -> Path:
        """A new empty temporary file, registered for removal."""
        with self.io():
            path = _temp_path(self.directory, suffix)
            self.files.append(path)
        return path

    def text(self, text: str, suffix: str) -> Path:
        """A new temporary file holding ``text``."""
        with self.io():
            path = self.new(suffix)
            path.write_text(text, encoding="utf-8")
        return path

    def keep_previous(self, final: Path, suffix: str) -> Path | None:
        """A second name for the library file ``final`` (a hard link; a copy where the file system
        has none) while the new one is put in place; None when there is no such file."""
        if not os.path.lexists(final):
            return None
        with self.io():
            while True:
                backup = _partial_name(self.directory, _PREVIOUS_MARK + suffix)
                try:
                    os.link(final, backup, follow_symlinks=False)
                except FileExistsError:
                    continue
                except OSError:
                    shutil.copy2(final, backup, follow_symlinks=False)
                return backup

    def discard(self, folder: bool = True) -> None:
        """Remove the temporary files (and Blender's own temporary file of each) and, with
        ``folder``, the folder when this build made it and it is empty."""
        with self.io():
            for path in self.files:
                for p in (path, path.with_name(path.name + "@")):
                    with contextlib.suppress(OSError):
                        p.unlink()
            if folder and self.made_folder:
                with contextlib.suppress(OSError):
                    self.directory.rmdir()


def _commit(staged: _Staging, blend_tmp: Path, cats_tmp: Path, old_hashes: list[str], new_hash: str,
            names: dict[str, str]) -> None:
    """Put the new library in place, all of it or nothing.

    The record is placed first accepting both the old and the new .blend, so that a process
    killed between the renames leaves a library the next build still recognises as its own;
    the files it replaces are kept under second names until the last rename.  Any failure, and
    an interrupt received meanwhile (the guard waits for the lock), puts the previous files
    back (or removes the new ones where there were none) before the exception goes on.
    """
    directory = staged.directory
    manifest, blend, cats = directory / MANIFEST_FILE, directory / LIBRARY_FILE, directory / CATALOG_FILE
    with staged.io():
        staged.check()
        pending = staged.text(_manifest_text(old_hashes + [new_hash], names), ".json")
        final = staged.text(_manifest_text([new_hash], names), ".json")
        previous: dict[Path, Path | None] = {}
        placed: list[Path] = []
        try:
            for target, suffix in ((manifest, ".json"), (blend, ".blend"), (cats, ".cats.txt")):
                previous[target] = staged.keep_previous(target, suffix)
            for tmp, target in ((pending, manifest), (blend_tmp, blend), (cats_tmp, cats), (final, manifest)):
                os.replace(tmp, target)
                placed.append(target)
            staged.check()
        except BaseException:
            _put_back(previous, placed)
            raise
        for backup in previous.values():
            if backup is not None:
                with contextlib.suppress(OSError):
                    backup.unlink()


def _put_back(previous: dict[Path, Path | None], placed: list[Path]) -> None:
    """Undo a commit: each placed file gets its earlier version back (or is removed where it had
    none); the second names of files not placed yet are dropped.  The record goes last."""
    for target in sorted(previous, key=lambda p: p.name == MANIFEST_FILE):
        backup = previous[target]
        with contextlib.suppress(OSError):
            if target not in placed:
                if backup is not None:
                    backup.unlink()
            elif backup is not None:
                os.replace(backup, target)
            else:
                target.unlink()


class _Registered:
    """The add-on registered for the duration (the materials need its settings); left as found."""

    def __enter__(self):
        from . import properties, registration

        self.registered = False
        if not hasattr(bpy.types.Material, properties.SETTINGS):
            registration.register()
            self.registered = True
        return self

    def __exit__(self, *exc):
        if self.registered:
            from . import registration

            registration.unregister()
        return False


def _unique_names(identifiers: list[str]) -> dict[str, str]:
    """Asset name -> identifier; a user preset named like a built-in look gets ' (user preset)'."""
    names: dict[str, str] = {}
    for ident in identifiers:
        name = assets.look_name(ident)
        if name in names:
            name = f"{name} (user preset)"
        if name in names:
            raise ParameterError("presets", ident, f"presets whose names differ ('{name}' twice)")
        names[name] = ident
    return names


def _make_looks(names: dict[str, str], made: list, step) -> None:
    """A material asset per look, named exactly so (a material of the file holding that name is
    renamed for the moment by the caller), appended to ``made`` as it is made."""
    from . import properties

    for name, ident in names.items():
        params = user_presets.preset_params(ident)
        mat = bpy.data.materials.new(name)
        made.append(mat)
        mat.node_tree.nodes.clear()  # the default Principled BSDF is not part of the look
        mat[M.MATERIAL_KEY] = True
        properties._apply(mat, params, "nodes", plan_effects(params), preview=False)
        properties.settings(mat).preset = ident
        if mat.name != name:
            raise RuntimeError(f"the look '{name}' was named '{mat.name}'")
        assets.mark_look(mat, ident)
        step()


def write_asset_library(directory, presets=None, preview_size: int = assets.PREVIEW_SIZE,
                        samples: int = assets.PREVIEW_SAMPLES, hdri: str | None = None,
                        progress=None, guard: InterruptGuard | None = None) -> LibraryResult:
    """Write the looks library into ``directory``: ``Layered BRDF Looks.blend`` (a material asset
    per preset of ``presets``, default :func:`default_presets`) and ``blender_assets.cats.txt``.

    ``preview_size`` is the previews' size in pixels (0: no previews), rendered with ``samples``
    per pixel under the bundled HDRI ``hdri``.  The folder is made when only it is missing.
    Re-running replaces the library's own files; a ``.blend`` of that name the library did not
    write is never replaced, and a folder (or anything but a file) under one of the library's
    file names is refused (ParameterError naming ``directory``, nothing made or written).
    Temporary files left in the folder by a build whose process is gone are removed.
    ``progress(done, total)`` is called as looks are made and previews rendered.  With an
    interrupt ``guard`` (the command line's), a signal ends the process at once with the
    folder as it was: the temporary files are removed and the previous library stays whole.
    """
    t0 = time.perf_counter()
    identifiers = _check_presets(presets)
    if preview_size != 0:
        from .lookdev import hdri_path

        assets.check_preview_options(preview_size, samples)
        hdri_path(hdri)  # a bundled HDRI, else ParameterError naming 'hdri'
        if bpy.app.is_job_running("RENDER"):
            raise ParameterError("preview_size", preview_size, "0 while a render is running "
                                 "(previews are Cycles renders): wait for the render to finish")
    path = _check_directory(directory)
    names = _unique_names(identifiers)
    _existing(path)  # refused now, before anything is made, when the folder holds files not ours
    remove_stale_partials(path)

    result = LibraryResult(directory=path, blend=path / LIBRARY_FILE, catalogs=path / CATALOG_FILE, assets=names)
    before_groups = {g.as_pointer() for g in bpy.data.node_groups}
    before_texts = {t.as_pointer() for t in bpy.data.texts}
    renamed = []  # the file's own materials holding a look's name, renamed for the moment
    made = []
    staged = _Staging(path, guard)
    total = len(names) * (2 if preview_size else 1)
    count = [0]

    def step(*_):
        count[0] += 1
        if progress is not None:
            progress(count[0], total)

    if guard is not None:
        guard.add_cleanup(staged.discard)
    try:
        with _Registered():
            for name in names:
                other = bpy.data.materials.get(name)
                if other is not None and other.library is None:
                    other.name = f"{name} (set aside by the Layered BRDF library)"
                    renamed.append((other, name))
            _make_looks(names, made, step)
            if preview_size:
                result.preview_seconds = assets.render_previews(made, preview_size, samples, hdri, done=step,
                                                                guard=guard)
            staged.check()
            with staged.io():
                staged.make_folder()
                # Read again just before writing: the folder may have changed during the renders
                # (say the catalogs were edited in Blender's Asset Browser).
                old_hashes, cats = _existing(path)
                blend_tmp = staged.new(".blend")
                bpy.data.libraries.write(str(blend_tmp), set(made), fake_user=True, compress=True)
                new_hash = _sha256(blend_tmp)
                cats_tmp = staged.text(cats, ".cats.txt")
                _commit(staged, blend_tmp, cats_tmp, old_hashes, new_hash, names)
    except BaseException:
        staged.discard(folder=True)
        raise
    finally:
        staged.discard(folder=False)
        if guard is not None:
            guard.remove_cleanup(staged.discard)
        try:
            _remove_made(made, before_groups, before_texts)
        finally:
            for mat, name in renamed:
                mat.name = name
    result.seconds = time.perf_counter() - t0
    return result


def _check_library_files(path: Path) -> None:
    """ParameterError naming ``directory`` and the path when one of the library's file names in
    the folder is taken by a folder or anything else that is not a file: found before anything
    is rendered, rather than when the new files are put in place."""
    for name in (LIBRARY_FILE, CATALOG_FILE, MANIFEST_FILE):
        target = path / name
        if target.is_dir():
            raise ParameterError("directory", str(path), f"a folder whose {name} is a file ('{target}' is a "
                                 "folder: move it or choose another folder)")
        if target.exists() and not target.is_file():
            raise ParameterError("directory", str(path), f"a folder whose {name} is a regular file ('{target}' "
                                 "is a FIFO, a device or a socket: move it or choose another folder)")


def _existing(path: Path) -> tuple[list[str], str]:
    """What the folder holds now: the hashes of a library .blend that may be replaced and the
    catalog file to write (its other catalogs kept).  ParameterError naming ``directory`` when one
    of the library's file names is not a file, the .blend there is not the library's or the
    catalog file is not one of VERSION 1."""
    if not path.exists():
        return [], catalog_text(None)
    _check_library_files(path)
    old_hashes = _owned_hashes(path)
    cats = path / CATALOG_FILE
    if not cats.is_file():
        return old_hashes, catalog_text(None)
    try:
        text = cats.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError("directory", str(path), f"a folder whose {CATALOG_FILE} is readable UTF-8 text "
                             f"({e})") from None
    return old_hashes, catalog_text(text)


def _remove_made(made, before_groups: set, before_texts: set) -> None:
    """Remove the looks made for the library and the add-on data only they used."""
    for mat in made:
        try:
            bpy.data.materials.remove(mat)
        except ReferenceError:
            continue
    while True:
        stale = [g for g in bpy.data.node_groups if g.as_pointer() not in before_groups and g.library is None
                 and g.users == 0]
        if not stale:
            break
        bpy.data.node_groups.remove(stale[0])
    for t in [t for t in bpy.data.texts if t.as_pointer() not in before_texts and t.users == 0]:
        bpy.data.texts.remove(t)


# --- Preferences > File Paths > Asset Libraries --------------------------------------------------
def registered_library(directory):
    """The asset library of Blender's preferences whose folder is ``directory``, or None."""
    target = os.path.realpath(os.fspath(directory))
    for lib in bpy.context.preferences.filepaths.asset_libraries:
        if lib.path and os.path.realpath(bpy.path.abspath(lib.path)) == target:
            return lib
    return None


def register_library(directory, name: str = LIBRARY_NAME):
    """Add ``directory`` to Preferences > File Paths > Asset Libraries (unless it is there);
    returns ``(library, added)``.  The preferences are saved with Blender's own rules (on quit
    when auto-save is on)."""
    path = Path(directory)
    if not path.is_dir():
        raise ParameterError("directory", str(directory), "an existing folder")
    lib = registered_library(path)
    if lib is not None:
        return lib, False
    prefs = bpy.context.preferences
    lib = prefs.filepaths.asset_libraries.new(name=name, directory=str(path.absolute()))
    prefs.is_dirty = True
    return lib, True


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
