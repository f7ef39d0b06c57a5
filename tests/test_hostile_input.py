"""Hostile and careless input on the command line: absurd values, special files and the size
of what is read, a sun that cannot be normalised, negative numbers.

Every case here is refused before anything renders (exit 2, or the job alone is invalid),
so most tests are fast; the few that render are marked slow.  The output targets are
tested in test_hostile_outputs.py.
"""
from __future__ import annotations

import functools
import json
import os

import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli.input_files import MAX_INPUT_BYTES, load_params_file
from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.cli.option_values import parse_sun
from layered_brdf_addon.cli.requests import request_from_options
from layered_brdf_addon.model.params import PARAM_SPECS, ParameterError

import process_helpers
from process_helpers import assert_refused, files_under

TIMEOUT = 120
NESTED = 50  # lists nested this deep are read, then refused value by value
DEEPER = 400_000  # past what any parser should follow: the whole file is refused
HUGE_INT = int("9" * 400)

run_cli = functools.partial(process_helpers.run_cli, timeout=TIMEOUT)


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
