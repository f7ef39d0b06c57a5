"""README and the extension manifest agree on the oldest supported Blender."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_readme_states_the_manifest_minimum_blender():
    minimum = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["blender_version_min"]
    major_minor = ".".join(minimum.split(".")[:2])
    readme = (ROOT / "README.md").read_text()
    stated = set(re.findall(r"Blender (\d+\.\d+)\+", readme))
    assert stated == {major_minor}, f"README says Blender {sorted(stated)}+, the manifest {minimum}"


MD_LINK = re.compile(r"\]\(([^)\s]+)\)")
DOC_MENTION = re.compile(r"\bdocs/[\w\-]+\.md")


def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(md: Path) -> set[str]:
    return {_slug(line.lstrip("#")) for line in md.read_text().splitlines() if line.startswith("#")}


def _markdown_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted(ROOT.glob("*/README.md"))]


def test_every_relative_link_of_the_docs_leads_somewhere():
    broken = []
    for md in _markdown_files():
        for target in MD_LINK.findall(md.read_text()):
            if re.match(r"[a-z]+:", target):
                continue  # a web address
            path, _, anchor = target.partition("#")
            dest = (md.parent / path).resolve() if path else md
            if not dest.exists():
                broken.append(f"{md.relative_to(ROOT)}: {target}")
            elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
                broken.append(f"{md.relative_to(ROOT)}: {target} (no such heading)")
    assert not broken, broken


def test_every_doc_the_code_names_exists():
    named = {(py.relative_to(ROOT), m) for folder in ("layered_brdf_addon", "layered_brdf_reference", "tests",
                                                      "benchmarks", "tools")
             for py in (ROOT / folder).rglob("*.py") for m in DOC_MENTION.findall(py.read_text())}
    missing = sorted(f"{py}: {m}" for py, m in named if not (ROOT / m).exists())
    assert not missing, missing
