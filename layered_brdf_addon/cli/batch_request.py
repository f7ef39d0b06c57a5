"""Validating a ``batch`` request without Blender: the job file read into render requests (every job checked,
every output target probed) and how the jobs run.  :func:`batch_request_from_options` takes the options of
``layered-brdf batch`` as a mapping (from the command line or a script) and returns a :class:`BatchRequest`, or
raises :class:`ParameterError` naming the first invalid option.  Nothing here imports bpy.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

from ..model.params import ParameterError
from .job_files import Job, load_job_file
from .option_table import read_options
from .runner import check_report_target

DEFAULT_OUTPUT_DIR = Path("out") / "batch"


@dataclass(frozen=True)
class BatchRequest:
    """A validated batch: its jobs (each a :class:`~.requests.RenderRequest`) and how they run."""

    jobfile: Path
    jobs: list[Job]
    n_jobs: int = 1  # parallel jobs on a local cluster (1: serial)
    scheduler: str | None = None  # a Dask scheduler's address: the jobs run on its workers
    timeout: float | None = None  # seconds per job
    report: Path | None = None  # the results as JSON, written after the jobs
    progress: bool = True


def batch_request_from_options(options: Mapping[str, Any]) -> BatchRequest:
    """Validate ``batch``'s options (``jobfile``, ``jobs``, ``scheduler``, ``output_dir``, ``timeout``,
    ``report``, ``progress``; names with ``_``): each value alone (the option table), then together, then
    the job file's jobs and every output they and the report would write."""
    o = {k: v for k, v in options.items() if v is not None}
    given = read_options("batch", o)
    if "jobfile" not in given:
        raise ParameterError("jobfile", None, "the path of a .toml or .json job file")
    n_jobs, scheduler = given.get("jobs", 1), given.get("scheduler")
    if scheduler is not None and n_jobs > 1:
        raise ParameterError("jobs", n_jobs, "1 with --scheduler (the cluster's workers set the parallelism)")
    report = check_report_target(given["report"]) if given.get("report") else None
    jobs = load_job_file(given["jobfile"], output_dir=given.get("output_dir") or DEFAULT_OUTPUT_DIR, report=report)
    return BatchRequest(jobfile=Path(given["jobfile"]).absolute(), jobs=jobs, n_jobs=n_jobs, scheduler=scheduler,
                        timeout=given.get("timeout"), report=report, progress=given.get("progress", True))
