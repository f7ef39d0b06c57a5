"""The command line run as a separate process, as a farm or a shell would run it, and what it leaves."""
from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.io.codecs import read_exr_layers

CLI_TIMEOUT = 240


def _limit_memory() -> None:  # a runaway read fails fast instead of filling the machine
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def run_cli(*args, cwd: Path, timeout: float = CLI_TIMEOUT, limit_memory: bool = False) -> subprocess.CompletedProcess:
    """``python -m layered_brdf_addon ARGS`` run to its end in ``cwd``, its output captured; a hang
    past ``timeout`` fails the test.  ``limit_memory``: at most 4 GiB of address space."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    try:
        return subprocess.run([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=timeout,
                              preexec_fn=_limit_memory if limit_memory else None)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{' '.join(map(str, args))} did not end within {timeout} s")


def files_under(folder: Path) -> list[str]:
    """The paths under ``folder`` (none where it does not exist), relative to it, sorted."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def beauty(path: Path) -> np.ndarray:
    """The Combined pass (RGB) of an EXR the command line wrote."""
    layers = read_exr_layers(path)
    ch = layers["ViewLayer.Combined"]
    return np.stack([ch[f"ViewLayer.Combined.{c}"] for c in "RGB"], axis=-1).astype(np.float64)


def assert_refused(res: subprocess.CompletedProcess, name: str) -> None:
    """Exit 2, the parameter named, no traceback."""
    assert res.returncode == 2, (res.returncode, res.stderr[-3000:])
    assert f"'{name}'" in res.stderr, res.stderr[-3000:]
    assert "Traceback" not in res.stderr, res.stderr[-3000:]


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
