"""Job files: the render requests of a TOML or JSON file, validated without Blender."""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..io.staging import TargetError, check_targets
from ..model.params import ParameterError
from .input_files import read_table_file, same_file
from .option_values import check_name, short_name, shown
from .requests import RenderRequest, reference_only, request_from_options


@dataclass
class Job:
    """One entry of a job file: its options, and the validated request or why it is invalid."""

    index: int
    name: str
    options: dict[str, Any]
    request: RenderRequest | None = None
    error: str | None = None


def load_job_file(path: str | os.PathLike, output_dir: str | os.PathLike | None = None,
                  report: str | os.PathLike | None = None) -> list[Job]:
    """Jobs of a TOML or JSON job file.

    TOML: an optional ``[defaults]`` table and ``[[job]]`` tables.  JSON: a list of
    jobs, or ``{"defaults": {...}, "jobs": [...]}``.  Defaults for the reference
    scene's sun do not apply to jobs that render a .blend.  Every job has the options of
    ``render`` (``d_min = 80``, ``sun = [1, -1, 1]``, ...) and an optional ``name``
    (a name, not a path).  Every job's outputs stay inside ``output_dir`` (default: the
    current folder).

    A file that cannot be read or has no list of jobs raises :class:`ParameterError`,
    and so do outputs that the jobs share or that would replace the job file, another
    job's input or the ``report`` (:func:`check_batch_targets`); a job with invalid
    options (its outputs replacing its own params file included) is returned with its
    ``error`` set (it fails alone).
    """
    p = Path(path)
    allowed = "a readable .toml or .json job file with a list of jobs ([[job]] tables), at most 1 MiB"
    data: Any = read_table_file(p, "jobfile", allowed)
    defaults: Any = {}
    if isinstance(data, dict):
        extra = set(data) - {"defaults", "job", "jobs"}
        if extra:
            keys = ", ".join(short_name(k) for k in sorted(extra, key=str)[:10])
            raise ParameterError("jobfile", str(p), f"{allowed}; unknown top-level keys: {keys}")
        defaults = data.get("defaults", {})
        data = data.get("job", data.get("jobs"))
    if not isinstance(defaults, dict):
        raise ParameterError("defaults", shown(defaults), "a table of render options")
    if not isinstance(data, list) or not data:
        raise ParameterError("jobfile", str(p), allowed)
    out_dir = Path(output_dir) if output_dir is not None else Path.cwd()
    jobs: list[Job] = []
    seen: dict[str, int] = {}
    for k, entry in enumerate(data):
        if not isinstance(entry, dict):
            raise ParameterError(f"job[{k}]", shown(entry), "a table of render options")
        inherited = dict(defaults)
        if "blend" in entry or "blend" in defaults:
            for key in reference_only():  # a .blend uses its own lights
                inherited.pop(key, None)
        options = {**inherited, **entry}
        explicit = options.get("name")
        name_error = None
        if explicit is not None:
            try:
                check_name(explicit)
            except ParameterError as e:
                name_error, explicit = str(e), None
        base = explicit if explicit else (
            options["preset"] if _is_name(options.get("preset")) else f"job{k + 1}")
        name = base
        if name in seen:
            if explicit:
                raise ParameterError("name", explicit, "a name no other job in the file has")
            name = f"{base}-{k + 1}"
        seen[name] = k
        options["name"] = name
        job = Job(k, name, options, error=name_error)
        if name_error is None:
            try:
                job.request = request_from_options(options, base_dir=p.parent.absolute(), output_dir=out_dir,
                                                   confine=True)
            except ParameterError as e:
                job.error = str(e)
        jobs.append(job)
    check_batch_targets(jobs, p, report=report)
    return jobs


def _is_name(value: Any) -> bool:
    try:
        check_name(value)
        return True
    except ParameterError:
        return False


def _identities(path: Path) -> set[Any]:
    """What writing (or reading) ``path`` touches: its resolved path and, if it exists, its inode."""
    ids: set[Any] = {os.path.realpath(path)}
    try:
        st = os.stat(path)
        ids.add((st.st_dev, st.st_ino))
    except OSError:
        pass
    return ids


def check_batch_targets(jobs: list[Job], jobfile: str | os.PathLike, report: str | os.PathLike | None = None) -> None:
    """Refuse a batch whose outputs collide, before anything renders.

    Raises :class:`ParameterError` (naming ``output`` and both jobs, or ``report``) when
    two jobs would write the same file (paths resolved: ``sub/../x``, symlinked folders
    and hard links are seen through), when a job's output would replace the job file or
    another job's params file or .blend, and when the report would replace any input
    or output, or cannot be written.
    """
    jobfile = Path(jobfile)
    inputs: list[tuple[str, Path]] = [("the job file", jobfile)]
    for job in jobs:
        if job.request is not None:
            for label, p in (("params file", job.request.params_file), (".blend", job.request.blend)):
                if p is not None:
                    inputs.append((f"the {label} of job '{job.name}'", p))
    input_ids: dict[Any, str] = {}
    for label, p in inputs:
        for i in _identities(p):
            input_ids.setdefault(i, f"{label} ({p})")
    written: dict[Any, tuple[str, Path]] = {}
    for job in jobs:
        if job.request is None:
            continue
        for f in job.request.paths.all():
            for i in _identities(f):
                if i in input_ids:
                    raise ParameterError("output", str(f), f"outputs that replace no input (job '{job.name}' "
                                         f"would write {f.name} over {input_ids[i]})")
                other = written.get(i)
                if other is not None and other[0] != job.name:
                    raise ParameterError("output", str(f), f"a different output for each job (jobs '{other[0]}' "
                                         f"and '{job.name}' would both write {f})")
                written[i] = (job.name, f)
    if report is None:
        return
    report = Path(report)
    allowed = "a .json file that is neither an input nor an output of the batch, in a writable folder"
    try:
        check_targets([report])
    except TargetError as e:
        raise ParameterError("report", str(report), f"{allowed}; {e}") from None
    for i in _identities(report):
        if i in input_ids:
            raise ParameterError("report", str(report), f"{allowed} (it would replace {input_ids[i]})")
        if i in written:
            raise ParameterError("report", str(report), f"{allowed} (it would replace {written[i][1]}, an output "
                                 f"of job '{written[i][0]}')")
    for label, p in inputs:  # hard links and symlinks to an input
        if same_file(report, p):
            raise ParameterError("report", str(report), f"{allowed} (it would replace {label} {p})")
