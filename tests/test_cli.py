"""The command line: render, batch (serial and Dask), gallery, validation and exit codes.

Renders run in subprocesses (as a user runs them) at 32-64 px with one sample.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli.codecs import read_exr_layers, srgb_encode, to_srgb8
from layered_brdf_addon.cli.commands import format_table
from layered_brdf_addon.cli.gallery import label_lines, layout_for
from layered_brdf_addon.cli.job_files import load_job_file
from layered_brdf_addon.cli.lookdev import DEFAULT_PRESETS, settings_from_options as lookdev_settings
from layered_brdf_addon.cli.render_job import PNG_ENCODING
from layered_brdf_addon.cli.requests import request_from_options
from layered_brdf_addon.cli.sidecar import read_sidecar
from layered_brdf_addon.cli.staging import OutputPaths, StagedOutputs, stale_temps, temp_path
from layered_brdf_addon.model.params import PARAM_SPECS, LayeredParams, ParameterError
from layered_brdf_addon.model.presets import PAPER_PRESETS, PRESETS, preset, preset_label

from constants import MAX_FAILING, REL_TOL
from process_helpers import interrupt_once_started, start_cli, stop

TIMEOUT = 240


def run_cli(*args, cwd: Path, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """``python -m layered_brdf_addon ARGS`` in ``cwd``."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.run([sys.executable, "-m", "layered_brdf_addon", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


def beauty(path: Path) -> np.ndarray:
    layers = read_exr_layers(path)
    ch = layers["ViewLayer.Combined"]
    return np.stack([ch[f"ViewLayer.Combined.{c}"] for c in "RGB"], axis=-1).astype(np.float64)


def files_under(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# ---------------------------------------------------------------------------
# options derived from PARAM_SPECS, validation without Blender
def test_every_parameter_has_an_option_with_unit_range_and_choices():
    parser = cli.build_parser()
    render = next(a for a in parser._subparsers._group_actions[0].choices.items() if a[0] == "render")[1]
    by_dest = {a.dest: a for a in render._actions}
    for spec in PARAM_SPECS:
        action = by_dest[spec.name]
        assert "--" + spec.name.replace("_", "-") in action.option_strings
        assert spec.allowed in action.help.replace("%%", "%")
        if spec.unit and spec.kind == "float":
            assert spec.unit in action.help
        if spec.kind == "enum":
            assert tuple(action.choices) == spec.options
    ns = parser.parse_args(["render", "--d-min", "80", "--normal-mode", "tilted", "--tilt", "12"])
    assert (ns.d_min, ns.normal_mode, ns.tilt) == (80.0, "tilted", 12.0)


def test_no_command_means_lookdev():
    assert cli.normalise_argv([]) == ["lookdev"]
    assert cli.normalise_argv(["--samples", "4"]) == ["lookdev", "--samples", "4"]
    assert cli.normalise_argv(["render", "--preset", "fig4_tilted"])[0] == "render"
    assert cli.normalise_argv(["gallery"]) == ["gallery"]


def test_request_validation_names_the_parameter(tmp_path):
    req = request_from_options({"preset": "fig4_tilted", "d_max": 90, "sun": ["1", "-1", "0.5"],
                                "resolution": "48x32", "output": tmp_path / "a.png"})
    assert req.params == preset("fig4_tilted").replace(d_max=90.0)
    assert req.resolution == (48, 32) and req.sun == (1.0, -1.0, 0.5) and req.output == tmp_path / "a"
    assert req.samples == 1 and req.threads == 2
    cases = [({"preset": "nope"}, "preset"), ({"d_min": -1}, "d_min"), ({"d_min": 90, "d_max": 80}, "d_min"),
             ({"bogus": 1}, "bogus"), ({"samples": 0}, "samples"), ({"sun": [0, 0, 0]}, "sun"),
             ({"backend": "eevee"}, "backend"), ({"lobe": "phong"}, "lobe"), ({"object": "Cube"}, "object")]
    for options, name in cases:
        with pytest.raises(ParameterError) as e:
            request_from_options({**options, "output": tmp_path / "x"})
        assert e.value.name == name, options
    (tmp_path / "fake.blend").write_bytes(b"not a blend at all")
    with pytest.raises(ParameterError, match="readable .blend"):
        request_from_options({"blend": tmp_path / "fake.blend", "object": "Cube"})
    assert list(tmp_path.iterdir()) == [tmp_path / "fake.blend"]


def test_params_file_and_sidecar_round_trip(tmp_path):
    (tmp_path / "m.toml").write_text('d_min = 120.0\nd_max = 180.0\nnormal_mode = "tilted"\ntilt = 5.0\n')
    req = request_from_options({"params": "m.toml", "ks": 0.5}, base_dir=tmp_path, output_dir=tmp_path)
    assert (req.params.d_min, req.params.tilt, req.params.ks) == (120.0, 5.0, 0.5)
    assert req.output == tmp_path / "m"
    (tmp_path / "s.json").write_text(json.dumps({"format": "x", "params": req.params.to_dict()}))
    again = request_from_options({"params": tmp_path / "s.json", "output": tmp_path / "b"})
    assert again.params == req.params
    argv = req.to_argv()
    assert argv[argv.index("--ks") + 1] == "0.5" and argv[argv.index("--output") + 1] == str(tmp_path / "m")


def test_job_file_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[[job]\npreset = 'x'\n")
    with pytest.raises(ParameterError, match="jobfile"):
        load_job_file(bad)
    (tmp_path / "empty.json").write_text("{}")
    with pytest.raises(ParameterError):
        load_job_file(tmp_path / "empty.json")
    dup = tmp_path / "dup.json"
    dup.write_text(json.dumps([{"name": "a", "output": "same"}, {"name": "b", "output": "same"}]))
    with pytest.raises(ParameterError, match="output"):
        load_job_file(dup, output_dir=tmp_path / "out")
    mixed = tmp_path / "mixed.json"
    mixed.write_text(json.dumps({"defaults": {"resolution": 32}, "jobs": [{"preset": "fig3_clay"},
                                                                           {"preset": "fig3_clay", "d_min": -3}]}))
    jobs = load_job_file(mixed, output_dir=tmp_path / "out")
    assert [j.name for j in jobs] == ["fig3_clay", "fig3_clay-2"]
    assert jobs[0].request.resolution == (32, 32) and jobs[0].error is None
    assert jobs[1].request is None and "d_min" in jobs[1].error
    assert not (tmp_path / "out").exists()


def test_staged_outputs_commit_together_or_not_at_all(tmp_path):
    paths = OutputPaths(tmp_path / "r")
    with StagedOutputs(paths.all()) as st:
        for p in paths.all():
            st.temp(p).write_text(p.suffix)
    assert files_under(tmp_path) == ["r.exr", "r.json", "r.png"]
    other = OutputPaths(tmp_path / "q")
    with pytest.raises(KeyboardInterrupt):
        with StagedOutputs(other.all()) as st:
            st.temp(other.exr).write_text("partial")
            raise KeyboardInterrupt
    assert files_under(tmp_path) == ["r.exr", "r.json", "r.png"]
    with pytest.raises(RuntimeError, match="not written"):
        with StagedOutputs(other.all()) as st:
            st.temp(other.exr).write_text("only one")
    assert files_under(tmp_path) == ["r.exr", "r.json", "r.png"]
    left = [temp_path(other.exr, pid=1), tmp_path / f".{temp_path(other.exr, pid=1).stem}.partial7.exr"]
    for p in left:
        p.write_text("x")
    assert stale_temps(other.stem) == sorted(left)


def test_srgb_and_table():
    assert np.allclose(srgb_encode(np.array([0.0, 0.0031308, 0.18, 1.0, 4.0])),
                       [0.0, 0.04045, 0.46135612, 1.0, 1.0], atol=1e-5)
    assert to_srgb8(np.full((1, 1, 3), 0.5)).tolist() == [[[188, 188, 188]]]
    t = format_table(["job", "status", "seconds"], [["a", "ok", "1.5"], ["bad", "invalid", "0.0"]])
    assert t.splitlines()[0].split() == ["job", "status", "seconds"] and "bad  invalid" in t


def test_gallery_layout_fits_all_paper_presets():
    labels = [label_lines(n, preset(n)) for n in PAPER_PRESETS]
    lay = layout_for(labels, 128, title="t")
    assert lay.columns * lay.rows >= len(PAPER_PRESETS) > lay.columns * (lay.rows - 1)
    assert lay.sheet_size == (lay.columns * 128, lay.title_height + lay.rows * (128 + lay.label_height))
    boxes = {lay.tile_box(k) for k in range(len(labels))}
    assert len(boxes) == len(labels)
    assert labels[4][0] == "fig4_tilted" and "tilt 10" in labels[4][2]


# ---------------------------------------------------------------------------
# invalid input through the command line: exit 2, a message, nothing written
@pytest.fixture(scope="module")
def blend_file(tmp_path_factory) -> Path:
    """A small .blend: factory cube, camera and light, 48x36 px, AgX view transform with +0.5 exposure."""
    path = tmp_path_factory.mktemp("blend") / "scene.blend"
    code = ("import bpy\nbpy.ops.wm.read_factory_settings(use_empty=False)\n"
            "r = bpy.context.scene.render\nr.resolution_x, r.resolution_y = 48, 36\n"
            "v = bpy.context.scene.view_settings\nv.view_transform, v.look, v.exposure = 'AgX', 'None', 0.5\n"
            f"bpy.ops.wm.save_as_mainfile(filepath={str(path)!r})\n")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, timeout=TIMEOUT)
    return path


@pytest.mark.parametrize("args, names", [
    (["--preset", "no_such_preset"], ["'preset'", "fig4_tilted"]),
    (["--preset", "fig4_tilted", "--d-min", "-5"], ["'d_min'", "[0, 1e+06] nm"]),
    (["--d-min", "100", "--d-max", "50"], ["'d_min'", "at most d_max"]),
    (["--blend", "garbage.blend", "--object", "Cube"], ["'blend'", "readable .blend"]),
    (["--blend", "missing.blend", "--object", "Cube"], ["'blend'", "No such file"]),
])
def test_invalid_render_exits_2_and_writes_nothing(tmp_path, args, names):
    (tmp_path / "garbage.blend").write_bytes(b"\x00\x01 not a blend")
    out = tmp_path / "out"
    out.mkdir()
    res = run_cli("render", *args, "--output", out / "x", cwd=tmp_path, timeout=60)
    assert res.returncode == 2, res.stderr
    for n in names:
        assert n in res.stderr
    assert files_under(out) == []


def test_unknown_object_exits_2_and_lists_the_objects(tmp_path, blend_file):
    out = tmp_path / "out"
    out.mkdir()
    res = run_cli("render", "--blend", blend_file, "--object", "Nope", "--preset", "fig4_tilted",
                  "--output", out / "x", cwd=tmp_path, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "'object' = 'Nope'" in res.stderr and "Cube" in res.stderr
    assert files_under(out) == []


def test_bad_job_file_exits_2(tmp_path):
    (tmp_path / "jobs.toml").write_text("[[job]]\npreset = 'fig3_clay'\nresolution = [32\n")
    res = run_cli("batch", "jobs.toml", "--output-dir", tmp_path / "out", cwd=tmp_path, timeout=60)
    assert res.returncode == 2 and "'jobfile'" in res.stderr
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------
# renders
@pytest.mark.slow
def test_render_writes_png_exr_sidecar_that_predict_the_pixels(tmp_path):
    from layered_brdf_addon.blender.scene import passes_from_exr
    from layered_brdf_reference.closures import closure_shading
    from layered_brdf_reference.compare import agreement, lit_mask
    from layered_brdf_addon.model.sphere import render_spheres
    from layered_brdf_addon.cli.sidecar import scene_from_sidecar
    from PIL import Image

    res = run_cli("render", "--preset", "fig6_medium", "--resolution", 64, "--sun", 0.6, -1, 0.4,
                  "--sun-strength", 2, "--output", "out/sphere", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = tmp_path / "out"
    assert files_under(out) == ["sphere.exr", "sphere.json", "sphere.png"]
    side = read_sidecar(out / "sphere.json")
    assert side["params"] == preset("fig6_medium").to_dict()
    assert side["plan"]["normals"] == "tilted" and side["backend"] == "nodes" and side["samples"] == 1
    assert side["camera"]["width"] == side["camera"]["height"] == 64 and len(side["camera"]["matrix_world"]) == 4
    assert side["sun"]["strength"] == 2.0 and side["sun"]["direction"] == [0.6, -1.0, 0.4]
    import bpy

    assert side["bpy_version"] == bpy.app.version_string and side["render_seconds"] > 0
    passes = passes_from_exr(out / "sphere.exr")
    sc = scene_from_sidecar(side)
    expected, geo = render_spheres(sc.params, sc.camera, sc.sun, sc.centers, thickness=passes.thickness,
                                   prefer_analytic=True, shading=closure_shading)
    mask = lit_mask(geo, sc.sun.l)
    assert mask.sum() > 1000
    ag = agreement(passes.beauty, expected, mask, rel_tol=REL_TOL)
    assert ag.failing_fraction <= MAX_FAILING, str(ag)
    png = np.asarray(Image.open(out / "sphere.png"))
    assert png.shape == (64, 64, 3) and side["png_encoding"] == PNG_ENCODING
    assert np.abs(png.astype(int) - to_srgb8(passes.beauty).astype(int)).max() <= 1


@pytest.mark.slow
def test_render_on_an_object_of_a_blend(tmp_path, blend_file):
    from PIL import Image

    res = run_cli("render", "--blend", blend_file, "--object", "Cube", "--preset", "oil_slick", "--samples", 1,
                  "--output", tmp_path / "cube", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    side = read_sidecar(tmp_path / "cube.json")
    assert side["scene"] == "blend" and side["object"] == "Cube" and side["camera"]["type"] == "PERSP"
    assert (side["camera"]["width"], side["camera"]["height"]) == (48, 36)
    assert beauty(tmp_path / "cube.exr").shape == (36, 48, 3)
    assert beauty(tmp_path / "cube.exr").max() > 0
    # The PNG keeps the .blend's colour management (AgX, exposure +0.5), not the Standard curve.
    assert side["png_view"] == {"view_transform": "AgX", "look": "None", "exposure": 0.5, "gamma": 1.0,
                                "display_device": "sRGB"}
    assert "view transform AgX" in side["png_encoding"] and "exposure 0.5" in side["png_encoding"]
    png = np.asarray(Image.open(tmp_path / "cube.png").convert("RGB")).astype(int)
    standard = to_srgb8(beauty(tmp_path / "cube.exr")).astype(int)
    assert np.abs(png - standard).mean() > 5.0
    own = blender_encoding(tmp_path / "cube.exr", side["png_view"], tmp_path / "own.png").astype(int)
    assert np.abs(png - own).max() <= 1


@pytest.mark.slow
def test_the_sidecar_reports_the_plan_a_keyframed_material_was_built_with(tmp_path):
    path = tmp_path / "animated.blend"
    code = ("import bpy\nbpy.ops.wm.read_factory_settings(use_empty=False)\n"
            "r = bpy.context.scene.render\nr.resolution_x, r.resolution_y = 32, 24\n"
            "from layered_brdf_addon.blender.material import apply_layered_material, param_socket, shader_node\n"
            "from layered_brdf_addon.model import preset\n"
            "mat = apply_layered_material(bpy.data.objects['Cube'], preset('oil_slick').replace(kd=0.0))\n"
            "sock, _ = param_socket(shader_node(mat), 'kd')\n"
            "sock.keyframe_insert('default_value', frame=1)\n"
            "sock.default_value = 0.5\nsock.keyframe_insert('default_value', frame=20)\n"
            f"bpy.ops.wm.save_as_mainfile(filepath={str(path)!r})\n")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, timeout=TIMEOUT)
    res = run_cli("render", "--blend", path, "--object", "Cube", "--preset", "oil_slick", "--kd", 0, "--samples", 1,
                  "--output", tmp_path / "cube", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    # kd is 0 on this frame, but keyframed: the diffuse part stays in the shader, and the sidecar says so.
    assert read_sidecar(tmp_path / "cube.json")["plan"]["diffuse"] is True


def blender_encoding(exr: Path, view: dict, png: Path) -> np.ndarray:
    """Blender's own 8-bit encoding of the EXR's beauty with the view settings ``view``: the
    file loaded as an image and saved as a render PNG from a scene with those settings."""
    import bpy
    from PIL import Image

    scene = bpy.data.scenes.new("encode")
    img = bpy.data.images.load(str(exr), check_existing=False)
    try:
        scene.display_settings.display_device = view["display_device"]
        for key in ("view_transform", "look", "exposure", "gamma"):
            setattr(scene.view_settings, key, view[key])
        s = scene.render.image_settings
        s.media_type, s.file_format, s.color_mode, s.color_depth = "IMAGE", "PNG", "RGB", "8"
        img.save_render(filepath=str(png), scene=scene)
    finally:
        bpy.data.images.remove(img)
        bpy.data.scenes.remove(scene)
    return np.asarray(Image.open(png).convert("RGB"))


@pytest.mark.slow
def test_interrupt_leaves_no_partial_files(tmp_path):
    out = tmp_path / "out"
    proc = start_cli("render", "--preset", "fig4_tilted", "--resolution", 320, "--samples", 64,
                     "--output", out / "x", cwd=tmp_path)
    try:
        err, seconds = interrupt_once_started(proc, out)
    finally:
        stop(proc)
    assert proc.returncode == 130, err
    assert seconds < 10
    assert "no partial output" in err
    assert files_under(out) == []


JOBS = """
[defaults]
resolution = 32
samples = 1
sun = [0.4, -1.0, 0.5]

[[job]]
name = "clay"
preset = "fig3_clay"

[[job]]
name = "no_such"
preset = "fig9_missing"

[[job]]
name = "film_height"
preset = "fig3_thin_film"
thickness_mode = "height"
d_max = 600.0

[[job]]
name = "corrupt"
blend = "corrupt.blend"
object = "Cube"
"""


@pytest.fixture(scope="module")
def job_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("jobs")
    (d / "jobs.toml").write_text(JOBS)
    (d / "corrupt.blend").write_bytes(b"BLENDER-v500" + b"\x00" * 64)
    return d


@pytest.fixture(scope="module")
def serial_batch(job_dir):
    res = run_cli("batch", "jobs.toml", "--output-dir", "serial", "--report", "serial.json", cwd=job_dir)
    return res, json.loads((job_dir / "serial.json").read_text())


@pytest.mark.slow
def test_batch_reports_the_bad_job_and_runs_the_others(job_dir, serial_batch):
    res, report = serial_batch
    assert res.returncode == 1, res.stderr
    status = {r["name"]: r["status"] for r in report["results"]}
    assert status == {"clay": "ok", "no_such": "invalid", "film_height": "ok", "corrupt": "invalid"}
    lines = {ln.split()[0]: ln for ln in res.stdout.splitlines() if ln.strip()}
    assert "parameter 'preset' = 'fig9_missing' is invalid" in lines["no_such"]
    assert "'blend'" in lines["corrupt"] and "Blender can open" in lines["corrupt"]
    assert "serial/clay.{png,exr,json}" in lines["clay"]
    assert "2 of 4 jobs rendered, 2 failed" in res.stdout
    assert files_under(job_dir / "serial") == ["clay.exr", "clay.json", "clay.png", "film_height.exr",
                                               "film_height.json", "film_height.png"]
    side = read_sidecar(job_dir / "serial" / "film_height.json")
    assert side["name"] == "film_height" and side["params"]["d_max"] == 600.0


@pytest.mark.slow
def test_batch_on_a_local_dask_cluster_equals_the_serial_run(job_dir, serial_batch):
    res = run_cli("batch", "jobs.toml", "--jobs", 2, "--output-dir", "dask", "--report", "dask.json",
                  "--no-progress", cwd=job_dir)
    assert res.returncode == 1, res.stderr
    report = json.loads((job_dir / "dask.json").read_text())
    assert [(r["name"], r["status"]) for r in report["results"]] == \
        [(r["name"], r["status"]) for r in serial_batch[1]["results"]]
    for name in ("clay", "film_height"):
        a = beauty(job_dir / "serial" / f"{name}.exr")
        b = beauty(job_dir / "dask" / f"{name}.exr")
        # Cycles is reproducible up to float rounding of a few ray hits (also run to run).
        np.testing.assert_allclose(b, a, rtol=1e-6, atol=1e-6)
        sa, sb = (read_sidecar(job_dir / d / f"{name}.json") for d in ("serial", "dask"))
        for key in ("params", "camera", "sun", "samples", "seed"):
            assert sa[key] == sb[key]


@pytest.mark.slow
def test_gallery_contact_sheet_has_one_labelled_tile_per_configuration(tmp_path):
    from PIL import Image

    res = run_cli("gallery", "--samples", 1, "--size", 48, "--output", "sheet/gallery.png", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    meta = read_sidecar(tmp_path / "sheet" / "gallery.json")
    names = [t["name"] for t in meta["tiles"]]
    assert names == list(PAPER_PRESETS)
    lay = meta["layout"]
    cols, rows, size = lay["columns"], lay["rows"], lay["size"]
    assert size == 48 and cols * rows >= len(names)
    expected = (cols * size, lay["title_height"] + rows * (size + lay["label_height"]))
    img = np.asarray(Image.open(tmp_path / "sheet" / "gallery.png").convert("RGB"))
    assert (img.shape[1], img.shape[0]) == expected == tuple(lay["sheet_size"])
    for t in meta["tiles"]:
        assert t["label"][0] == t["name"] and len(t["label"]) >= 3
        assert t["params"] == preset(t["name"]).to_dict()
        x0, y0, x1, y1 = t["box"]
        assert (x1 - x0, y1 - y0) == (size, size)
        assert img[y0:y1, x0:x1].max() > 40  # the sphere is there
        label = img[y1:y1 + lay["label_height"], x0:x1]
        assert label.max() > 150  # and its caption
    assert beauty(tmp_path / "sheet" / "gallery.exr").shape == (rows * size, cols * size, 3)
    for n in PAPER_PRESETS:
        assert n in res.stdout
    assert "one render of 9 spheres" in res.stdout
    params = LayeredParams.from_dict(meta["tiles"][0]["params"])
    assert params == preset(names[0])


# ---------------------------------------------------------------------------
# lookdev: every preset on the shader ball, one labelled sheet
def test_lookdev_options_are_validated_without_blender(tmp_path):
    s = lookdev_settings({"output": tmp_path / "sheet", "size": 24, "samples": 2, "presets": ["oil_slick"]})
    assert s.output == tmp_path / "sheet.png" and s.sidecar == tmp_path / "sheet.json"
    assert (s.size, s.samples, s.presets, s.hdri) == (24, 2, ("oil_slick",), None)
    default = lookdev_settings({"output": tmp_path / "d.png"})
    assert set(default.presets) == set(PRESETS) == set(DEFAULT_PRESETS)
    cases = [({"size": 8}, "size", "[16, 2048]"), ({"size": "big"}, "size", "[16, 2048]"),
             ({"samples": 0}, "samples", "[1, 4096]"), ({"presets": ["oil_slick", "nope"]}, "presets", "oil_slick"),
             ({"presets": ["oil_slick", "oil_slick"]}, "presets", "distinct"), ({"columns": 0}, "columns", "[1, 64]"),
             ({"output": tmp_path}, "output", "folder"), ({"hdri": "../x"}, "hdri", "bundled HDRIs")]
    for options, name, allowed in cases:
        with pytest.raises(ParameterError) as e:
            lookdev_settings({"output": tmp_path / "x.png", **options})
        assert e.value.name == name and allowed in str(e.value), options
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args, names", [
    (["--size", "4"], ["'size'", "[16, 2048]", "--size"]),
    (["--samples", "-3"], ["'samples'", "[1, 4096]"]),
    (["--presets", "oil_slick", "fig9"], ["'presets'", "'fig9'", "soap_bubble"]),
    (["--hdri", "mars"], ["'hdri'", "'mars'", "forest", "courtyard", "studio"]),
])
def test_invalid_lookdev_exits_2_and_writes_nothing(tmp_path, args, names):
    res = run_cli("lookdev", *args, "--output", tmp_path / "out" / "sheet.png", cwd=tmp_path, timeout=60)
    assert res.returncode == 2, res.stderr
    for n in names:
        assert n in res.stderr
    assert files_under(tmp_path) == []


@pytest.mark.slow
def test_lookdev_sheet_has_a_labelled_tile_per_preset(tmp_path):
    from PIL import Image

    (tmp_path / "out").mkdir()
    old = tmp_path / "out" / "sheet.png"
    old.write_bytes(b"an earlier sheet")
    res = run_cli("lookdev", "--presets", "oil_slick", "fig4_tilted", "--size", 24, "--samples", 2,
                  "--output", old, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert files_under(tmp_path / "out") == ["sheet.json", "sheet.png"]
    assert "look-dev" in res.stderr and "2/2" in res.stderr  # the progress bar
    meta = read_sidecar(tmp_path / "out" / "sheet.json")
    assert [t["name"] for t in meta["tiles"]] == ["oil_slick", "fig4_tilted"]
    assert meta["view"]["view_transform"] == "AgX" and meta["hdri"] == "forest.exr" and meta["samples"] == 2
    img = np.asarray(Image.open(old).convert("RGB"))
    assert (img.shape[1], img.shape[0]) == tuple(meta["layout"]["sheet_size"])
    for t in meta["tiles"]:
        assert t["label"][0] == preset_label(t["name"])
        assert t["params"] == preset(t["name"]).to_dict()
        x0, y0, x1, y1 = t["box"]
        assert (x1 - x0, y1 - y0) == (24, 24) and img[y0:y1, x0:x1].std() > 5  # ball on a background
        assert img[y1:y1 + meta["layout"]["label_height"], x0:x1].max() > 150  # its caption
    a, b = (img[t["box"][1]:t["box"][3], t["box"][0]:t["box"][2]].astype(int) for t in meta["tiles"])
    assert np.abs(a - b).mean() > 2  # two materials, two looks


@pytest.mark.slow
def test_interrupted_lookdev_keeps_the_earlier_sheet(tmp_path):
    """Ctrl-C after the first tile: exit 130, the earlier sheet untouched, nothing else left."""
    import threading
    import time

    (tmp_path / "out").mkdir()
    old = tmp_path / "out" / "lookdev.png"
    old.write_bytes(b"an earlier sheet")
    proc = start_cli("lookdev", "--presets", "glazed_clay", "fig3_clay", "fig6_thin", "--size", 48, "--samples", 64,
                     "--output", old, cwd=tmp_path)
    err: list[str] = []
    reader = threading.Thread(target=lambda: err.extend(iter(lambda: proc.stderr.read(1), "")), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 120
        while "1/3" not in "".join(err) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.1)
        assert proc.poll() is None, "".join(err)
        proc.send_signal(__import__("signal").SIGINT)
        proc.wait(timeout=60)
        reader.join(timeout=10)
    finally:
        stop(proc)
    assert proc.returncode == 130, "".join(err)
    assert "no partial output" in "".join(err)
    assert files_under(tmp_path / "out") == ["lookdev.png"] and old.read_bytes() == b"an earlier sheet"
