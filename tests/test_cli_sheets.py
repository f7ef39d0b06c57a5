"""The command line's contact sheets: ``gallery`` (the paper's figures as spheres of one render)
and ``lookdev`` (every preset on the shader ball under an HDRI): layouts, validation, exit
codes, and the labelled sheets they render.
"""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.cli.gallery import label_lines, layout_for
from layered_brdf_addon.cli.lookdev import DEFAULT_PRESETS, settings_from_options as lookdev_settings
from layered_brdf_addon.io.sidecar import read_sidecar
from layered_brdf_addon.model.params import LayeredParams, ParameterError
from layered_brdf_addon.model.presets import PAPER_PRESETS, PRESETS, preset, preset_label

from process_helpers import beauty, files_under, run_cli, start_cli, stop


def test_gallery_layout_fits_all_paper_presets():
    labels = [label_lines(n, preset(n)) for n in PAPER_PRESETS]
    lay = layout_for(labels, 128, title="t")
    assert lay.columns * lay.rows >= len(PAPER_PRESETS) > lay.columns * (lay.rows - 1)
    assert lay.sheet_size == (lay.columns * 128, lay.title_height + lay.rows * (128 + lay.label_height))
    boxes = {lay.tile_box(k) for k in range(len(labels))}
    assert len(boxes) == len(labels)
    assert labels[4][0] == "fig4_tilted" and "tilt 10" in labels[4][2]


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
