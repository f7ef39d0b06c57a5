"""The command line's options are declared once (cli/option_table.py, fit's in cli/fit_options.py): an option
added to the table alone is taken by every command that declares it, on the command line (with its range in
--help), in job files and in the commands' requests, read and checked the same way, reproduced by a request's
arguments and listed in docs/options.md; no command adds an option the table does not declare."""
from __future__ import annotations

from pathlib import Path

import pytest

from layered_brdf_addon.cli import batch_request, commands as cli
from layered_brdf_addon.cli import fit_request, gallery, lookdev, option_docs, option_table, requests
from layered_brdf_addon.cli.option_spec import OptionSpec, ints
from layered_brdf_addon.cli.option_table import names_of, options_of
from layered_brdf_addon.cli.option_values import PARAM_NAMES, allowed_for
from layered_brdf_addon.model.params import ParameterError

ROOT = Path(__file__).resolve().parent.parent
COMMANDS = ("lookdev", "gallery", "render", "batch", "fit")
THROWAWAY = OptionSpec("bounces", "light bounces in the scene", "an integer in [0, 64]", ints(0, 64),
                       ("render", "gallery"), defaults={"render": "8"}, group="scene")
EVERYWHERE = OptionSpec("budget", "seconds the command may take", "an integer in [1, 99]", ints(1, 99), COMMANDS,
                        job=False)


@pytest.fixture
def with_throwaway(monkeypatch):
    """The table with two options more (one of the scene, one of every command), and what is made from it
    at import made again."""
    monkeypatch.setattr(option_table, "SCENE_OPTIONS", option_table.SCENE_OPTIONS + (THROWAWAY,))
    monkeypatch.setattr(option_table, "RUN_OPTIONS", option_table.RUN_OPTIONS + (EVERYWHERE,))
    for spec in (THROWAWAY, EVERYWHERE):
        monkeypatch.setitem(option_table.OPTION_ALLOWED, spec.name, spec.allowed)  # joined at import


def _help(command: str, capsys) -> str:
    with pytest.raises(SystemExit):
        cli.main([command, "--help"])
    return " ".join(capsys.readouterr().out.split())


def test_every_command_that_declares_an_option_takes_it_with_its_range_in_help(with_throwaway, capsys):
    for command in ("render", "gallery"):
        assert "--bounces N light bounces in the scene; an integer in [0, 64]" in _help(command, capsys), command
    assert "--bounces" not in _help("lookdev", capsys)
    for command in COMMANDS:
        assert "--budget N seconds the command may take; an integer in [1, 99]" in _help(command, capsys), command


def test_a_job_file_and_the_command_line_read_it_the_same_way(with_throwaway, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    req = requests.request_from_options({"preset": "oil_slick", "bounces": "12", "output": "x"})
    assert req.scene_options["bounces"] == 12
    assert req.to_argv()[req.to_argv().index("--bounces") + 1] == "12"
    sheet = gallery.settings_from_options({"bounces": 3, "output": str(tmp_path / "g.png")})
    assert sheet.scene_options["bounces"] == 3
    with pytest.raises(ParameterError, match=r"'bounces'.*\[0, 64\]"):
        requests.request_from_options({"preset": "oil_slick", "bounces": 65, "output": "x"})
    assert allowed_for("bounces") == "an integer in [0, 64]"
    job = tmp_path / "jobs.toml"
    job.write_text('[[job]]\nname = "a"\npreset = "oil_slick"\nbounces = 99\n[[job]]\nname = "b"\nbounces = 9\n')
    a, b = batch_request.batch_request_from_options({"jobfile": str(job)}).jobs
    assert "'bounces' = 99" in a.error and "[0, 64]" in a.error  # the job fails alone
    assert b.error is None and b.request.scene_options["bounces"] == 9
    assert "budget" not in requests.run_options()  # not a job's option: job=False


def test_every_command_s_request_checks_an_option_of_the_table(with_throwaway, tmp_path, monkeypatch, capsys):
    """The same value refused by each command's request, naming the option and its range."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "jobs.toml").write_text('[[job]]\nname = "a"\npreset = "oil_slick"\n')
    (tmp_path / "r.csv").write_text("angle_deg,channel,reflectance\n0,r,0.1\n0,g,0.1\n0,b,0.1\n")
    builders = {"gallery": gallery.settings_from_options, "lookdev": lookdev.settings_from_options,
                "batch": lambda o: batch_request.batch_request_from_options({"jobfile": "jobs.toml", **o}),
                "fit": lambda o: fit_request.fit_request_from_options({"reflectance": "r.csv", **o})}
    for command, build in builders.items():
        with pytest.raises(ParameterError, match=r"'budget'.*\[1, 99\]"):
            build({"budget": 100})
        build({"budget": 5})  # a value in range passes
    arguments = {"render": ["--preset", "oil_slick"], "gallery": [], "lookdev": [], "batch": ["jobs.toml"],
                 "fit": ["--reflectance", "r.csv"]}
    for command in COMMANDS:  # on the command line: exit code 2, nothing rendered
        assert cli.main([command, *arguments[command], "--budget", "100"]) == 2
        err = capsys.readouterr().err
        assert "'budget' = '100'" in err and "[1, 99]" in err and "(option --budget)" in err, (command, err)
    assert "| `--budget N` | seconds the command may take | an integer in [1, 99] |" in option_docs.options_markdown()


def test_no_command_takes_an_option_the_table_does_not_declare():
    """Every argument of every command's parser is an option of the table or a material parameter."""
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for command in COMMANDS:
        dests = {a.dest for a in sub.choices[command]._actions} - {"help"}
        extra = dests - set(names_of(command)) - set(PARAM_NAMES)
        assert not extra, (command, extra)
        assert set(names_of(command)) <= dests, command


def test_the_table_s_options_are_each_command_s_own():
    assert [s.name for s in option_table.scene_options_of("render")] == ["backend", "samples", "sun", "sun_strength",
                                                                         "seed", "threads"]
    assert requests.run_options() == ("preset", "params", "blend", "object", "resolution", "backend", "samples",
                                      "sun", "sun_strength", "seed", "threads", "output", "name")
    assert requests.reference_only() == ("sun", "sun_strength")
    for command in COMMANDS:
        flags = [s.flag for s in options_of(command)]
        assert len(flags) == len(set(flags)), command
        for s in options_of(command):
            assert s.help and (s.allowed or s.action), (command, s.name)


def test_docs_options_is_what_the_table_makes():
    """docs/options.md is current (python -m layered_brdf_addon.cli.option_docs writes it)."""
    assert (ROOT / "docs" / "options.md").read_text(encoding="utf-8") == option_docs.options_markdown()


def test_readme_s_table_of_scene_options_is_the_table(with_throwaway):
    """README lists each scene option with what it sets and allows, as the table declares them (the same
    command writes it), and an option added to the table joins it."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "| `--bounces` | light bounces in the scene | an integer in [0, 64] |" in \
        option_docs.readme_with_scene_options(readme)
    for spec in (THROWAWAY,):
        option_table.SCENE_OPTIONS = tuple(s for s in option_table.SCENE_OPTIONS if s is not spec)
    assert option_docs.readme_with_scene_options(readme) == readme
    assert "| `--sun-strength` | sun irradiance (W/m^2) | a number in [0, 1e+06] |" in readme
