"""Files of one idea each: no Python module of the add-on, the reference package, the tests or the
benchmarks grows past 500 lines (past that, a module holds more than one job: split it by job)."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("layered_brdf_addon", "layered_brdf_reference", "tests", "benchmarks", "tools", "examples")
MAX_LINES = 500


def test_no_module_is_longer_than_the_limit():
    modules = [path for folder in FOLDERS for path in sorted((ROOT / folder).rglob("*.py"))]
    assert len(modules) > 100, "the folders were not found"
    long = {str(path.relative_to(ROOT)): n for path in modules
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines (split them by job): {long}"
