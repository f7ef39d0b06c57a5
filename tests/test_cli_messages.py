"""What the command line says when something is wrong: a full disk while the outputs are
written, and which option, file or key a refused value is attributed to.

A full disk is simulated as tests/test_farm_faults.py does (every ``os.fsync`` fails with
ENOSPC), together with what Blender's EXR writer does on a full disk: it reports nothing
and leaves the file cut short.  Renders are 16-32 px with one sample.
"""
from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli import gallery, render_job
from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.cli.option_values import unit_notes
from layered_brdf_addon.cli.input_files import FileValueError
from layered_brdf_addon.cli.requests import request_from_options
from layered_brdf_addon.io.staging import WriteError, writing
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.presets import preset

TIMEOUT = 240
FULL = "the disk is full (No space left on device)"

# Loaded by every Python process whose PYTHONPATH holds its folder (the render, a batch's
# jobs): the output folder's disk is full.  Blender's EXR keeps the share KEPT of its bytes:
# 0.1 loses the beauty pass, 0.6 keeps it and loses the passes after it.
FULL_DISK_SITE = '''
import errno
import os

KEPT = float(os.environ.get("LAYERED_BRDF_TEST_KEPT", "0.1"))

_replace = os.replace


def _cut_short(src, dst, *args, **kwargs):
    """Blender's EXR writer on a full disk: no error, the file cut short."""
    name = os.fspath(src)
    if ".partial" in name and name.endswith(".exr"):
        os.truncate(name, int(os.path.getsize(name) * KEPT))
    return _replace(src, dst, *args, **kwargs)


def _full(fd):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


os.replace = _cut_short
os.fsync = _full
'''


def full_disk(*args, cwd: Path, kept: float = 0.1, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """``python -m layered_brdf_addon ARGS`` in ``cwd`` with a full disk (:data:`FULL_DISK_SITE`,
    Blender's EXRs cut to the share ``kept``), its temporary files in ``cwd/tmp``."""
    site = cwd / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(FULL_DISK_SITE)
    (cwd / "tmp").mkdir(exist_ok=True)
    path = os.pathsep.join(p for p in (str(site), os.environ.get("PYTHONPATH", "")) if p)
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONPATH": path, "TMPDIR": str(cwd / "tmp"),
           "LAYERED_BRDF_TEST_KEPT": str(kept)}
    return subprocess.run([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")) if folder.exists() else []


def enospc(*args):
    raise OSError(errno.ENOSPC, "No space left on device")


def blender_exr(path: Path, size: int = 32) -> Path:
    """A multilayer EXR as Blender writes a render: one part per pass, the beauty first."""
    import OpenEXR

    rng = np.random.default_rng(3)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    parts = [OpenEXR.Part(dict(header), {f"ViewLayer.{name}.{c}": rng.random((size, size), dtype=np.float32)
                                   for c in channels}, f"ViewLayer.{name}")
             for name, channels in (("Combined", "RGBA"), ("Normal", "XYZ"), ("layer_thickness", "X"))]
    with OpenEXR.File(parts) as f:
        f.write(str(path))
    return path


# ---------------------------------------------------------------------------
# a full disk: one line with the reason, exit 1, nothing written
@pytest.mark.parametrize("kept", [0.03, 0.2, 0.6, 0.95])
def test_an_exr_cut_short_by_a_full_disk_is_a_write_error_naming_the_output(tmp_path, monkeypatch, capfd, kept):
    staged = blender_exr(tmp_path / ".a.tmp1.exr")
    rgb, alpha = render_job.read_written_beauty(staged, tmp_path / "a.exr")
    assert rgb.shape == (32, 32, 3) and alpha is not None
    os.truncate(staged, int(staged.stat().st_size * kept))  # 0.6, 0.95: the beauty is there, other passes not

    with pytest.raises(WriteError) as e:  # the disk has room: the file Blender wrote is unreadable
        render_job.read_written_beauty(staged, tmp_path / "a.exr")
    assert str(e.value).startswith(f"could not write {tmp_path / 'a.exr'}: the file Blender wrote cannot be read")

    monkeypatch.setattr(os, "fsync", enospc)
    with pytest.raises(WriteError) as e:
        render_job.read_written_beauty(staged, tmp_path / "a.exr")
    assert str(e.value) == f"could not write {tmp_path / 'a.exr'}: {FULL}"
    assert capfd.readouterr().err == "", "OpenEXR's complaints about the damaged chunks are shown"
    assert [p.name for p in tmp_path.iterdir()] == [".a.tmp1.exr"], "the probe file was left"


def test_writers_failing_on_a_full_disk_are_write_errors_naming_the_output(tmp_path, monkeypatch):
    png = tmp_path / "a.png"
    with pytest.raises(WriteError, match="could not write .*a.png: the disk is full"):
        with writing(png):
            enospc()
    with pytest.raises(RuntimeError, match="not about the disk"):  # the disk has room: not a write error
        with writing(png):
            raise RuntimeError("not about the disk")
    monkeypatch.setattr(os, "fsync", enospc)
    with pytest.raises(WriteError) as e:  # OpenEXR says a full disk with a RuntimeError
        with writing(png):
            raise RuntimeError("Failed to write pixel data to image file")
    assert str(e.value) == f"could not write {png}: {FULL}"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("error", [WriteError("/out/a.exr", FULL),
                                   OSError(errno.ENOSPC, "No space left on device", "/out/a.png")],
                         ids=["write_error", "os_error"])
def test_a_full_disk_is_one_line_and_exit_1(monkeypatch, capsys, error):
    def render(ns, argv):
        raise error

    monkeypatch.setattr(cli, "cmd_render", render)
    assert cli.main(["render", "--preset", "fig3_clay"]) == cli.EXIT_FAILED
    err = capsys.readouterr().err
    assert err.startswith("layered-brdf: error: could not write /out/a.") and FULL in err, err
    assert err.count("\n") == 1 and "Traceback" not in err, err


@pytest.mark.slow
@pytest.mark.parametrize("command, kept", [("render", 0.1), ("render", 0.6), ("gallery", 0.1), ("lookdev", 0.1)])
def test_a_full_disk_while_the_exr_is_written_says_so_and_keeps_the_earlier_outputs(tmp_path, command, kept):
    out = tmp_path / "out"
    out.mkdir()
    earlier = {"x.png": b"earlier png", "x.exr": b"earlier exr", "x.json": b"{}"}
    for name, data in earlier.items():
        (out / name).write_bytes(data)
    args = {"render": ["render", "--preset", "fig3_clay", "--resolution", 32],
            "gallery": ["gallery", "--presets", "fig3_clay", "--size", 16, "--samples", 1],
            "lookdev": ["lookdev", "--presets", "fig3_clay", "--size", 16, "--samples", 1, "--no-progress"]}[command]
    res = full_disk(*args, "--output", out / "x", cwd=tmp_path, kept=kept)
    assert res.returncode == 1, res.stderr[-3000:]
    written = "x.exr" if command != "lookdev" else "0.exr"  # the look-dev sheet's tiles: in the temp folder
    line = res.stderr.strip().splitlines()[-1]
    assert line.startswith("layered-brdf: error: could not write ") and f"{written}: {FULL}" in line, res.stderr
    for bad in ("Traceback", "KeyError", "Combined", "EXR_ERR"):
        assert bad not in res.stderr, res.stderr[-3000:]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == earlier, "the earlier outputs were changed"
    assert files_under(tmp_path / "tmp") == []


@pytest.mark.slow
def test_a_full_disk_in_a_batch_job_is_said_in_its_row(tmp_path):
    (tmp_path / "jobs.toml").write_text('[[job]]\nname = "clay"\npreset = "fig3_clay"\nresolution = 32\n')
    res = full_disk("batch", "jobs.toml", "--output-dir", "out", "--no-progress", cwd=tmp_path)
    assert res.returncode == 1, res.stderr[-3000:]
    row = next(ln for ln in res.stdout.splitlines() if ln.startswith("clay"))
    assert row.split()[1] == "failed" and "could not write" in row and "the disk is full" in row, res.stdout
    assert "KeyError" not in res.stdout + res.stderr and "Traceback" not in res.stderr, res.stdout + res.stderr
    assert files_under(tmp_path / "out") == []


# ---------------------------------------------------------------------------
# refused values name what the user typed: the option, or the file and its key
def _refused(argv: list[str], capsys) -> str:
    assert cli.main(argv) == cli.EXIT_INVALID
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err.strip()


@pytest.mark.parametrize("presets", [["nope"], ["fig3_clay", "nope"], ["fig3_clay", "fig3_clay"]])
def test_gallery_and_lookdev_name_presets_as_typed(tmp_path, capsys, presets):
    said = {cmd: _refused([cmd, "--presets", *presets, "--output", str(tmp_path / cmd)], capsys)
            for cmd in ("gallery", "lookdev")}
    assert said["gallery"] == said["lookdev"]
    assert said["gallery"].startswith("layered-brdf: error: parameter 'presets' = ")
    assert said["gallery"].endswith("(option --presets)")
    assert list(tmp_path.iterdir()) == []


def test_a_preset_the_gallery_backend_cannot_build_names_presets(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(gallery, "preset", lambda name: preset(name).replace(lobe="phong"))
    with pytest.raises(ParameterError) as e:
        gallery.settings_from_options({"presets": ["fig3_clay"], "output": tmp_path / "g"})
    assert e.value.name == "presets" and "choose --backend osl" in str(e.value)
    assert gallery.settings_from_options({"presets": ["fig3_clay"], "backend": "osl",
                                          "output": tmp_path / "g"}).presets == ("fig3_clay",)
    err = _refused(["gallery", "--presets", "fig3_clay", "--output", str(tmp_path / "g")], capsys)
    assert "'presets' = 'fig3_clay'" in err and err.endswith("(option --presets)") and "--lobe" not in err


PARAMS_CASES = [
    pytest.param("params.json", {"d_min": -5}, [],
                 "parameter 'd_min' = -5 in params.json: allowed a number in [0, 1e+06] nm", id="out_of_range"),
    pytest.param("params.json", {"d_min": 300, "d_max": 100}, [],
                 "parameter 'd_min' = 300.0 in params.json: allowed at most d_max = 100 nm", id="d_min_above_d_max"),
    pytest.param("params.json", {"d_min": 300}, ["--d-max", "100"],
                 "parameter 'd_min' = 300.0 in params.json: allowed at most", id="d_min_above_a_typed_d_max"),
    pytest.param("params.json", {"bogus": 1}, [],
                 "parameter 'bogus' = 1 in params.json: allowed a known parameter name", id="unknown_key"),
    pytest.param("params.json", {"d_min": [1, 2]}, [],
                 "parameter 'd_min' = [1, 2] in params.json: allowed a number", id="a_list"),
    pytest.param("params.json", {"lobe": "phong"}, ["--backend", "nodes"],
                 "parameter 'lobe' = 'phong' in params.json: allowed one of 'beckmann' with the nodes backend",
                 id="lobe_the_backend_cannot_build"),
    pytest.param("sub/mat.toml", 'normal_mode = "wobbly"\n', [],
                 "parameter 'normal_mode' = 'wobbly' in sub/mat.toml: allowed one of", id="toml"),
]


@pytest.mark.parametrize("name, content, args, said", PARAMS_CASES)
def test_a_bad_value_in_a_params_file_names_the_file_and_the_key(tmp_path, monkeypatch, capsys, name, content, args,
                                                                  said):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / name
    path.parent.mkdir(exist_ok=True)
    path.write_text(content if isinstance(content, str) else json.dumps(content))
    err = _refused(["render", "--params", name, *args, "--output", "out/x"], capsys)
    assert err == f"layered-brdf: error: {said}" or err.startswith(f"layered-brdf: error: {said}"), err
    assert "(option --" not in err and not (tmp_path / "out").exists()


def test_options_typed_next_to_a_params_file_keep_their_own_names(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.json").write_text(json.dumps({"lobe": "phong", "ks": 0.5}))
    err = _refused(["render", "--params", "params.json", "--lobe", "beckmann", "--ks", "7", "--output", "x"], capsys)
    assert err.startswith("layered-brdf: error: parameter 'ks' = 7.0 is invalid") and err.endswith("(option --ks)")
    req = request_from_options({"params": "params.json", "lobe": "beckmann", "output": "x"})
    assert (req.params.lobe, req.params.ks) == ("beckmann", 0.5)


def test_a_jobs_params_file_is_named_and_a_job_files_output_is_no_option(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.json").write_text(json.dumps({"d_min": -5}))
    (tmp_path / "jobs.json").write_text(json.dumps([{"name": "a", "params": "m.json"}, {"name": "b", "d_min": -4}]))
    a, b = load_job_file(tmp_path / "jobs.json", output_dir=tmp_path / "out")
    assert a.error == "parameter 'd_min' = -5 in m.json: allowed a number in [0, 1e+06] nm"
    assert b.error.startswith("parameter 'd_min' = -4 is invalid")
    with pytest.raises(FileValueError):
        request_from_options({"params": "m.json", "output": "x"})

    (tmp_path / "same.json").write_text(json.dumps([{"name": "a", "output": "o"}, {"name": "b", "output": "o"}]))
    err = _refused(["batch", "same.json", "--output-dir", "out", "--no-progress"], capsys)
    assert "parameter 'output'" in err and "(option --output)" not in err, err
    err = _refused(["batch", "same.json", "--jobs", "0"], capsys)
    assert "parameter 'jobs'" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jobs.json", "m.json", "same.json"]


def test_a_params_file_and_typed_options_are_checked_as_one_set(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "params.json").write_text(json.dumps({"d_min": 300, "lower_medium": "custom", "r2_r": 1.7}))
    req = request_from_options({"params": "params.json", "d_max": 400, "output": "x"})
    assert (req.params.d_min, req.params.d_max, req.params.r2_r) == (300, 400, 1.7)
    water = request_from_options({"lower_medium": "water", "output": "x"}).params
    typed = request_from_options({"params": "params.json", "lower_medium": "water", "d_max": 400,
                                  "output": "x"}).params
    assert (typed.r2_r, typed.k2_g) == (water.r2_r, water.k2_g) and typed.d_min == 300
    kept = request_from_options({"params": "params.json", "lower_medium": "water", "r2_r": 1.2, "d_max": 400,
                                 "output": "x"}).params
    assert kept.r2_r == 1.2


@pytest.mark.parametrize("options, name, needs", [
    ({"preset": "oil_slick", "r1_r": 3, "r1_g": 3, "r1_b": 3}, "r1_r", "layer_index 'channels'"),
    ({"preset": "fig4_parallel", "layer_ior": 1.6}, "layer_ior", "layer_index 'ior'"),
])
def test_a_value_the_material_would_not_use_is_refused(options, name, needs):
    with pytest.raises(ParameterError, match=f"{name}.*used only with {needs}"):
        request_from_options({**options, "output": "x"})
    enum, option = needs.split(" ")
    req = request_from_options({**options, enum: option.strip("'"), "output": "x"})
    assert getattr(req.params, name) == options[name]


@pytest.mark.parametrize("option, name", [("--k2-g", "k2_g"), ("--samples", "samples"), ("--d-max", "d_max")])
def test_digits_grouped_by_underscores_are_no_number(tmp_path, monkeypatch, capsys, option, name):
    monkeypatch.chdir(tmp_path)
    err = _refused(["render", "--preset", "oil_slick", option, "1_5", "--output", "x"], capsys)
    assert f"parameter '{name}' = '1_5'" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["gallery", "lookdev"])
def test_the_help_gives_the_range_the_error_names(tmp_path, monkeypatch, capsys, command):
    monkeypatch.chdir(tmp_path)
    err = _refused([command, "--size", "1", "--output", "x.png"], capsys)
    allowed = err[err.index("["):err.index("]") + 1]
    with pytest.raises(SystemExit):
        cli.main([command, "--help"])
    assert allowed in " ".join(capsys.readouterr().out.split()), allowed


def test_a_python_without_blender_s_module_says_which_python_to_use(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    real_import = __builtins__["__import__"] if isinstance(__builtins__, dict) else __builtins__.__import__

    def no_bpy(name, *args, **kwargs):
        if name == "bpy" or name.startswith("bpy."):
            raise ModuleNotFoundError("No module named 'bpy'", name="bpy")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr("builtins.__import__", no_bpy)
    for module in [m for m in sys.modules if m == "bpy" or m.startswith("bpy.")]:
        monkeypatch.delitem(sys.modules, module)
    assert cli.main(["render", "--preset", "oil_slick", "--output", "x"]) == cli.EXIT_FAILED
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1
    assert "has no module 'bpy' (Blender as a Python module)" in err and ".venv-5.2/bin/python -m layered_brdf_addon" in err
    assert list(tmp_path.iterdir()) == []


def test_a_thickness_typed_in_micrometres_or_picometres_gets_a_note(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["render", "--preset", "oil_slick", "--d-min", "0.1", "--d-max", "0.6", "--resolution", "16",
                     "--output", "x"]) == cli.EXIT_OK
    err = capsys.readouterr().err
    assert "note: --d-min 0.1 is 0.1 nm" in err and "--d-max 600" in err
    assert unit_notes({"d_min": 150000.0}) == ["--d-min 150000 is 150 micrometres: thickness is in nm; if you "
                                               "meant picometres, that is --d-min 150"]
    assert unit_notes({"d_min": 0.0, "d_max": 600.0, "ks": 0.5}) == []
