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
