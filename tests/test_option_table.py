"""The scene options are declared once (cli/option_table.py): an option added to the table alone is taken by
every command that declares it, on the command line (with its range in --help) and in job files, read and
checked the same way, and reproduced by a request's arguments."""
from __future__ import annotations

import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli import gallery, option_table, requests
from layered_brdf_addon.cli.option_table import OptionSpec, options_of
from layered_brdf_addon.cli.option_values import allowed_for, int_option
from layered_brdf_addon.model.params import ParameterError

THROWAWAY = OptionSpec("bounces", "light bounces in the scene", "an integer in [0, 64]",
                       lambda name, value: int_option(name, value, 0, 64), ("render", "gallery"),
                       defaults={"render": "8"})


@pytest.fixture
def with_throwaway(monkeypatch):
    """The table with one option more, and what is made from it at import made again."""
    monkeypatch.setattr(option_table, "SCENE_OPTIONS", option_table.SCENE_OPTIONS + (THROWAWAY,))
    monkeypatch.setitem(option_table.OPTION_ALLOWED, THROWAWAY.name, THROWAWAY.allowed)  # joined at import


def test_every_command_that_declares_an_option_takes_it_with_its_range_in_help(with_throwaway, capsys):
    for command in ("render", "gallery"):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "--bounces N light bounces in the scene; an integer in [0, 64]" in text, command
    with pytest.raises(SystemExit):
        cli.main(["lookdev", "--help"])
    assert "--bounces" not in capsys.readouterr().out


def test_a_job_file_and_the_command_line_read_it_the_same_way(with_throwaway, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    req = requests.request_from_options({"preset": "oil_slick", "bounces": "12", "output": "x"})
    assert req.scene_options["bounces"] == 12
    assert req.to_argv()[req.to_argv().index("--bounces") + 1] == "12"
    assert gallery.settings_from_options({"bounces": 3, "output": str(tmp_path / "g.png")}).scene_options["bounces"] == 3
    with pytest.raises(ParameterError, match=r"'bounces'.*\[0, 64\]"):
        requests.request_from_options({"preset": "oil_slick", "bounces": 65, "output": "x"})
    assert allowed_for("bounces") == "an integer in [0, 64]"


def test_the_table_s_options_are_each_command_s_own():
    assert [s.name for s in options_of("render")] == ["backend", "samples", "sun", "sun_strength", "seed", "threads"]
    assert set(requests.run_options()) >= {s.name for s in options_of("render")}
    assert requests.reference_only() == ("sun", "sun_strength")


def test_readme_s_table_of_scene_options_is_the_table():
    """README lists each scene option with what it sets and allows, as the table declares them."""
    from pathlib import Path

    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    start = readme.index("| option | what | allowed |")
    rows = [line for line in readme[start:].splitlines()[2:] if line.startswith("| `--")]
    listed = {row.split("|")[1].strip().strip("`"): row for row in rows}
    assert list(listed) == [s.flag for s in option_table.SCENE_OPTIONS]
    for s in option_table.SCENE_OPTIONS:
        cells = [c.strip() for c in listed[s.flag].replace("\\|", "PIPE").split("|")[1:-1]]  # README escapes a pipe in a cell
        assert cells[1:] == [s.help, s.allowed.replace("|", "PIPE")], s.name
