"""The looks library's folder on disk: its file names, the record of what the library wrote
(``.layered_brdf_library.json``: the SHA-256 of each .blend it wrote), and writing the files
under temporary names first, then putting them in place all together or not at all.

A ``.blend`` of the library's name that the library did not write is never replaced; the
temporary files of a build whose process is gone are removed by the next build.

Plain Python: imports no bpy.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import secrets
import shutil
from pathlib import Path

from ..io.staging import InterruptGuard
from ..model.params import ParameterError
from . import tempdirs
from .catalogs import CATALOG_FILE, all_catalogs, catalog_text

LIBRARY_FILE = "Layered BRDF Looks.blend"
MANIFEST_FILE = ".layered_brdf_library.json"  # what the library wrote: file names and their SHA-256
MANIFEST_FORMAT = "layered_brdf.asset_library"
MANIFEST_VERSION = 1
_TEMP_PREFIX = ".layered_brdf_partial_"
_PREVIOUS_MARK = ".previous"  # the earlier version of a library file, kept while the new one is put in place
# A build's temporary files: .layered_brdf_partial_PID_TOKEN[.previous]SUFFIX, and the file Blender writes
# first when it saves a .blend (that name and '@').
_PARTIAL = re.compile(re.escape(_TEMP_PREFIX) + r"(\d+)_[0-9a-f]{12}(" + re.escape(_PREVIOUS_MARK)
                      + r")?(\.blend|\.cats\.txt|\.json)@?")


# --- what the folder holds -------------------------------------------------------------------------
def check_directory(directory) -> Path:
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


def sha256(path: Path) -> str:
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


def owned_hashes(directory: Path) -> list[str]:
    """The SHA-256 of the library .blend that may be replaced: [] when there is none; ParameterError
    when the one there is not the library's (or was changed since the library wrote it)."""
    blend = directory / LIBRARY_FILE
    if not blend.exists() and not blend.is_symlink():
        return []
    manifest = read_manifest(directory)
    accepted = manifest["files"].get(LIBRARY_FILE, []) if manifest else []
    current = sha256(blend) if blend.is_file() and not blend.is_symlink() else None
    if current is None or current not in accepted:
        why = "it was changed since" if manifest else "there is no record of it"
        raise ParameterError("directory", str(directory), f"a folder without a '{LIBRARY_FILE}' that the "
                             f"Layered BRDF asset library did not write (the one there is not its own: {why}); "
                             "move that file or choose another folder")
    return [current]



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


def read_folder(path: Path) -> tuple[list[str], str]:
    """What the folder holds now: the hashes of a library .blend that may be replaced and the
    catalog file to write (its other catalogs kept).  ParameterError naming ``directory`` when one
    of the library's file names is not a file, the .blend there is not the library's or the
    catalog file is not one of VERSION 1."""
    if not path.exists():
        return [], catalog_text(None)
    _check_library_files(path)
    old_hashes = owned_hashes(path)
    cats = path / CATALOG_FILE
    if not cats.is_file():
        return old_hashes, catalog_text(None)
    try:
        text = cats.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ParameterError("directory", str(path), f"a folder whose {CATALOG_FILE} is readable UTF-8 text "
                             f"({e})") from None
    return old_hashes, catalog_text(text)


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



class Staging:
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


def commit(staged: Staging, blend_tmp: Path, cats_tmp: Path, old_hashes: list[str], new_hash: str,
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
