"""One reader of a render's sidecar and EXR (:mod:`layered_brdf_addon.io.sphere_render`), two ways of
saying no: a render that cannot be fitted is refused by ``layered-brdf fit`` (exit code 2, a
ParameterError naming ``target`` or ``tile``) and by the panel's *Fit to Render...*
(:func:`~layered_brdf_addon.blender.sidecar_views.sidecar_views`: a TargetError), each giving the
reader's reason.  No render is made: the EXRs are numpy images written by OpenEXR."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from layered_brdf_addon.blender.sidecar_views import read_exr_beauty, sidecar_views
from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.cli.fit_targets import Source, load_render_target, read_complete_beauty
from layered_brdf_addon.fit.targets import TargetError
from layered_brdf_addon.io.regular_files import MAX_INPUT_BYTES
from layered_brdf_addon.io.sidecar import SidecarError, camera_to_dict, sidecar_path, write_json
from layered_brdf_addon.io.sphere_render import read_sphere_render
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.sphere import OrthoCamera

from test_fit_cli import write_render

SIZE = 32
PARAMS = preset("soap_bubble")


def _reference(folder: Path, image=None) -> Path:
    """A reference render ``t`` of SIZE x SIZE pixels (grey unless ``image``): its sidecar's path."""
    write_render(folder / "t", PARAMS, size=SIZE, image=np.full((SIZE, SIZE, 3), 0.2) if image is None else image)
    return folder / "t.json"


def _gallery(folder: Path) -> Path:
    """A gallery ``t`` of two spheres, tiles ``thin`` and ``thick``: its sidecar's path."""
    camera = OrthoCamera(view=(0.0, -1.0, 0.0), ortho_scale=4.4, width=2 * SIZE, height=SIZE)
    write_render(folder / "t", PARAMS, image=np.full((SIZE, 2 * SIZE, 3), 0.2))
    side = json.loads((folder / "t.json").read_text())
    side.update(scene="gallery", camera=camera_to_dict(camera), centers=[[-1.1, 0.0, 0.0], [1.1, 0.0, 0.0]],
                tiles=[{"name": n, "params": PARAMS.to_dict()} for n in ("thin", "thick")])
    side.pop("params")
    write_json(folder / "t.json", side)
    return folder / "t.json"


def _edited(make, edit):
    """``make``'s render with its sidecar changed by ``edit(sidecar dict)``."""
    def made(folder):
        path = make(folder)
        side = json.loads(path.read_text())
        edit(side)
        write_json(path, side)
        return path
    return made


def _sidecar_text(text):
    def made(folder):
        _reference(folder)
        (folder / "t.json").write_text(text)
        return folder / "t.json"
    return made


def _folder_sidecar(folder):
    _reference(folder)
    (folder / "t.json").unlink()
    (folder / "t.json").mkdir()
    return folder / "t.json"


def _without_exr(folder):
    _reference(folder)
    (folder / "t.exr").unlink()
    return folder / "t.exr"


def _garbled_exr(folder):
    _reference(folder)
    (folder / "t.exr").write_bytes(b"not an EXR")
    return folder / "t"


def _nan_pixel(folder):
    image = np.full((SIZE, SIZE, 3), 0.2)
    image[SIZE // 2, SIZE // 2, 1] = np.nan
    return _reference(folder, image).with_suffix(".png")


# name: (the render's files, the CLI's --tile and the panel's sphere, the field refused, what the reason says)
FAULTS = {
    "not JSON": (_sidecar_text("{not json"), None, 0, "target", "not JSON"),
    "another format": (_sidecar_text('{"format": "something else"}'), None, 0, "target",
                       "not the sidecar of a layered-brdf render"),
    "a JSON array": (_sidecar_text("[1, 2]"), None, 0, "target", "not an object"),
    "a folder": (_folder_sidecar, None, 0, "target", "a regular file; this is a folder"),
    "over 1 MiB": (_edited(_reference, lambda s: s.update(note=" " * MAX_INPUT_BYTES)), None, 0, "target",
                   "at most 1 MiB"),
    "a .blend render": (_edited(_reference, lambda s: s.update(scene="blend")), None, 0, "target",
                        "this is a render of a .blend (--blend)"),
    "a look-dev sheet": (_edited(_reference, lambda s: s.update(scene="lookdev")), None, 0, "target",
                         "this is a look-dev sheet"),
    "an unknown scene": (_edited(_reference, lambda s: s.update(scene="cube")), None, 0, "target",
                         "a sidecar of scene 'cube'"),
    "no camera": (_edited(_reference, lambda s: s.pop("camera")), None, 0, "target", "lacks the key 'camera'"),
    "a camera of zero width": (_edited(_reference, lambda s: s["camera"].update(width=0)), None, 0, "target",
                               "'camera.width' = 0"),
    "a missing EXR": (_without_exr, None, 0, "target", "t.exr is missing"),
    "an EXR that is not one": (_garbled_exr, None, 0, "target", "t.exr cannot be read"),
    "an EXR of another size": (_edited(_reference, lambda s: s["camera"].update(width=48, height=40)), None, 0,
                               "target", "its EXR is 32x32 pixels where the sidecar's camera renders 48x40"),
    "NaN pixels": (_nan_pixel, None, 0, "target", "1 of the sphere's"),
    "no sphere in sight": (_edited(_reference, lambda s: s.update(centers=[[50.0, 0.0, 0.0]])), None, 0, "target",
                           "sees no pixel of sphere 0"),
    "a tile out of range": (_gallery, "5", 5, "tile", "it holds 2 sphere(s): 5 is not one of them"),
    "a negative tile": (_gallery, "-1", -1, "tile", "-1 is not one of them"),
    "an unknown tile name": (_gallery, "nope", "nope", "tile", "'nope' is not one of them (choose a name among "
                             "thin, thick or an index in [0, 1])"),
}


def _cli_target(path: Path, tile):
    """The command line's read of the render whose set holds ``path``, its ``--tile`` being ``tile``."""
    return load_render_target(Source("render", sidecar_path(path), "t"), tile)


@pytest.mark.parametrize("case", list(FAULTS))
def test_the_command_line_and_the_panel_refuse_a_render_for_the_reader_s_reason(case, tmp_path, capsys):
    make, tile, sphere, field, said = FAULTS[case]
    path = make(tmp_path)
    with pytest.raises(SidecarError) as caught:
        read_sphere_render(path, read_complete_beauty, tile=tile)
    reason = caught.value.reason
    assert said in reason and caught.value.field == field and "\n" not in reason
    with pytest.raises(ParameterError) as cli_error:
        _cli_target(path, tile)
    assert cli_error.value.name == field and f"({reason})" in str(cli_error.value)
    with pytest.raises(TargetError) as panel_error:
        sidecar_views(path, sphere=sphere)
    assert str(panel_error.value) == f"t.json: {reason}"
    # The command: exit code 2, one line naming the option, nothing written.
    args = [path] + (["--tile", tile] if tile is not None else [])
    code = cli.main(["fit", *map(str, args), "--output", str(tmp_path / "out" / "fit"), "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1 and f"'{field}'" in err and reason in err, err
    assert not (tmp_path / "out").exists()


def test_a_gallery_s_tile_is_chosen_by_name_or_index_and_read_alike(tmp_path):
    path = _gallery(tmp_path)
    for tile, sphere in (("thick", 1), ("1", 1), ("thin", 0)):
        loaded = _cli_target(path, tile)
        [view] = sidecar_views(path, sphere=sphere)
        render = read_sphere_render(path.with_suffix(".exr"), read_complete_beauty, tile=tile)
        assert render.sphere == sphere and render.tile == ("thin", "thick")[sphere] and render.kind == "gallery"
        assert loaded.target.views[0].sphere == view.sphere == sphere
        assert loaded.record["tile"] == render.tile and loaded.record["size"] == [2 * SIZE, SIZE]
        assert np.array_equal(loaded.target.views[0].image, view.image)
    with pytest.raises(SidecarError, match="several spheres: choose one of its tiles, a name among thin, thick"):
        read_sphere_render(path, read_complete_beauty)
    (tmp_path / "ref").mkdir()
    with pytest.raises(SidecarError, match="holds one sphere"):
        read_sphere_render(_reference(tmp_path / "ref"), read_complete_beauty, tile="0")


def test_the_exr_is_found_beside_the_sidecar_else_where_it_records(tmp_path):
    path = _reference(tmp_path)
    (tmp_path / "elsewhere").mkdir()
    moved = (tmp_path / "t.exr").replace(tmp_path / "elsewhere" / "t.exr")
    with pytest.raises(SidecarError, match="t.exr is missing: the target image"):
        read_sphere_render(path, read_complete_beauty)
    side = json.loads(path.read_text())
    write_json(path, {**side, "outputs": {"exr": str(tmp_path / "gone.exr")}})
    with pytest.raises(SidecarError, match=r"t.exr is missing \(nor at .*gone.exr, where it was written\)"):
        read_sphere_render(path, read_complete_beauty)
    write_json(path, {**side, "outputs": {"exr": str(moved)}})
    loaded = _cli_target(tmp_path / "t", None)
    [view] = sidecar_views(tmp_path / "t.png")
    assert loaded.record["exr"] == moved and loaded.record["tile"] is None
    assert np.array_equal(loaded.target.views[0].image, view.image)
    assert np.array_equal(read_exr_beauty(moved), view.image)


def test_the_panel_s_exr_reader_is_its_own(tmp_path):
    path = _reference(tmp_path)
    read = []
    [view] = sidecar_views(path, read_beauty=lambda p: read.append(p) or np.ones((SIZE, SIZE, 4)))
    assert read == [tmp_path / "t.exr"] and view.image.shape == (SIZE, SIZE, 3) and view.image.dtype == np.float64
    with pytest.raises(TargetError, match=r"t.json: its EXR .*t.exr cannot be read: OSError: no disk"):
        sidecar_views(path, read_beauty=lambda p: (_ for _ in ()).throw(OSError("no disk")))
    with pytest.raises(TargetError, match=r"holds no RGB image \(an array of shape \(32, 32\)\)"):
        sidecar_views(path, read_beauty=lambda p: np.ones((SIZE, SIZE)))
    with pytest.raises(TypeError):
        read_sphere_render(path, read_complete_beauty, tile="0", sphere=0)
