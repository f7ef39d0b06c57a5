"""Atomic output staging: a render's files appear together or not at all.

Every output is written under a temporary name in its final folder and renamed when
all files of the set are complete, so a reader never sees a partial PNG, EXR or
sidecar; :class:`InterruptGuard` makes Ctrl-C and SIGTERM stop a render at once and
leave nothing behind.  Nothing here imports bpy.
"""
from __future__ import annotations

import contextlib
import errno
import os
import re
import signal
import stat
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

OUTPUT_SUFFIXES = (".png", ".exr", ".json")
_TEMP_MARK = ".tmp"
_BACKUP_MARK = ".old"
PID_DIGITS = 7  # Linux's largest pid_max, 4194304, has 7 digits
NAME_MAX = 255  # bytes of a file name on the usual file systems
PATH_MAX = 4096  # bytes of a path


@dataclass(frozen=True)
class OutputPaths:
    """The three files of one render: ``stem.png``, ``stem.exr`` and ``stem.json``."""

    stem: Path

    @property
    def png(self) -> Path:
        return self.stem.with_name(self.stem.name + ".png")

    @property
    def exr(self) -> Path:
        return self.stem.with_name(self.stem.name + ".exr")

    @property
    def json(self) -> Path:
        return self.stem.with_name(self.stem.name + ".json")

    def all(self) -> tuple[Path, Path, Path]:
        """EXR, PNG, sidecar: the order in which they are committed (sidecar last)."""
        return (self.exr, self.png, self.json)


def output_stem(path: str | os.PathLike) -> Path:
    """The stem of an output path: ``out/a``, ``out/a.png`` and ``out/a.exr`` all give ``out/a``."""
    p = Path(path)
    if p.suffix.lower() in OUTPUT_SUFFIXES:
        p = p.with_suffix("")
    return p


def temp_path(final: Path, pid: int | None = None) -> Path:
    """The temporary name of ``final`` while it is written: hidden, same folder, same suffix."""
    pid = os.getpid() if pid is None else pid
    return final.with_name(f".{final.stem}{_TEMP_MARK}{pid}{final.suffix}")


def backup_path(final: Path, pid: int | None = None) -> Path:
    """Where the earlier version of ``final`` waits while a set of outputs is renamed."""
    t = temp_path(final, pid)
    return t.with_name(t.stem + _BACKUP_MARK + t.suffix)


def longest_temp_name(final: Path) -> str:
    """The longest name written next to ``final`` while it is made (Blender's partial EXR of
    its temporary file), with the largest process ids: a name that fits fits them all."""
    big = "9" * PID_DIGITS
    return f"..{final.stem}{_TEMP_MARK}{big}.partial{big}{final.suffix}"


class TargetError(ValueError):
    """An output file that could not be written where it is asked for."""


FULL_DISK_ERRNOS = frozenset(n for n in (errno.ENOSPC, getattr(errno, "EDQUOT", None)) if n is not None)
PROBE_BYTES = 1 << 16  # what a probe write puts on disk: more than a full disk's last partial block


class WriteError(Exception):
    """An output file that could not be written while a render wrote it (a full disk, a
    failing device): the file, by its final name, and the reason, for a one-line message."""

    def __init__(self, path: str | os.PathLike, reason: str):
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"could not write {self.path}: {reason}")


def os_reason(e: OSError) -> str:
    """The OS's reason for a failed write, for people: a full disk (or quota) is called so."""
    text = e.strerror or str(e)
    if e.errno == errno.ENOSPC:
        return f"the disk is full ({text})"
    if e.errno in FULL_DISK_ERRNOS:
        return f"the disk quota is used up ({text})"
    return text


def write_probe(folder: str | os.PathLike, size: int = PROBE_BYTES) -> None:
    """Write ``size`` bytes to a new probe file in ``folder``, flush them to disk and remove
    the file; OSError (ENOSPC on a full disk) when the folder cannot take them now."""
    probe = Path(folder) / f"..layered-brdf-probe-{os.getpid()}-{threading.get_ident() % 100000}.tmp"
    fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
    try:
        data = memoryview(bytes(size))
        while data:
            data = data[os.write(fd, data):]
        os.fsync(fd)
    finally:
        os.close(fd)
        with contextlib.suppress(OSError):
            os.unlink(probe)


def unwritable_reason(folder: str | os.PathLike) -> str | None:
    """Why ``folder`` takes no file now (the OS's reason of a failed probe write), or None."""
    try:
        write_probe(folder)
    except OSError as e:
        return os_reason(e)
    return None


def write_error(e: OSError) -> WriteError:
    """An OSError of a write as a :class:`WriteError` naming the file it gives."""
    return WriteError(e.filename if e.filename is not None else "a file", os_reason(e))


@contextlib.contextmanager
def writing(final: str | os.PathLike, folder: str | os.PathLike | None = None) -> Iterator[None]:
    """Report a failed write of the output ``final`` as a :class:`WriteError` naming it.

    An OSError carries its own reason.  Other writers say a full disk their own way
    (OpenEXR with a RuntimeError): any other error is a failed write when a probe write
    in ``folder`` (default: ``final``'s) fails too, and is raised unchanged otherwise.
    """
    folder = Path(final).parent if folder is None else folder
    try:
        yield
    except WriteError:
        raise
    except OSError as e:
        raise WriteError(final, os_reason(e)) from None
    except Exception:
        reason = unwritable_reason(folder)
        if reason is None:
            raise
        raise WriteError(final, reason) from None


def _what_went_wrong(e: BaseException) -> str:
    text = e.args[0] if len(e.args) == 1 and isinstance(e.args[0], str) else str(e)
    return f"{e.__class__.__name__}: {text}" if text else e.__class__.__name__


@contextlib.contextmanager
def reading_back(final: str | os.PathLike, folder: str | os.PathLike) -> Iterator[None]:
    """Read back a file that Blender wrote in ``folder`` for ``final``.

    Blender's image writer reports no failed write: on a full disk it leaves a file cut
    short under the name it was given.  So a file that cannot be read back was not
    written: a :class:`WriteError` naming ``final``, with the OS's reason when a probe
    write in ``folder`` fails too (a full disk), else with what the reader said.
    """
    try:
        yield
    except WriteError:
        raise
    except Exception as e:
        reason = unwritable_reason(folder) or f"the file Blender wrote cannot be read back ({_what_went_wrong(e)})"
        raise WriteError(final, reason) from None


def _probe(folder: Path, name_length: int) -> None:
    """Create and remove a file with a name of ``name_length`` bytes in ``folder``."""
    base = f"..layered-brdf-probe-{os.getpid()}-{threading.get_ident() % 100000}-"
    name = base + "x" * max(0, name_length - len(base.encode()) - 4) + ".tmp"
    probe = folder / name
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o600)
    except OSError as e:
        if e.errno == errno.ENAMETOOLONG:
            raise TargetError(f"the file names in {folder} cannot be that long") from None
        raise TargetError(f"{folder} is not a folder this process can write to ({e.strerror or e})") from None
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass


def check_targets(finals: Iterable[str | os.PathLike]) -> list[Path]:
    """Check, before anything is rendered, that every file of ``finals`` can be written.

    Each name (with the longest temporary name made from it) must fit the file system,
    none may be an existing folder or other non-regular file, the nearest existing folder
    above each must be a folder, and a probe file (created and removed at once) must be
    writable there.  Raises :class:`TargetError` saying what is wrong; returns the
    absolute paths.  Nothing is left behind.
    """
    paths = [Path(os.path.abspath(f)) for f in finals]
    longest: dict[Path, int] = {}
    for f in paths:
        if not f.name or f.name in (".", ".."):
            raise TargetError(f"{f} is not a file name")
        n = len(os.fsencode(longest_temp_name(f)))
        if n > NAME_MAX or len(os.fsencode(f.name)) > NAME_MAX:
            raise TargetError(f"the file name {f.name[:40]}... is too long ({len(os.fsencode(f.name))} bytes; "
                              f"with its temporary names it needs at most {NAME_MAX - (n - len(os.fsencode(f.name)))})")
        if len(os.fsencode(str(f.parent / longest_temp_name(f)))) >= PATH_MAX:
            raise TargetError(f"the path {str(f)[:60]}... is too long (at most {PATH_MAX} bytes with its temporary names)")
        if os.path.lexists(f):
            if f.is_dir():
                raise TargetError(f"{f} is a folder")
            if f.exists() and not stat.S_ISREG(f.stat().st_mode):
                raise TargetError(f"{f} exists and is not a regular file")
        longest[f.parent] = max(longest.get(f.parent, 0), n)
    for folder, n in longest.items():
        existing, missing = folder, []
        while not os.path.lexists(existing):
            missing.append(existing.name)
            existing = existing.parent
        if not existing.is_dir():
            raise TargetError(f"{existing} is not a folder")
        for part in missing:
            if len(os.fsencode(part)) > NAME_MAX:
                raise TargetError(f"the folder name {part[:40]}... is too long")
        _probe(existing, n if not missing else len(os.fsencode(missing[-1])))
    return paths


def stale_temps(stem: str | os.PathLike) -> list[Path]:
    """Temporary files of the outputs of ``stem`` left by a process that was killed.

    Matches this module's temporary names (``.NAME.tmpPID.SUFFIX``), the earlier
    versions kept while a set is renamed (``.NAME.tmpPID.old.SUFFIX``) and the
    ``..NAME.tmpPID.partialPID.exr`` names Blender's EXR writer uses for them.
    """
    stem = Path(stem)
    folder = stem.parent
    if not folder.is_dir():
        return []
    pattern = re.compile(r"\.{1,2}" + re.escape(stem.name) + re.escape(_TEMP_MARK)
                         + r"\d+(\.partial\d+|" + re.escape(_BACKUP_MARK) + r")?(\.png|\.exr|\.json)(\.rewrite)?")
    return sorted(p for p in folder.iterdir() if pattern.fullmatch(p.name) and p.is_file())


def remove_stale_temps(stem: str | os.PathLike) -> list[Path]:
    """Delete :func:`stale_temps` of ``stem``; returns what was removed."""
    removed = []
    for p in stale_temps(stem):
        try:
            p.unlink()
            removed.append(p)
        except FileNotFoundError:
            pass
    return removed


class InterruptGuard:
    """Ctrl-C and SIGTERM stop a render at once and leave no partial output.

    Blender's SIGINT handler swallows Ctrl-C, and a long render runs in C with
    Python's signal handlers waiting, so :meth:`arm` installs Python handlers and a
    wake-up pipe that a watchdog thread reads: on a signal it takes :attr:`io_lock`
    (held by every step that creates, writes or renames an output file, so none is
    half done), runs the registered clean-ups and ends the process with exit code
    130.  :meth:`check` raises KeyboardInterrupt for a signal noticed between steps
    (where the watchdog cannot run).  Outside the main thread the guard does nothing.
    """

    SIGNALS = (signal.SIGINT, signal.SIGTERM)
    EXIT_CODE = 130

    def __init__(self, message: str = "interrupted; no partial output was left"):
        self.message = message
        self.received: int | None = None
        self.io_lock = threading.RLock()
        self._cleanups: list[Callable[[], None]] = []
        self._previous: dict[int, Any] = {}
        self._previous_wakeup: int | None = None
        self._pipe: tuple[int, int] | None = None
        self._thread: threading.Thread | None = None

    @staticmethod
    def _main_thread() -> bool:
        return threading.current_thread() is threading.main_thread()

    def _handle(self, signum, frame) -> None:
        self.received = signum

    def arm(self) -> "InterruptGuard":
        """Install (again: Blender may have replaced them) the handlers; start the watchdog once."""
        if not self._main_thread():
            return self
        for s in self.SIGNALS:
            prev = signal.signal(s, self._handle)
            self._previous.setdefault(s, prev)
        if self._pipe is None:
            r, w = os.pipe()
            os.set_blocking(w, False)
            self._pipe = (r, w)
            self._thread = threading.Thread(target=self._watch, name="layered-brdf-interrupt", daemon=True)
            self._thread.start()
        prev_fd = signal.set_wakeup_fd(self._pipe[1], warn_on_full_buffer=False)
        if self._previous_wakeup is None:
            self._previous_wakeup = prev_fd
        return self

    def _watch(self) -> None:
        r = self._pipe[0]
        while True:
            try:
                data = os.read(r, 1)
            except OSError:
                return
            if not data:
                return
            if data[0] in {int(s) for s in self.SIGNALS}:
                self.received = data[0]
                self.abort()

    def add_cleanup(self, fn: Callable[[], None]) -> None:
        self._cleanups.append(fn)

    def remove_cleanup(self, fn: Callable[[], None]) -> None:
        if fn in self._cleanups:
            self._cleanups.remove(fn)

    def io(self) -> threading.RLock:
        """Hold while creating, writing or renaming output files."""
        return self.io_lock

    def abort(self) -> None:
        """Clean up and end the process now (from the watchdog)."""
        self.io_lock.acquire()
        for fn in list(self._cleanups):
            try:
                fn()
            except Exception:
                pass
        try:
            os.write(2, f"layered-brdf: {self.message}\n".encode())
        finally:
            os._exit(self.EXIT_CODE)

    def check(self) -> None:
        if self.received is not None:
            raise KeyboardInterrupt(f"received signal {signal.Signals(self.received).name}")

    def disarm(self) -> None:
        if not self._main_thread():
            return
        if self._pipe is not None:
            signal.set_wakeup_fd(self._previous_wakeup if self._previous_wakeup is not None else -1)
            r, w = self._pipe
            os.close(w)
            if self._thread is not None:
                self._thread.join(timeout=1.0)
            os.close(r)
            self._pipe = self._thread = None
            self._previous_wakeup = None
        for s, prev in self._previous.items():
            signal.signal(s, prev if prev is not None else signal.SIG_DFL)
        self._previous.clear()

    def __enter__(self) -> "InterruptGuard":
        return self.arm()

    def __exit__(self, exc_type, exc, tb) -> bool:
        self.disarm()
        return False


class StagedOutputs:
    """A set of files written under temporary names and renamed together.

    Use as a context manager: write each file to :meth:`temp` (holding the guard's
    :meth:`InterruptGuard.io` lock); leaving the block normally renames them all (in
    the given order, so a sidecar listed last marks a complete set); leaving it by an
    exception, KeyboardInterrupt included, deletes them.  With a ``guard``, an abort
    by signal deletes them too.
    """

    def __init__(self, finals: Iterable[str | os.PathLike], guard: InterruptGuard | None = None):
        self.finals = [Path(f) for f in finals]
        self._temps = {f: temp_path(f) for f in self.finals}
        self.guard = guard
        self.committed: list[Path] = []

    def temp(self, final: str | os.PathLike) -> Path:
        return self._temps[Path(final)]

    def _lock(self):
        return self.guard.io() if self.guard is not None else contextlib.nullcontext()

    def __enter__(self) -> "StagedOutputs":
        with self._lock():
            for f in self.finals:
                f.parent.mkdir(parents=True, exist_ok=True)
        if self.guard is not None:
            self.guard.add_cleanup(self.discard)
        return self

    def commit(self) -> list[Path]:
        """Rename every file to its final name, or none: if a rename fails, the files
        already placed are taken back (their earlier versions restored) and the error raised."""
        with self._lock():
            missing = [str(t) for t in self._temps.values() if not t.exists()]
            if missing:
                raise RuntimeError("outputs were not written: " + ", ".join(missing))
            placed: list[tuple[Path, Path | None]] = []
            try:
                for f in self.finals:
                    backup = self._keep_earlier(f)
                    try:
                        os.replace(self._temps[f], f)
                    except BaseException:
                        if backup is not None and os.path.lexists(f):
                            os.unlink(backup)  # a second link: the file itself is untouched
                        elif backup is not None:
                            os.replace(backup, f)
                        raise
                    placed.append((f, backup))
            except BaseException:
                for f, backup in reversed(placed):
                    with contextlib.suppress(OSError):
                        if backup is not None:
                            os.replace(backup, f)
                        else:
                            os.unlink(f)
                raise
            for f, backup in placed:
                if backup is not None:
                    with contextlib.suppress(OSError):
                        os.unlink(backup)
                self.committed.append(f)
        return list(self.committed)

    @staticmethod
    def _keep_earlier(final: Path) -> Path | None:
        """A second name for the file ``final`` (if there is one) until the set is placed."""
        if not os.path.lexists(final) or os.path.isdir(final):
            return None
        backup = backup_path(final)
        with contextlib.suppress(FileNotFoundError):
            os.unlink(backup)
        try:
            os.link(final, backup, follow_symlinks=False)
        except OSError:  # no hard links here: move it aside (a moment without the file)
            os.replace(final, backup)
        return backup

    def discard(self) -> None:
        """Delete the temporary files (and Blender's partial files for them)."""
        with self._lock():
            for t in self._temps.values():
                for p in [t, *t.parent.glob(f".{t.stem}.partial*{t.suffix}"), t.with_name(t.name + ".rewrite")]:
                    try:
                        p.unlink()
                    except FileNotFoundError:
                        pass

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self.commit()
        finally:
            self.discard()
            if self.guard is not None:
                self.guard.remove_cleanup(self.discard)
        return False
