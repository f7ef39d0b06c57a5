"""The command line run as a separate process, as a farm or a shell would run it."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path


def start_cli(*args, cwd: Path, env: dict | None = None) -> subprocess.Popen:
    """``python -m layered_brdf_addon ARGS`` started in ``cwd``, its output captured."""
    return subprocess.Popen([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd,
                            env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})},
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def stop(proc: subprocess.Popen) -> None:
    """Kill ``proc`` if it still runs."""
    if proc.poll() is None:
        proc.kill()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            pass


def interrupt_once_started(proc: subprocess.Popen, started: Path, timeout: float = 120.0) -> tuple[str, float]:
    """Wait until ``started`` exists (the render is under way), press Ctrl+C, wait for the
    process to end: its standard error and the seconds it took to end after the signal."""
    deadline = time.monotonic() + timeout
    while not started.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(0.5)
    assert proc.poll() is None, "the render ended before it could be interrupted"
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    return err, time.monotonic() - t0
