"""The GPU check (benchmarks/gpu_check.py, `make gpu-check`): without a GPU it says so, writes that
and passes; its comparison, run CPU against CPU, finds the same pixels."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import bpy  # noqa: F401  (a module that uses Blender: the factory state before each test)
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import gpu_check  # noqa: E402


def test_without_a_gpu_it_says_so_and_passes(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gpu_check, "device_types", lambda: {})
    out = tmp_path / "gpu.json"
    assert gpu_check.main(["--out", str(out)]) == 0
    assert "No GPU device found" in capsys.readouterr().out
    d = json.loads(out.read_text())
    assert d["devices"] == [] and d["spheres"] == [] and d["scene"] == []


@pytest.mark.slow
def test_the_comparison_finds_a_device_agrees_with_itself():
    rows = gpu_check.compare_spheres("CPU", ["tables"])
    assert len(rows) == len(gpu_check.PRESETS)
    for row in rows:
        print(row["preset"], row["summary"])
        assert row["ok"] and row["failing"] == 0.0, row


def test_a_device_type_asked_for_and_not_found_is_an_error(tmp_path, monkeypatch, capsys):
    """Cycles would render such a scene on the CPU: the check would compare the CPU with itself."""
    monkeypatch.setattr(gpu_check, "device_types", lambda: {"CUDA": ["a card"]})
    out = tmp_path / "gpu.json"
    with pytest.raises(SystemExit) as e:
        gpu_check.main(["--devices", "OPTIX", "--out", str(out)])
    assert e.value.code == 2
    assert "--devices: no OPTIX device found (found: CUDA)" in capsys.readouterr().err
    assert not out.exists()
