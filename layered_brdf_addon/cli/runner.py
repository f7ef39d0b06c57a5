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

from ..io.sidecar import to_jsonable
from ..io.staging import OutputPaths, remove_stale_temps
from ..model.params import ParameterError
from .job_files import Job


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
            try:
                client.close(timeout=CONNECT_TIMEOUT)
            except Exception:
                pass
        if cluster is not None:
            cluster.close()
    return [results[j.index] for j in jobs]


CONNECT_TIMEOUT = 10.0  # seconds to reach a scheduler and get its answer
NO_WORKER_GRACE = 60.0  # seconds without a worker (or the scheduler) before the jobs left are given up


def _scheduler_error(address: str, why: str) -> ParameterError:
    return ParameterError("scheduler", address, f"the address of a running Dask scheduler, e.g. "
                          f"tcp://host:8786 (--scheduler: {why})")


def probe_scheduler(address: str, timeout: float = CONNECT_TIMEOUT) -> dict[str, Any]:
    """Ask ``address`` who it is, within ``timeout`` seconds in all; return the scheduler's identity.

    Dask's own client trusts the peer: an HTTP server's reply reads as a frame length of
    exabytes (MemoryError), and a server that accepts and never answers keeps it waiting
    past its connect timeout.  This asks once, under one deadline, and raises
    :class:`ParameterError` naming ``--scheduler`` for anything but a Dask scheduler.
    """
    import asyncio
    import logging

    from distributed.comm import connect

    async def ask() -> Any:
        comm = await connect(address, timeout=timeout)
        try:
            await comm.write({"op": "identity", "n_workers": 0, "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(logging.CRITICAL)  # its errors would print tracebacks of the garbage it read
    try:
        reply = asyncio.run(asyncio.wait_for(ask(), timeout))
    except (asyncio.TimeoutError, TimeoutError):
        raise _scheduler_error(address, f"no answer from it within {timeout:g} s") from None
    except MemoryError:
        raise _scheduler_error(address, "it answered, but not in Dask's protocol (is it an HTTP server?)") from None
    except ValueError as e:
        raise _scheduler_error(address, f"not a valid address: {e}") from None
    except Exception as e:  # refused, reset, closed, unreadable reply: all "not a scheduler"
        raise _scheduler_error(address, f"{e.__class__.__name__}: {e}".rstrip(": ")) from None
    finally:
        log.setLevel(level)
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        kind = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise _scheduler_error(address, f"it answered as {kind!r}, not as a Dask scheduler")
    return reply


def _connect(scheduler: str | None, n_jobs: int):
    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        probe_scheduler(scheduler)
        try:
            return Client(scheduler, timeout=f"{CONNECT_TIMEOUT:g}s"), None
        except Exception as e:
            raise _scheduler_error(scheduler, f"{e.__class__.__name__}: {e}") from None
    import logging
    import warnings

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*[Pp]ort .* already in use.*")
        cluster = LocalCluster(n_workers=n_jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _cluster_state(client) -> tuple[bool, int]:
    """(the scheduler answered, its number of workers), asking with a short deadline."""
    if client.status not in ("running", "connecting"):
        return False, 0
    try:
        info = client.sync(client.scheduler.identity, n_workers=0, callback_timeout=5.0)
        return True, int(info.get("n_workers", 0))
    except Exception:
        return False, 0


def _run_on_dask(jobs: Sequence[Job], client, *, timeout: float | None, poll: float = 0.25):
    """Submit every job as a Dask task; yield ``(job, result)`` as they complete.

    Every few seconds the scheduler is asked how many workers it has: after
    ``min(timeout, NO_WORKER_GRACE)`` seconds with none (all died or left) or without an
    answer from the scheduler, the jobs not done are given up (status ``cancelled``).  A
    worker that dies while others live costs nothing: Dask reruns its tasks elsewhere.
    """
    token = uuid.uuid4().hex[:8]
    futures = {}
    grace = min(timeout, NO_WORKER_GRACE) if timeout is not None else NO_WORKER_GRACE
    try:
        for job in jobs:
            fut = client.submit(run_job, job.name, job.request.to_argv(), str(job.request.output), timeout,
                                key=f"layered-brdf-{token}-{job.index}", pure=False, retries=0)
            futures[fut] = job
        pending = list(futures)
        trouble_since: float | None = None
        next_check = time.monotonic() + 2.0
        while pending:
            done = [f for f in pending if f.done()]
            for fut in done:
                pending.remove(fut)
                job = futures[fut]
                try:
                    res = fut.result()
                except Exception as e:  # the worker died or the task could not run
                    remove_stale_temps(job.request.output)
                    res = JobResult(job.name, "crashed", error=f"{e.__class__.__name__}: {e}")
                yield job, res
            if done or not pending:
                continue
            now = time.monotonic()
            if now >= next_check:
                answered, n_workers = _cluster_state(client)
                now = time.monotonic()
                next_check = now + 2.0
                if answered and n_workers > 0:
                    trouble_since = None
                else:
                    trouble_since = trouble_since if trouble_since is not None else now
                    if now - trouble_since >= grace:
                        why = (f"no Dask worker alive for {grace:g} s (all died or left)" if answered
                               else f"no answer from the Dask scheduler for {grace:g} s")
                        print(f"layered-brdf: error: {why}; {len(pending)} job(s) not run", file=sys.stderr)
                        if answered:
                            try:
                                client.cancel(pending, force=True)
                            except Exception:
                                pass
                        for fut in pending:
                            job = futures[fut]
                            remove_stale_temps(job.request.output)
                            yield job, JobResult(job.name, "cancelled", error=f"not run: {why}")
                        return
            time.sleep(poll)
    except BaseException:
        try:
            client.cancel(list(futures), force=True)
        except Exception:
            pass
        for job in jobs:
            remove_stale_temps(job.request.output)
        raise


def check_report_target(text: str | os.PathLike) -> Path:
    """The absolute path of ``--report``, checked before any job runs.

    It must end in .json, must not be a folder, and its folder must exist (or be
    creatable under an existing folder) and take a new file: a probe file is created
    and removed there.  Raises :class:`ParameterError` naming ``--report``.
    """
    import tempfile

    path = Path(text).absolute()

    def bad(why: str) -> ParameterError:
        return ParameterError("report", str(text), f"a writable .json file path (--report: {why})")

    if path.suffix.lower() != ".json":
        raise ParameterError("report", str(text), "a path ending in .json (--report)")
    if path.is_dir():
        raise bad(f"{path} is a folder")
    if path.exists() and not path.is_file():
        raise bad(f"{path} is not a regular file")
    folder = path.parent
    while not folder.exists():
        folder = folder.parent
    if not folder.is_dir():
        raise bad(f"{folder} is not a folder")
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=f".{path.name}.", suffix=".probe"):
            pass
    except OSError as e:
        raise bad(f"cannot create a file in {folder}: {e.strerror or e}") from None
    return path


def write_report(path: str | os.PathLike, data: Any) -> None:
    """Write the JSON report atomically: a temporary file in the same folder, renamed over ``path``.

    A reader sees the old report or the complete new one, never a partial file; on an
    error nothing is left but the old report (OSError is raised).
    """
    import tempfile

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(json.dumps(to_jsonable(data), indent=2) + "\n")
            f.flush()
            os.fsync(f.fileno())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp's 0600 -> what a plain open() would give
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def exit_code(results: Iterable[JobResult]) -> int:
    """0 when every job rendered, else 1."""
    return 0 if all(r.ok for r in results) else 1
