"""Job files: the render requests of a TOML or JSON file, validated without Blender."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..model.params import ParameterError
from .requests import REFERENCE_ONLY, RenderRequest, read_table_file, request_from_options


@dataclass
class Job:
    """One entry of a job file: its options, and the validated request or why it is invalid."""

    index: int
    name: str
    options: dict[str, Any]
    request: RenderRequest | None = None
    error: str | None = None


def load_job_file(path: str | os.PathLike, output_dir: str | os.PathLike | None = None) -> list[Job]:
    """Jobs of a TOML or JSON job file.

    TOML: an optional ``[defaults]`` table and ``[[job]]`` tables.  JSON: a list of
    jobs, or ``{"defaults": {...}, "jobs": [...]}``.  Defaults for the reference
    scene's sun do not apply to jobs that render a .blend.  Every job has the options of
    ``render`` (``d_min = 80``, ``sun = [1, -1, 1]``, ...) and an optional ``name``.
    A file that cannot be read or has no list of jobs raises :class:`ParameterError`;
    a job with invalid options is returned with its ``error`` set (it fails alone).
    """
    p = Path(path)
    allowed = "a readable .toml or .json job file with a list of jobs ([[job]] tables)"
    data: Any = read_table_file(p, "jobfile", allowed)
    defaults: Any = {}
    if isinstance(data, dict):
        extra = set(data) - {"defaults", "job", "jobs"}
        if extra:
            raise ParameterError("jobfile", str(p), f"{allowed}; unknown top-level keys: {', '.join(sorted(extra))}")
        defaults = data.get("defaults", {})
        data = data.get("job", data.get("jobs"))
    if not isinstance(defaults, dict):
        raise ParameterError("defaults", defaults, "a table of render options")
    if not isinstance(data, list) or not data:
        raise ParameterError("jobfile", str(p), allowed)
    jobs: list[Job] = []
    seen: dict[str, int] = {}
    for k, entry in enumerate(data):
        if not isinstance(entry, dict):
            raise ParameterError(f"job[{k}]", entry, "a table of render options")
        inherited = dict(defaults)
        if "blend" in entry or "blend" in defaults:
            for key in REFERENCE_ONLY:  # a .blend uses its own lights
                inherited.pop(key, None)
        options = {**inherited, **entry}
        explicit = options.get("name")
        base = explicit if isinstance(explicit, str) and explicit else (
            options.get("preset") if isinstance(options.get("preset"), str) else f"job{k + 1}")
        name = base
        if name in seen:
            if isinstance(explicit, str) and explicit:
                raise ParameterError("name", explicit, "a name no other job in the file has")
            name = f"{base}-{k + 1}"
        seen[name] = k
        options["name"] = name
        job = Job(k, name, options)
        try:
            job.request = request_from_options(options, base_dir=p.parent.absolute(), output_dir=output_dir)
        except ParameterError as e:
            job.error = str(e)
        jobs.append(job)
    stems: dict[Path, str] = {}
    for job in jobs:
        if job.request is None:
            continue
        other = stems.get(job.request.output)
        if other is not None:
            raise ParameterError("output", str(job.request.output),
                                 f"a different output for each job ('{other}' and '{job.name}' share it)")
        stems[job.request.output] = job.name
    return jobs
