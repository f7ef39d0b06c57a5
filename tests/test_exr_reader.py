"""The numpy EXR reader (io/exr_reader.py) against OpenEXR: Blender's own renders (multilayer,
ZIP / ZIPS / none, float and half, and a single-layer file), a file with a last chunk shorter
than its sixteen lines and every pixel type, and the files it must refuse with a reason."""
from __future__ import annotations

import numpy as np
import OpenEXR
import pytest

from layered_brdf_addon.io.codecs import read_exr_layers
from layered_brdf_addon.io.exr_reader import ExrError, read_exr


@pytest.fixture(scope="module")
def blender_renders(tmp_path_factory):
    """A 24 x 20 render of a sphere written by Blender in the formats the reader takes."""
    from layered_brdf_addon.blender.material import apply_layered_material
    from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, render_to_file, reset_blender
    from layered_brdf_addon.model.presets import preset
    from layered_brdf_reference.fit_cases import SUNS

    reset_blender()
    scene = build_scene(SceneSpec(camera=camera_for(1, 24), sun=SUNS[1]))
    apply_layered_material(scene[0], preset("oil_slick"))
    import bpy

    s = bpy.context.scene
    s.render.resolution_y = 20
    out = tmp_path_factory.mktemp("exr")
    files = {}
    for multilayer, codec, depth in ((True, "ZIP", "32"), (True, "ZIPS", "16"), (True, "NONE", "32"),
                                     (False, "ZIP", "16"), (True, "PIZ", "32")):
        settings = s.render.image_settings
        settings.media_type = "MULTI_LAYER_IMAGE" if multilayer else "IMAGE"
        settings.file_format = "OPEN_EXR_MULTILAYER" if multilayer else "OPEN_EXR"
        settings.color_depth, settings.exr_codec = depth, codec
        path = out / f"{'layers' if multilayer else 'image'}_{codec}_{depth}.exr"
        render_to_file(path, s)
        files[(multilayer, codec, depth)] = path
    reset_blender()
    return files


def _same(path) -> None:
    ours, theirs = read_exr(path), read_exr_layers(path)
    assert ours.keys() == theirs.keys()
    for part, channels in theirs.items():
        assert ours[part].keys() == channels.keys()
        for name, pixels in channels.items():
            assert ours[part][name].shape == pixels.shape
            assert np.array_equal(ours[part][name], pixels.astype(np.float32)), (part, name)


@pytest.mark.slow
@pytest.mark.parametrize("kind", [(True, "ZIP", "32"), (True, "ZIPS", "16"), (True, "NONE", "32"),
                                  (False, "ZIP", "16")])
def test_blender_s_renders_read_as_openexr_reads_them(blender_renders, kind):
    _same(blender_renders[kind])


@pytest.mark.slow
def test_another_compression_is_refused_by_name(blender_renders):
    with pytest.raises(ExrError, match="PIZ-compressed; this reader takes ZIP, ZIPS or none"):
        read_exr(blender_renders[(True, "PIZ", "32")])


@pytest.mark.parametrize("compression", [OpenEXR.ZIP_COMPRESSION, OpenEXR.ZIPS_COMPRESSION,
                                         OpenEXR.NO_COMPRESSION])
def test_every_pixel_type_and_a_short_last_chunk(tmp_path, compression):
    rng = np.random.default_rng(5)
    h, w = 37, 23  # 37 lines: two chunks of 16 and one of 5
    ids = rng.integers(0, 2 ** 31, (h, w)).astype(np.uint32)
    channels = {"R": rng.normal(size=(h, w)).astype(np.float32), "G": rng.normal(size=(h, w)).astype(np.float16),
                "id": ids,
                "flat": np.zeros((h, w), np.float32)}  # compresses to less than its bytes
    path = tmp_path / "kinds.exr"
    with OpenEXR.File({"compression": compression, "type": OpenEXR.scanlineimage}, channels) as f:
        f.write(str(path))
    _same(path)
    [part] = read_exr(path).values()
    assert np.array_equal(part["id"], ids.astype(np.float32))


def test_files_it_cannot_read_are_refused_with_a_reason(tmp_path):
    path = tmp_path / "a.exr"
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"R": np.ones((40, 8), np.float32)}) as f:
        f.write(str(path))
    data = path.read_bytes()
    cut = tmp_path / "cut.exr"
    cut.write_bytes(data[:-30])
    with pytest.raises(ExrError, match="ends early|unpacked|Error"):
        read_exr(cut)
    text = tmp_path / "text.exr"
    text.write_text("not an image")
    with pytest.raises(ExrError, match="is not an EXR file"):
        read_exr(text)
    empty = tmp_path / "empty.exr"
    empty.write_bytes(b"")
    with pytest.raises(ExrError, match="ends early"):
        read_exr(empty)
