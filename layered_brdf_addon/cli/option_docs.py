"""docs/options.md and README's table of scene options, made from the option table: every command's options by
``--help`` section, each with what it sets, the values it allows and its default.
``python -m layered_brdf_addon.cli.option_docs`` writes both (``make generated`` too); a test fails when the
checked-in text is not what the table makes.

Nothing here imports bpy.
"""
from __future__ import annotations

import sys
from pathlib import Path

from ..io.staging import temp_path
from . import option_table
from .option_table import options_of

COMMANDS = ("lookdev", "gallery", "render", "batch", "fit")
ROOT = Path(__file__).resolve().parents[2]
DOC, README = ROOT / "docs" / "options.md", ROOT / "README.md"
SCENE_BEGIN = "<!-- the scene options: made from the option table by python -m layered_brdf_addon.cli.option_docs -->"
SCENE_END = "<!-- end of the scene options -->"
PREAMBLE = """# Command-line options

Made from the option table (`layered_brdf_addon/cli/option_table.py`, `fit`'s in `cli/fit_options.py`) by
`python -m layered_brdf_addon.cli.option_docs`; `--help`, the error messages and job files are made from the
same table.  A job file (`batch`) holds `render`'s options, with `_` in their names.  The material's
parameters (`--d-min NM`, `--tilt DEG`, ...) are `render`'s options too: `render --help` lists them with their
units and ranges, and README's *Parameters* describes them.
"""


def _cell(text: str) -> str:
    return text.replace("|", "\\|") if text else ""


def _usage(spec) -> str:
    """How the option is typed, as ``--help``'s usage line writes it."""
    if spec.action is not None:
        return f"`{spec.flag}`"
    value = "{" + ",".join(spec.choices) + "}" if spec.choices is not None else \
        " ".join(spec.metavar) if isinstance(spec.metavar, tuple) else spec.metavar
    if spec.nargs == "+":
        value = f"{value} [{value} ...]"
    if spec.positional:
        return f"`[{value}]`" if spec.nargs == "?" else f"`{value}`"
    return f"`{spec.flag} {value}`"


def options_markdown() -> str:
    """docs/options.md as the option table makes it."""
    lines = [PREAMBLE]
    for command in COMMANDS:
        lines += [f"## {command}", ""]
        groups: dict[str, list] = {}
        for spec in options_of(command):
            groups.setdefault(spec.group or "options", []).append(spec)
        for group, specs in groups.items():
            lines += [f"{group}:", "", "| option | what | allowed | default |", "| --- | --- | --- | --- |"]
            for s in specs:
                lines.append(f"| {_cell(_usage(s))} | {_cell(s.help)} | {_cell(s.allowed)} | "
                             f"{_cell(s.defaults.get(command, ''))} |")
            lines.append("")
    return "\n".join(lines)


def scene_options_markdown() -> str:
    """README's table of the scene options (``render``'s and ``gallery``'s), between its markers."""
    rows = [f"| `{s.flag}` | {_cell(s.help)} | {_cell(s.allowed)} |" for s in option_table.SCENE_OPTIONS]
    return "\n".join([SCENE_BEGIN, "| option | what | allowed |", "| --- | --- | --- |", *rows, SCENE_END])


def readme_with_scene_options(readme: str) -> str:
    """``readme`` with the text between its scene options' markers made from the table."""
    start, end = readme.index(SCENE_BEGIN), readme.index(SCENE_END) + len(SCENE_END)
    return readme[:start] + scene_options_markdown() + readme[end:]


def _write(path: Path, text: str) -> None:
    tmp = temp_path(path)
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def main() -> int:
    """Write docs/options.md and README's scene options (each file whole or not at all)."""
    _write(DOC, options_markdown())
    _write(README, readme_with_scene_options(README.read_text(encoding="utf-8")))
    print(f"wrote {DOC}, {README}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
