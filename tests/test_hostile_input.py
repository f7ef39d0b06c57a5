"""Hostile and careless input on the command line: absurd values, special files, output
targets that cannot be written, outputs that would replace inputs or each other, job
names and outputs that leave the output folder, negative numbers.

Every case here is refused before anything renders (exit 2, or the job alone is invalid),
so most tests are fast; the few that render are marked slow.
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli.gallery import settings_from_options
from layered_brdf_addon.cli import input_files, job_files
from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.cli.requests import load_params_file, parse_sun, request_from_options
from layered_brdf_addon.cli.staging import OutputPaths, StagedOutputs, temp_path
from layered_brdf_addon.model.params import PARAM_SPECS, ParameterError

TIMEOUT = 120
FAKE_BLEND = b"BLENDER-v500" + b"\x00" * 64  # passes the header check; never rendered here
NESTED = 50  # lists nested this deep are read, then refused value by value
DEEPER = 400_000  # past what any parser should follow: the whole file is refused
HUGE_INT = int("9" * 400)


def _limit_memory():  # a runaway read fails fast instead of filling the machine
    resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))


def run_cli(*args, cwd: Path, timeout: float = TIMEOUT, limit_memory: bool = False) -> subprocess.CompletedProcess:
    """``python -m layered_brdf_addon ARGS`` in ``cwd``; a hang past ``timeout`` fails the test."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    try:
        return subprocess.run([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=timeout,
                              preexec_fn=_limit_memory if limit_memory else None)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{' '.join(map(str, args))} did not end within {timeout} s")


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def assert_refused(res: subprocess.CompletedProcess, name: str) -> None:
    """Exit 2, the parameter named, no traceback."""
    assert res.returncode == 2, (res.returncode, res.stderr[-3000:])
    assert f"'{name}'" in res.stderr, res.stderr[-3000:]
    assert "Traceback" not in res.stderr, res.stderr[-3000:]


def deep_json(n: int = NESTED) -> str:
    return "[" * n + "]" * n


# ---------------------------------------------------------------------------
# 10. valid JSON/TOML, absurd values
ABSURD_JSON = {"huge_int": "9" * 400, "huge_float": "1e400", "deep": deep_json()}
ABSURD_TOML = {"huge_int": "9" * 400, "huge_float": "1e400", "deep": deep_json()}


@pytest.mark.parametrize("kind", sorted(ABSURD_JSON))
@pytest.mark.parametrize("fmt", ["json", "toml"])
def test_absurd_value_in_a_params_file_exits_2_naming_it(tmp_path, fmt, kind):
    if fmt == "json":
        text = '{"ks": 0.5, "d_min": ' + ABSURD_JSON[kind] + "}"
    else:
        text = "ks = 0.5\nd_min = " + ABSURD_TOML[kind] + "\n"
    (tmp_path / f"mat.{fmt}").write_text(text)
    res = run_cli("render", "--params", f"mat.{fmt}", "--resolution", 16, "--output", tmp_path / "out" / "x",
                  cwd=tmp_path)
    assert_refused(res, "d_min")
    assert len(res.stderr) < 2000  # the value is summarised, not printed
    assert files_under(tmp_path / "out") == []


ABSURD_JOBS = [
    ("samples", HUGE_INT), ("seed", HUGE_INT), ("resolution", [HUGE_INT, 16]), ("sun", [HUGE_INT, 0, 1]),
    ("sun_strength", HUGE_INT), ("d_max", HUGE_INT), ("name", HUGE_INT), ("preset", HUGE_INT),
    ("samples", float("inf")), ("sun", [float("inf"), 0, 1]), ("threads", float("-inf")),
    ("samples", "deep"), ("sun", "deep"), ("output", "deep"), ("d_min", "deep"), ("params", "deep"),
    ("tilt", "x" * 500_000),
]


def _case_id(case) -> str:
    option, value = case
    text = "deep" if value == "deep" else "huge_int" if HUGE_INT in (value if isinstance(value, list) else [value]) \
        else "long_text" if isinstance(value, str) else repr(value).replace(" ", "")
    return f"{option}-{text}"


@pytest.mark.parametrize("option, value", ABSURD_JOBS, ids=[_case_id(c) for c in ABSURD_JOBS])
def test_an_absurd_job_fails_alone_naming_the_option(tmp_path, option, value):
    good = {"name": "good", "resolution": 16}
    bad = {"name": "bad", option: value}
    text = json.dumps({"jobs": [good, bad, {"name": "also_good"}]})
    if value == "deep":
        text = text.replace('"deep"', deep_json())
    (tmp_path / "jobs.json").write_text(text)
    jobs = load_job_file(tmp_path / "jobs.json", output_dir=tmp_path / "out")
    assert [j.request is not None for j in jobs] == [True, False, True]
    assert f"'{option}'" in jobs[1].error and len(jobs[1].error) < 1000, jobs[1].error[:1000]


def test_absurd_values_in_a_toml_job_file_fail_alone(tmp_path):
    (tmp_path / "jobs.toml").write_text(
        "[[job]]\nname = 'a'\nsamples = " + "9" * 400 + "\n"
        "[[job]]\nname = 'b'\nsun = [1e400, 0, 1]\n"
        "[[job]]\nname = 'c'\nd_min = " + deep_json() + "\n"
        "[[job]]\nname = 'd'\n")
    jobs = load_job_file(tmp_path / "jobs.toml", output_dir=tmp_path / "out")
    assert ["'samples'" in jobs[0].error, "'sun'" in jobs[1].error, "'d_min'" in jobs[2].error] == [True] * 3
    assert jobs[3].request is not None


def test_absurd_defaults_and_top_level_exit_2(tmp_path):
    (tmp_path / "deep.json").write_text('{"jobs": ' + deep_json() + "}")
    res = run_cli("batch", "deep.json", "--output-dir", "out", cwd=tmp_path)
    assert_refused(res, "job[0]")
    assert "= [[[...]]] is invalid" in res.stderr  # the value cut short
    (tmp_path / "deeper.json").write_text(deep_json(DEEPER))
    res = run_cli("batch", "deeper.json", "--output-dir", "out", cwd=tmp_path)
    assert_refused(res, "jobfile")
    assert "deeper.json" in res.stderr and "nested deeper than can be read" in res.stderr
    (tmp_path / "long.json").write_text('[{"samples": ' + "9" * 5000 + "}, {}]")  # more digits than int() reads
    with pytest.raises(ParameterError, match=r"'jobfile' = '.*long\.json'.*an integer too long to read"):
        load_job_file(tmp_path / "long.json", output_dir=tmp_path / "out")
    assert files_under(tmp_path / "out") == []


UNREADABLE = {"deeper": (deep_json(DEEPER), "nested deeper than can be read"),
              "long_int": ("9" * 5000, "an integer too long to read")}


@pytest.mark.parametrize("kind", sorted(UNREADABLE))
@pytest.mark.parametrize("fmt", ["json", "toml"])
def test_a_params_file_past_what_the_parsers_read_exits_2_naming_it(tmp_path, fmt, kind):
    value, why = UNREADABLE[kind]
    text = '{"ks": 0.5, "d_min": ' + value + "}" if fmt == "json" else "ks = 0.5\nd_min = " + value + "\n"
    (tmp_path / f"mat.{fmt}").write_text(text)
    res = run_cli("render", "--params", f"mat.{fmt}", "--resolution", 16, "--output", tmp_path / "out" / "x",
                  cwd=tmp_path)
    assert_refused(res, "params")
    assert f"mat.{fmt}" in res.stderr and "allowed a readable .json or .toml file" in res.stderr, res.stderr
    assert why in res.stderr and len(res.stderr) < 1000, res.stderr[-3000:]
    assert files_under(tmp_path / "out") == []


@pytest.mark.slow
def test_a_batch_with_an_absurd_job_renders_the_others_and_exits_1(tmp_path):
    (tmp_path / "jobs.json").write_text(
        '{"defaults": {"resolution": 16}, "jobs": [{"name": "deep", "d_min": ' + deep_json() + '}, '
        '{"name": "long", "samples": ' + "9" * 400 + '}, {"name": "ok"}]}')
    res = run_cli("batch", "jobs.json", "--output-dir", "out", "--report", "report.json", "--no-progress",
                  cwd=tmp_path, timeout=300)
    assert res.returncode == 1, res.stderr
    status = {r["name"]: r["status"] for r in json.loads((tmp_path / "report.json").read_text())["results"]}
    assert status == {"deep": "invalid", "long": "invalid", "ok": "ok"}
    assert files_under(tmp_path / "out") == ["ok.exr", "ok.json", "ok.png"]


# ---------------------------------------------------------------------------
# 11. special files and the size of what is read
def test_params_from_dev_zero_is_refused_without_reading_it(tmp_path):
    res = run_cli("render", "--params", "/dev/zero", "--output", tmp_path / "x", cwd=tmp_path, timeout=60,
                  limit_memory=True)
    assert_refused(res, "params")
    assert "regular file" in res.stderr
    assert files_under(tmp_path) == []


@pytest.mark.parametrize("which", ["params", "blend", "jobfile", "job_params", "job_blend"])
def test_a_fifo_is_refused_not_waited_on(tmp_path, which):
    fifo = tmp_path / ("in.blend" if "blend" in which else "in.json")
    os.mkfifo(fifo)
    if which == "params":
        args = ["render", "--params", fifo, "--output", tmp_path / "out" / "x"]
    elif which == "blend":
        args = ["render", "--blend", fifo, "--object", "Cube", "--output", tmp_path / "out" / "x"]
    elif which == "jobfile":
        args = ["batch", fifo, "--output-dir", tmp_path / "out"]
    else:
        key = which.split("_")[1]
        job = {"name": "a", key: fifo.name, **({"object": "Cube"} if key == "blend" else {})}
        (tmp_path / "jobs.json").write_text(json.dumps([job]))
        args = ["batch", "jobs.json", "--output-dir", tmp_path / "out", "--no-progress"]
    res = run_cli(*args, cwd=tmp_path, timeout=30)
    if which.startswith("job_"):  # the job is invalid, alone: exit 1 without rendering
        assert res.returncode == 1 and "Traceback" not in res.stderr, res.stderr
        assert f"'{which.split('_')[1]}'" in res.stdout and "regular file" in res.stdout, res.stdout
    else:
        assert_refused(res, "jobfile" if which == "jobfile" else which)
        assert "regular file" in res.stderr
    assert files_under(tmp_path / "out") == []


def test_params_and_job_files_are_capped_at_1_mib(tmp_path):
    MAX_INPUT_BYTES = input_files.MAX_INPUT_BYTES
    assert MAX_INPUT_BYTES == 1 << 20
    ok = tmp_path / "ok.json"
    ok.write_text('{"ks": 0.5}' + " " * (MAX_INPUT_BYTES - 11))
    assert load_params_file(ok) == {"ks": 0.5}
    big = tmp_path / "big.json"
    big.write_text('{"ks": 0.5}' + " " * (MAX_INPUT_BYTES - 10))
    with pytest.raises(ParameterError, match=r"'params'.*1 MiB"):
        load_params_file(big)
    jobs = tmp_path / "jobs.json"
    jobs.write_text('[{"name": "a"}]' + " " * MAX_INPUT_BYTES)
    with pytest.raises(ParameterError, match=r"'jobfile'.*1 MiB"):
        load_job_file(jobs, output_dir=tmp_path / "out")
    res = run_cli("render", "--params", big, "--output", tmp_path / "out" / "x", cwd=tmp_path)
    assert_refused(res, "params")
    res = run_cli("render", "--params", tmp_path, "--output", tmp_path / "out" / "x", cwd=tmp_path)
    assert_refused(res, "params")
    assert files_under(tmp_path / "out") == []


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
# 14. a sun that cannot be normalised
@pytest.mark.parametrize("xyz", [(1e200, 0, 0), (0, -1e160, 1e160), (0, 0, 0), (1e-200, 0, 0),
                                 (float("nan"), 0, 1), (float("inf"), 0, 1), ("1e400", 0, 1)])
def test_sun_that_cannot_be_normalised_is_refused(xyz):
    with pytest.raises(ParameterError, match="'sun'"):
        parse_sun(list(xyz))


def test_sun_that_can_be_normalised_is_kept():
    assert parse_sun([1e150, 0, 0]) == (1e150, 0.0, 0.0)
    assert parse_sun("-1e-3 2e-3 0") == (-1e-3, 2e-3, 0.0)


def test_sun_1e200_exits_2_naming_sun(tmp_path):
    res = run_cli("render", "--sun", "1e200", 0, 0, "--resolution", 16, "--output", tmp_path / "out" / "x",
                  cwd=tmp_path)
    assert_refused(res, "sun")
    assert files_under(tmp_path / "out") == []
    res = run_cli("gallery", "--sun", 0, "1e200", "1e200", "--output", tmp_path / "out" / "g", cwd=tmp_path)
    assert_refused(res, "sun")


# ---------------------------------------------------------------------------
# 15. negative numbers are values, for every numeric option
def _subparser(name: str):
    parser = cli.build_parser()
    return parser._subparsers._group_actions[0].choices[name]


def _numeric_options(command: str) -> list[str]:
    """Flags of the options of ``command`` that take numbers."""
    names = {"render": ["--samples", "--sun-strength", "--seed", "--threads", "--resolution"],
             "gallery": ["--samples", "--sun-strength", "--seed", "--threads", "--size", "--columns"],
             "batch": ["--jobs", "--timeout"]}[command]
    if command == "render":
        names += ["--" + s.name.replace("_", "-") for s in PARAM_SPECS if s.kind == "float"]
    return names


def _main(argv, capsys) -> tuple[int, str]:
    try:
        rc = cli.main(argv)
    except SystemExit as e:  # argparse gave up
        rc = e.code
    return rc, capsys.readouterr().err


def test_negative_numbers_parse_for_every_numeric_option():
    spec = {s.name: s for s in PARAM_SPECS}
    render = _subparser("render")
    allowed = []
    for flag in _numeric_options("render"):
        dest = flag[2:].replace("-", "_")
        for text in ("-1e2", "-.5", "-2", "-1.5E-1"):
            ns = render.parse_args([flag, text, "--output", "x"])
            assert getattr(ns, dest) is not None, (flag, text)
        s = spec.get(dest)
        if s is not None and s.min < 0:
            value = max(s.min, -1e2)
            ns = render.parse_args([flag, f"{value:e}", "--sun", "-1e0", "-2E-1", "-.3"])
            req = request_from_options({dest: getattr(ns, dest), "sun": ns.sun, "output": "x"})
            assert getattr(req.params, dest) == value and req.sun == (-1.0, -0.2, -0.3)
            allowed.append(dest)
    assert {"tilt_azimuth", "noise_phase"} <= set(allowed)
    for command in ("gallery", "batch"):
        sub = _subparser(command)
        for flag in _numeric_options(command):
            extra = ["jobs.toml"] if command == "batch" else []
            ns = sub.parse_args([*extra, flag, "-1e2"])
            assert getattr(ns, flag[2:].replace("-", "_")) is not None, (command, flag)


@pytest.mark.parametrize("command", ["render", "gallery", "batch"])
def test_out_of_range_negative_numbers_name_the_option(tmp_path, command, capsys):
    spec = {s.name: s for s in PARAM_SPECS}
    for flag in _numeric_options(command):
        dest = flag[2:].replace("-", "_")
        if dest in spec and spec[dest].min < 0:
            continue
        extra = [str(tmp_path / "jobs.toml")] if command == "batch" else []
        rc, err = _main([command, *extra, flag, "-1e2", "--output" if command != "batch" else "--output-dir",
                         str(tmp_path / "out" / "x")], capsys)
        assert rc == 2, (flag, err)
        assert "expected one argument" not in err, (flag, err)
        name = {"jobs": "jobs", "timeout": "timeout"}.get(dest, dest)
        assert f"'{name}'" in err, (flag, err)
    assert files_under(tmp_path) == []


def test_negative_scientific_azimuth_on_the_command_line(tmp_path):
    res = run_cli("render", "--tilt-azimuth", "-1e2", "--sun", "-1e0", "-2", "-3e-1", "--noise-phase", "-5E1",
                  "--d-min", "-1e1", "--output", tmp_path / "x", cwd=tmp_path)
    assert_refused(res, "d_min")  # the only invalid value: everything before it parsed


def test_names_and_objects_that_look_like_options_reach_the_render():
    req = request_from_options({"name": "-x", "output": "/tmp/layered-brdf-argv/x"})
    ns = _subparser("render").parse_args(req.to_argv())
    assert ns.name == "-x"


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
