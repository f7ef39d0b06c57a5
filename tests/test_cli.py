"""The command line's ``render``: options derived from PARAM_SPECS, validation and exit codes
without Blender, output staging, and renders of the reference sphere and of an object of a .blend.

Renders run in subprocesses (as a user runs them) at 32-64 px with one sample.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.io.codecs import srgb_encode, to_srgb8
from layered_brdf_addon.cli.commands import format_table
from layered_brdf_addon.cli.render_job import PNG_ENCODING
from layered_brdf_addon.cli.requests import request_from_options
from layered_brdf_addon.io.sidecar import read_sidecar
from layered_brdf_addon.io.staging import OutputPaths, StagedOutputs, stale_temps, temp_path
from layered_brdf_addon.model.params import PARAM_SPECS, ParameterError
from layered_brdf_addon.model.presets import preset

from constants import MAX_FAILING, REL_TOL
from process_helpers import beauty, files_under, interrupt_once_started, run_cli, start_cli, stop

TIMEOUT = 240


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
    (["--preset", "coated_lens", "--stack", json.dumps({"films": [{"ior": 1.5, "k": 12, "thickness_nm": 50}]})],
     ["'stack.films[0].k'", "[0, 10]"]),
    (["--preset", "coated_lens", "--stack", json.dumps({"films": []})], ["'stack.films'", "1 to 64 films"]),
    (["--preset", "coated_lens", "--stack", "missing.json"], ["missing.json"]),
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


# ---------------------------------------------------------------------------
# renders
@pytest.mark.slow
def test_render_writes_png_exr_sidecar_that_predict_the_pixels(tmp_path):
    from layered_brdf_addon.blender.scene import passes_from_exr
    from layered_brdf_reference.closures import closure_shading
    from layered_brdf_reference.compare import agreement, lit_mask
    from layered_brdf_addon.model.sphere import render_spheres
    from layered_brdf_addon.io.sidecar import scene_from_sidecar
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
