"""The command line's ``batch``: job files checked without Blender, and the jobs of one file
rendered serially and on a local Dask cluster (the bad ones reported, the others rendered).

Renders run in subprocesses (as a user runs them) at 32 px with one sample.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.io.sidecar import read_sidecar
from layered_brdf_addon.model.params import ParameterError

from process_helpers import beauty, files_under, run_cli


def test_job_file_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[job]\npreset = 'x'\n")
    with pytest.raises(ParameterError, match="jobfile"):
        load_job_file(bad)
    (tmp_path / "empty.json").write_text("{}")
    with pytest.raises(ParameterError):
        load_job_file(tmp_path / "empty.json")
    dup = tmp_path / "dup.json"
    dup.write_text(json.dumps([{"name": "a", "output": "same"}, {"name": "b", "output": "same"}]))
    with pytest.raises(ParameterError, match="output"):
        load_job_file(dup, output_dir=tmp_path / "out")
    mixed = tmp_path / "mixed.json"
    mixed.write_text(json.dumps({"defaults": {"resolution": 32}, "jobs": [{"preset": "fig3_clay"},
                                                                           {"preset": "fig3_clay", "d_min": -3}]}))
    jobs = load_job_file(mixed, output_dir=tmp_path / "out")
    assert [j.name for j in jobs] == ["fig3_clay", "fig3_clay-2"]
    assert jobs[0].request.resolution == (32, 32) and jobs[0].error is None
    assert jobs[1].request is None and "d_min" in jobs[1].error
    assert not (tmp_path / "out").exists()


def test_bad_job_file_exits_2(tmp_path):
    (tmp_path / "jobs.toml").write_text("[[job]]\npreset = 'fig3_clay'\nresolution = [32\n")
    res = run_cli("batch", "jobs.toml", "--output-dir", tmp_path / "out", cwd=tmp_path, timeout=60)
    assert res.returncode == 2 and "'jobfile'" in res.stderr
    assert not (tmp_path / "out").exists()


JOBS = """
[defaults]
resolution = 32
samples = 1
sun = [0.4, -1.0, 0.5]

[[job]]
name = "clay"
preset = "fig3_clay"

[[job]]
name = "no_such"
preset = "fig9_missing"

[[job]]
name = "film_height"
preset = "fig3_thin_film"
thickness_mode = "height"
d_max = 600.0

[[job]]
name = "corrupt"
blend = "corrupt.blend"
object = "Cube"
"""


@pytest.fixture(scope="module")
def job_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("jobs")
    (d / "jobs.toml").write_text(JOBS)
    (d / "corrupt.blend").write_bytes(b"BLENDER-v500" + b"\x00" * 64)
    return d


@pytest.fixture(scope="module")
def serial_batch(job_dir):
    res = run_cli("batch", "jobs.toml", "--output-dir", "serial", "--report", "serial.json", cwd=job_dir)
    return res, json.loads((job_dir / "serial.json").read_text())


@pytest.mark.slow
def test_batch_reports_the_bad_job_and_runs_the_others(job_dir, serial_batch):
    res, report = serial_batch
    assert res.returncode == 1, res.stderr
    status = {r["name"]: r["status"] for r in report["results"]}
    assert status == {"clay": "ok", "no_such": "invalid", "film_height": "ok", "corrupt": "invalid"}
    lines = {ln.split()[0]: ln for ln in res.stdout.splitlines() if ln.strip()}
    assert "parameter 'preset' = 'fig9_missing' is invalid" in lines["no_such"]
    assert "'blend'" in lines["corrupt"] and "Blender can open" in lines["corrupt"]
    assert "serial/clay.{png,exr,json}" in lines["clay"]
    assert "2 of 4 jobs rendered, 2 failed" in res.stdout
    assert files_under(job_dir / "serial") == ["clay.exr", "clay.json", "clay.png", "film_height.exr",
                                               "film_height.json", "film_height.png"]
    side = read_sidecar(job_dir / "serial" / "film_height.json")
    assert side["name"] == "film_height" and side["params"]["d_max"] == 600.0


@pytest.mark.slow
def test_batch_on_a_local_dask_cluster_equals_the_serial_run(job_dir, serial_batch):
    res = run_cli("batch", "jobs.toml", "--jobs", 2, "--output-dir", "dask", "--report", "dask.json",
                  "--no-progress", cwd=job_dir)
    assert res.returncode == 1, res.stderr
    report = json.loads((job_dir / "dask.json").read_text())
    assert [(r["name"], r["status"]) for r in report["results"]] == \
        [(r["name"], r["status"]) for r in serial_batch[1]["results"]]
    for name in ("clay", "film_height"):
        a = beauty(job_dir / "serial" / f"{name}.exr")
        b = beauty(job_dir / "dask" / f"{name}.exr")
        # Cycles is reproducible up to float rounding of a few ray hits (also run to run).
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6)
        sa, sb = (read_sidecar(job_dir / d / f"{name}.json") for d in ("serial", "dask"))
        for key in ("params", "camera", "sun", "samples", "seed"):
            assert sa[key] == sb[key]
