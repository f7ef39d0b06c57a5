"""Hostile and careless output targets on the command line: targets that cannot be written,
all or nothing at the final rename, outputs that would replace inputs or each other, job
names and outputs that leave the output folder.

Every case here is refused before anything renders (exit 2, or the job alone is invalid).
"""
from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import pytest

from layered_brdf_addon.cli import job_files
from layered_brdf_addon.cli.gallery import settings_from_options
from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.io.staging import OutputPaths, StagedOutputs
from layered_brdf_addon.model.params import ParameterError

import process_helpers
from process_helpers import assert_refused, files_under

TIMEOUT = 120
FAKE_BLEND = b"BLENDER-v500" + b"\x00" * 64  # passes the header check; never rendered here

run_cli = functools.partial(process_helpers.run_cli, timeout=TIMEOUT)


# ---------------------------------------------------------------------------
# 12. every output target checked before rendering; all or nothing at the final rename
@pytest.mark.parametrize("case", ["folder_png", "folder_json", "long_stem", "proc", "file_as_folder"])
def test_output_targets_are_checked_before_rendering(tmp_path, case):
    out = tmp_path / "out"
    out.mkdir()
    stem = out / "r"
    if case == "folder_png":
        (out / "r.png").mkdir()
    elif case == "folder_json":
        (out / "r.json").mkdir()
    elif case == "long_stem":
        stem = out / ("s" * 245)
    elif case == "proc":
        stem = Path("/proc/layered-brdf-no-such-folder/r")
    else:
        (out / "file").write_text("x")
        stem = out / "file" / "r"
    before = files_under(out)
    res = run_cli("render", "--resolution", 16, "--output", stem, cwd=tmp_path)
    assert_refused(res, "output")
    assert files_under(out) == before


def test_gallery_output_targets_are_checked_too(tmp_path):
    (tmp_path / "g.exr").mkdir()
    with pytest.raises(ParameterError, match="'output'"):
        settings_from_options({"output": tmp_path / "g"})
    with pytest.raises(ParameterError, match="'output'"):
        settings_from_options({"output": tmp_path / ("g" * 240)})


def test_a_failed_final_rename_rolls_back_the_files_already_placed(tmp_path):
    paths = OutputPaths(tmp_path / "r")
    paths.exr.write_text("old exr")
    with pytest.raises(OSError):
        with StagedOutputs(paths.all()) as st:
            for f in paths.all():
                st.temp(f).write_text("new")
            paths.png.mkdir()  # appears after the checks: the EXR is renamed first, then the PNG fails
    assert paths.exr.read_text() == "old exr"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.exr", "r.png"]
    assert paths.png.is_dir() and list(paths.png.iterdir()) == []
    # and with no earlier version: the placed files are removed
    paths.exr.unlink()
    with pytest.raises(OSError):
        with StagedOutputs(paths.all()) as st:
            for f in paths.all():
                st.temp(f).write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.png"]


def test_a_successful_commit_replaces_and_leaves_no_backup(tmp_path):
    paths = OutputPaths(tmp_path / "r")
    for f in paths.all():
        f.write_text("old")
    with StagedOutputs(paths.all()) as st:
        for f in paths.all():
            st.temp(f).write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.exr", "r.json", "r.png"]
    assert all(f.read_text() == "new" for f in paths.all())


# ---------------------------------------------------------------------------
# 13. an output never replaces an input
@pytest.mark.parametrize("case", ["params_stem", "params_json", "hard_link", "symlinked_folder", "blend"])
def test_render_never_overwrites_an_input(tmp_path, case):
    mat = tmp_path / "mat.json"
    mat.write_text('{"ks": 0.25}')
    original = mat.read_bytes()
    args = ["--params", mat]
    if case == "params_stem":
        output = tmp_path / "mat"
    elif case == "params_json":
        output = tmp_path / "mat.json"
    elif case == "hard_link":
        (tmp_path / "out").mkdir()
        os.link(mat, tmp_path / "out" / "x.json")
        output = tmp_path / "out" / "x"
    elif case == "symlinked_folder":
        (tmp_path / "link").symlink_to(tmp_path)
        output = tmp_path / "link" / "mat"
    else:
        (tmp_path / "shot.exr").write_bytes(FAKE_BLEND)
        original = FAKE_BLEND
        mat = tmp_path / "shot.exr"
        args = ["--blend", mat, "--object", "Cube"]
        output = tmp_path / "shot"
    res = run_cli("render", *args, "--resolution", 16, "--output", output, cwd=tmp_path)
    assert_refused(res, "output")
    assert mat.read_bytes() == original
    assert not (tmp_path / "mat.png").exists() and not (tmp_path / "shot.png").exists()


def test_a_job_whose_outputs_replace_its_own_params_is_invalid(tmp_path):
    (tmp_path / "m.json").write_text('{"ks": 0.25}')
    (tmp_path / "jobs.json").write_text(json.dumps([{"name": "m", "params": "m.json"}, {"name": "ok"}]))
    jobs = load_job_file(tmp_path / "jobs.json", output_dir=tmp_path)
    assert jobs[0].request is None and "'output'" in jobs[0].error and "m.json" in jobs[0].error
    assert jobs[1].request is not None


# ---------------------------------------------------------------------------
# 16. two jobs never write the same files
def test_jobs_writing_the_same_files_are_refused(tmp_path):
    out = tmp_path / "out"
    (out / "real").mkdir(parents=True)
    (out / "link").symlink_to(out / "real")
    cases = [
        ([{"name": "a", "output": "sub/../x"}, {"name": "x"}], ("a", "x")),
        ([{"name": "a", "output": "link/y"}, {"name": "b", "output": "real/y.png"}], ("a", "b")),
        ([{"name": "a", "output": "./z.exr"}, {"name": "b", "output": "z.json"}], ("a", "b")),
    ]
    for k, (jobs, names) in enumerate(cases):
        f = tmp_path / f"jobs{k}.json"
        f.write_text(json.dumps(jobs))
        with pytest.raises(ParameterError, match="'output'") as e:
            load_job_file(f, output_dir=out)
        assert all(f"'{n}'" in str(e.value) for n in names), str(e.value)
    (out / "h1.png").write_text("")
    os.link(out / "h1.png", out / "h2.png")
    f = tmp_path / "hard.json"
    f.write_text(json.dumps([{"name": "h1"}, {"name": "h2"}]))
    with pytest.raises(ParameterError, match="'h1'.*'h2'|'h2'.*'h1'"):
        load_job_file(f, output_dir=out)


def test_colliding_jobs_exit_2_and_render_nothing(tmp_path):
    (tmp_path / "jobs.json").write_text(json.dumps(
        {"defaults": {"resolution": 16}, "jobs": [{"name": "a", "output": "sub/../x"}, {"name": "x"}]}))
    res = run_cli("batch", "jobs.json", "--output-dir", "out", "--no-progress", cwd=tmp_path)
    assert_refused(res, "output")
    assert "'a'" in res.stderr and "'x'" in res.stderr
    assert files_under(tmp_path / "out") == []


# ---------------------------------------------------------------------------
# 17. every output stays in the output folder
@pytest.mark.parametrize("job, option", [
    ({"name": "../escape"}, "name"), ({"name": "/tmp/abs"}, "name"), ({"name": "a/b"}, "name"),
    ({"name": ".."}, "name"), ({"name": "."}, "name"), ({"name": ".hidden"}, "name"), ({"name": "a\\b"}, "name"),
    ({"name": "a\x00b"}, "name"), ({"name": 5}, "name"),
    ({"output": "../escape"}, "output"), ({"output": "/tmp/layered-brdf-abs/x"}, "output"),
    ({"output": "sub/../../escape"}, "output"), ({"output": "outside/x"}, "output"),
    ({"output": "~/x"}, "output"),
])
def test_job_outputs_are_confined_to_the_output_folder(tmp_path, job, option):
    out = tmp_path / "out"
    out.mkdir()
    (tmp_path / "elsewhere").mkdir()
    (out / "outside").symlink_to(tmp_path / "elsewhere")
    (tmp_path / "jobs.json").write_text(json.dumps([job, {"name": "fine"}]))
    jobs = load_job_file(tmp_path / "jobs.json", output_dir=out)
    assert jobs[0].request is None, jobs[0].request
    assert f"'{option}'" in jobs[0].error, jobs[0].error
    assert jobs[1].request is not None and jobs[1].request.output == out.resolve() / "fine"


def test_confined_outputs_inside_the_folder_are_fine(tmp_path):
    out = tmp_path / "out"
    (tmp_path / "jobs.json").write_text(json.dumps([{"name": "a", "output": "sub/a"},
                                                    {"name": "b", "output": str(out / "b.png")},
                                                    {"name": "c", "output": "sub/../c"}]))
    jobs = load_job_file(tmp_path / "jobs.json", output_dir=out)
    assert [j.request.output for j in jobs] == [out / "sub" / "a", out / "b", out / "c"]


def test_escaping_jobs_write_nothing_outside(tmp_path):
    (tmp_path / "jobs.json").write_text(json.dumps(
        {"defaults": {"resolution": 16}, "jobs": [{"name": "../escape"}, {"name": "e2", "output": "../e2"}]}))
    res = run_cli("batch", "jobs.json", "--output-dir", "out", "--no-progress", cwd=tmp_path)
    assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
    assert "0 of 2 jobs rendered" in res.stdout
    assert files_under(tmp_path) == ["jobs.json"]


# ---------------------------------------------------------------------------
# 18. a batch never overwrites its own inputs (job file, params) or outputs (report)
@pytest.mark.parametrize("case", ["job_named_like_jobfile", "report_is_a_sidecar", "report_is_the_jobfile",
                                  "report_is_a_params_file", "job_replaces_other_params", "report_is_a_folder"])
def test_batch_never_overwrites_its_inputs(tmp_path, case):
    jobs = [{"name": "a"}, {"name": "b"}]
    args = ["--output-dir", "out"]
    (tmp_path / "m.json").write_text('{"ks": 0.25}')
    if case == "job_named_like_jobfile":
        jobs.append({"name": "jobs"})
        args = ["--output-dir", "."]
    elif case == "report_is_a_sidecar":
        args += ["--report", "out/a.json"]
    elif case == "report_is_the_jobfile":
        args += ["--report", "jobs.json"]
    elif case == "report_is_a_params_file":
        jobs[0]["params"] = "m.json"
        args += ["--report", "m.json"]
    elif case == "job_replaces_other_params":
        jobs[0]["params"] = "m.json"
        jobs[1]["output"] = str(tmp_path / "m")
        args = ["--output-dir", "."]
    else:
        (tmp_path / "r.json").mkdir()
        args += ["--report", "r.json"]
    text = json.dumps({"defaults": {"resolution": 16}, "jobs": jobs})
    (tmp_path / "jobs.json").write_text(text)
    before = files_under(tmp_path)
    res = run_cli("batch", "jobs.json", *args, "--no-progress", cwd=tmp_path)
    assert_refused(res, "report" if case.startswith("report") else "output")
    assert (tmp_path / "jobs.json").read_text() == text
    assert (tmp_path / "m.json").read_text() == '{"ks": 0.25}'
    assert files_under(tmp_path) == before


def test_check_batch_targets_directly(tmp_path):
    (tmp_path / "jobs.json").write_text(json.dumps([{"name": "a"}]))
    jobs = load_job_file(tmp_path / "jobs.json", output_dir=tmp_path / "out")
    check_batch_targets = job_files.check_batch_targets
    check_batch_targets(jobs, tmp_path / "jobs.json", report=tmp_path / "report.json")
    with pytest.raises(ParameterError, match="'report'"):
        check_batch_targets(jobs, tmp_path / "jobs.json", report=tmp_path / "out" / "a.png")
    with pytest.raises(ParameterError, match="'report'"):
        check_batch_targets(jobs, tmp_path / "jobs.json", report=tmp_path / "out" / "a.json")
