"""Running render jobs: each in a fresh ``render`` subprocess, serially or on Dask.

bpy is not thread-safe and a crash must not take the runner down, so :func:`run_job`
renders one job in a subprocess; :func:`run_batch` runs many, serially, on a local
Dask cluster or on a Dask scheduler's workers.  Nothing here imports bpy.
"""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Sequence

from ..model.params import ParameterError
from .job_files import Job
from .staging import OutputPaths, remove_stale_temps


@dataclass
class JobResult:
    """How one job went; ``status`` is ok, invalid, failed, crashed, timeout or cancelled."""

    name: str
    status: str
    seconds: float = 0.0
    outputs: list[str] = field(default_factory=list)
    error: str = ""
    returncode: int | None = None
    command: list[str] = field(default_factory=list)
    render_seconds: float | None = None
    host: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "status": self.status, "seconds": self.seconds, "outputs": self.outputs,
                "error": self.error, "returncode": self.returncode, "command": self.command,
                "render_seconds": self.render_seconds, "host": self.host}


PARENT_ENV = "LAYERED_BRDF_PARENT_PID"


def follow_parent() -> None:
    """In a job's subprocess: get SIGTERM when the runner that started it dies (Linux).

    The runner sets ``LAYERED_BRDF_PARENT_PID``; a child whose parent is already gone
    stops at once.
    """
    expected = os.environ.get(PARENT_ENV)
    if not expected:
        return
    if sys.platform.startswith("linux"):
        import ctypes
        import signal

        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM))  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if str(os.getppid()) != expected:
        raise KeyboardInterrupt("the batch runner that started this render is gone")


def _error_from_stderr(stderr: str) -> str:
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    for ln in reversed(lines):
        if "error:" in ln:
            return ln.split("error:", 1)[1].strip()
    return lines[-1] if lines else ""


def run_job(name: str, argv: Sequence[str], stem: str, timeout: float | None = None,
            python: str | None = None) -> JobResult:
    """Run ``python -m layered_brdf_addon render ARGV`` in a subprocess and report how it went.

    A job past ``timeout`` seconds gets SIGTERM, then SIGKILL 10 s later; temporary
    files of its outputs are removed whatever happened.  This is the function Dask
    runs on its workers, so it takes and returns plain data.
    """
    cmd = [python or sys.executable, "-m", "layered_brdf_addon", "render", *argv]
    t0 = time.perf_counter()
    status, error = "ok", ""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1", PARENT_ENV: str(os.getpid())})
    try:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.terminate()
            try:
                out, err = proc.communicate(timeout=10.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                out, err = proc.communicate()
            status, error = "timeout", f"no result after {timeout:g} s"
    except BaseException:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        remove_stale_temps(stem)
        raise
    seconds = time.perf_counter() - t0
    rc = proc.returncode
    paths = OutputPaths(Path(stem))
    if status == "ok" and rc != 0:
        if rc < 0:
            detail = _error_from_stderr(err)
            status, error = "crashed", f"killed by signal {-rc}" + (f": {detail}" if detail else "")
        else:
            status, error = ("invalid" if rc == 2 else "failed"), _error_from_stderr(err) or f"exit code {rc}"
    remove_stale_temps(stem)
    render_seconds = None
    if status == "ok":
        missing = [str(p) for p in paths.all() if not p.exists()]
        if missing:
            status, error = "failed", "the render exited 0 but did not write " + ", ".join(missing)
        else:
            try:
                render_seconds = json.loads(paths.json.read_text(encoding="utf-8")).get("render_seconds")
            except (OSError, ValueError):
                render_seconds = None
    outputs = [str(paths.png), str(paths.exr), str(paths.json)] if status == "ok" else []
    return JobResult(name, status, seconds, outputs, error, rc, cmd, render_seconds, socket.gethostname())


def _progress(total: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, desc="render", unit="job", file=sys.stderr, disable=not enabled, dynamic_ncols=True)


def run_batch(jobs: Sequence[Job], *, n_jobs: int = 1, scheduler: str | None = None, timeout: float | None = None,
              progress: bool = True) -> list[JobResult]:
    """Render every valid job; invalid ones are reported without running.

    ``scheduler`` (a Dask scheduler address) runs each job as a Dask task on the
    cluster's workers; otherwise ``n_jobs`` > 1 starts a local Dask cluster of that
    many single-threaded worker processes, and 1 runs the jobs one after another.
    Results are in job order.
    """
    results: dict[int, JobResult] = {}
    runnable = [j for j in jobs if j.request is not None]
    use_dask = runnable and (scheduler is not None or n_jobs > 1)
    client, cluster = _connect(scheduler, n_jobs) if use_dask else (None, None)
    bar = _progress(len(jobs), progress)
    try:
        for job in jobs:
            if job.request is None:
                results[job.index] = JobResult(job.name, "invalid", error=job.error or "invalid options")
                bar.update(1)
        if use_dask:
            for job, res in _run_on_dask(runnable, client, timeout=timeout):
                results[job.index] = res
                bar.set_postfix_str(job.name)
                bar.update(1)
        else:
            for job in runnable:
                bar.set_postfix_str(job.name)
                results[job.index] = run_job(job.name, job.request.to_argv(), str(job.request.output), timeout)
                bar.update(1)
    finally:
        bar.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    return [results[j.index] for j in jobs]


def _connect(scheduler: str | None, n_jobs: int):
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError, ValueError) as e:
            raise ParameterError("scheduler", scheduler, "the address of a running Dask scheduler, e.g. "
                                 f"tcp://host:8786 ({e.__class__.__name__}: {e})") from None
    import logging
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Pp]ort .* already in use.*")
        cluster = LocalCluster(n_workers=n_jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _run_on_dask(jobs: Sequence[Job], client, *, timeout: float | None):
    """Submit every job as a Dask task; yield ``(job, result)`` as they complete."""
    from dask.distributed import as_completed

    token = uuid.uuid4().hex[:8]
    futures = {}
    try:
        for job in jobs:
            fut = client.submit(run_job, job.name, job.request.to_argv(), str(job.request.output), timeout,
                                key=f"layered-brdf-{token}-{job.index}", pure=False, retries=0)
            futures[fut] = job
        for fut in as_completed(list(futures)):
            job = futures[fut]
            try:
                res = fut.result()
            except Exception as e:  # the worker died or the task could not run
                remove_stale_temps(job.request.output)
                res = JobResult(job.name, "crashed", error=f"{e.__class__.__name__}: {e}")
            yield job, res
    except BaseException:
        client.cancel(list(futures), force=True)
        for job in jobs:
            remove_stale_temps(job.request.output)
        raise


def exit_code(results: Iterable[JobResult]) -> int:
    """0 when every job rendered, else 1."""
    return 0 if all(r.ok for r in results) else 1
