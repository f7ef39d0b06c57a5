"""Temporary folders the add-on owns: named after the owner process, removed when done,
swept when their owner died without removing them (kill -9, a crash, a power cut).

Every folder is ``layered_brdf_KIND_PID_XXXXXXXX`` in the system temp folder (``TMPDIR``):
``osl`` (an OSL compile: Cycles writes its ``.osl``/``.oso`` files there), ``aov`` (the
extra passes of an OSL render), ``preview`` (the renders of asset previews) and ``run`` (a
command-line render's or library build's own temp folder: Blender's session folder
``blender_*`` and everything else the process writes goes under it).  :func:`sweep_stale`
removes those whose PID no longer runs.  Nothing here imports bpy.
"""
from __future__ import annotations

import atexit
import contextlib
import functools
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Iterator

PREFIX = "layered_brdf_"
KINDS = ("osl", "aov", "run", "preview")
_OWNED = re.compile(PREFIX + r"(" + "|".join(KINDS) + r")_(\d+)_[A-Za-z0-9_]+")
TEMP_ENV = ("TMPDIR", "TEMP", "TMP")

_process_dir: Path | None = None


def owned_dir(kind: str, parent: str | os.PathLike | None = None) -> Path:
    """A new folder ``layered_brdf_KIND_PID_*`` (in ``parent``, default the temp folder)."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, not {kind!r}")
    return Path(tempfile.mkdtemp(prefix=f"{PREFIX}{kind}_{os.getpid()}_", dir=parent))


def owner_pid(path: str | os.PathLike) -> int | None:
    """The PID in an owned folder's name; None for any other name."""
    m = _OWNED.fullmatch(Path(path).name)
    return int(m.group(2)) if m else None


def pid_running(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, as another user
        return True
    return True


def stale_dirs(root: str | os.PathLike | None = None) -> list[Path]:
    """Owned folders in ``root`` (default the temp folder) whose process no longer runs."""
    root = Path(root or tempfile.gettempdir())
    try:
        entries = list(root.iterdir())
    except OSError:
        return []
    out = []
    for p in entries:
        pid = owner_pid(p)
        if pid is not None and pid != os.getpid() and not pid_running(pid) and p.is_dir() and not p.is_symlink():
            out.append(p)
    return sorted(out)


def sweep_stale(root: str | os.PathLike | None = None) -> list[Path]:
    """Remove :func:`stale_dirs`; returns what was removed (errors are ignored)."""
    removed = []
    for p in stale_dirs(root):
        shutil.rmtree(p, ignore_errors=True)
        if not p.exists():
            removed.append(p)
    return removed


@contextlib.contextmanager
def private_tempdir(kind: str) -> Iterator[Path]:
    """A new owned folder that is Python's ``tempfile`` folder inside the block, removed after.

    For code that puts files into :func:`tempfile.gettempdir` and does not remove them
    (Cycles' OSL compiler): everything it writes goes into the folder, which goes away.
    """
    folder = owned_dir(kind)
    saved = tempfile.tempdir
    tempfile.tempdir = str(folder)
    try:
        yield folder
    finally:
        tempfile.tempdir = saved
        shutil.rmtree(folder, ignore_errors=True)


@contextlib.contextmanager
def owned_tempdir(kind: str, guard=None) -> Iterator[Path]:
    """A new owned folder for the block (stale folders of dead processes swept first), removed after it.

    With an interrupt ``guard`` (:class:`~layered_brdf_addon.io.staging.InterruptGuard`) the
    folder is also removed by the guard's clean-up when a signal ends the process inside the
    block; a process killed outright leaves it to the next sweep.
    """
    sweep_stale()
    folder = owned_dir(kind)
    remove = functools.partial(shutil.rmtree, folder, ignore_errors=True)
    if guard is not None:
        guard.add_cleanup(remove)
    try:
        yield folder
    finally:
        remove()
        if guard is not None:
            guard.remove_cleanup(remove)


def enter_process_tempdir() -> Path | None:
    """Give this process its own temp folder, removed at exit; sweep stale ones first.

    Call it before the first ``import bpy`` of a command-line render or library build:
    Blender creates its session folder (``blender_*``) in ``TMPDIR`` when it starts, so it
    and everything else the process writes there ends up in ``layered_brdf_run_PID_*``,
    which goes away at exit, in :func:`remove_process_tempdir` (an interrupt's clean-up)
    or, when the process was killed, in the next run's sweep.  Where bpy is already loaded
    (the add-on in Blender, tests), only sweeps.  Returns the folder (None where not made).
    """
    global _process_dir
    sweep_stale()
    if _process_dir is not None:
        return _process_dir
    if "bpy" in sys.modules:
        return None
    folder = owned_dir("run")
    for name in TEMP_ENV:
        if name == "TMPDIR" or name in os.environ:
            os.environ[name] = str(folder)
    tempfile.tempdir = str(folder)
    _process_dir = folder
    atexit.register(remove_process_tempdir)
    return folder


def remove_process_tempdir() -> None:
    """Remove this process's temp folder (made by :func:`enter_process_tempdir`), if any."""
    if _process_dir is not None:
        shutil.rmtree(_process_dir, ignore_errors=True)
