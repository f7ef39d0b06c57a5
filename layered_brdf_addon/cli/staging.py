"""Atomic output staging: a render's files appear together or not at all.

Every output is written under a temporary name in its final folder and renamed when
all files of the set are complete, so a reader never sees a partial PNG, EXR or
sidecar; :class:`InterruptGuard` makes Ctrl-C and SIGTERM stop a render at once and
leave nothing behind.  Nothing here imports bpy.
"""
from __future__ import annotations

import contextlib
import os
import re
import signal
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterable

OUTPUT_SUFFIXES = (".png", ".exr", ".json")
_TEMP_MARK = ".tmp"


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


def stale_temps(stem: str | os.PathLike) -> list[Path]:
    """Temporary files of the outputs of ``stem`` left by a process that was killed.

    Matches this module's temporary names (``.NAME.tmpPID.SUFFIX``) and the
    ``..NAME.tmpPID.partialPID.exr`` names Blender's EXR writer uses for them.
    """
    stem = Path(stem)
    folder = stem.parent
    if not folder.is_dir():
        return []
    pattern = re.compile(r"\.{1,2}" + re.escape(stem.name) + re.escape(_TEMP_MARK)
                         + r"\d+(\.partial\d+)?(\.png|\.exr|\.json)(\.rewrite)?")
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
        with self._lock():
            missing = [str(t) for t in self._temps.values() if not t.exists()]
            if missing:
                raise RuntimeError("outputs were not written: " + ", ".join(missing))
            for f in self.finals:
                os.replace(self._temps[f], f)
                self.committed.append(f)
        return list(self.committed)

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
