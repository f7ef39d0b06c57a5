"""Looks in the Asset Browser: the library of material assets (one per preset) and its catalogs,
previews, what a dropped look carries, rewriting and refusing, and node groups that are no
longer assets."""
from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

import layered_brdf_addon
from layered_brdf_addon.blender.asset_library import (CATALOG_FILE, LIBRARY_FILE, LIBRARY_NAME, MANIFEST_FILE,
                                                      all_catalogs, read_catalogs, registered_library,
                                                      write_asset_library)
from layered_brdf_addon.blender import assets, library_folder, ui, user_presets
from layered_brdf_addon.blender.material_values import layered_material_of, params_of, settings
from layered_brdf_addon.blender.sync import apply_to_object, material_problem, sync_material
from layered_brdf_addon.blender.scene import reset_blender
from layered_brdf_addon.blender.material import shader_node
from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.model.params import LayeredParams, ParameterError
from layered_brdf_addon.model.presets import ARTIST_PRESETS, PAPER_PRESETS, STACK_PRESETS, preset, preset_label

from blender_helpers import addon, user_dir, add_sphere, load_preset

ROOT = Path(__file__).resolve().parents[1]
STAMP = node_group_builder.STAMP_KEY
SMALL = ["anodised_titanium", "fig4_tilted"]
SESSION_IMAGES = {"Render Result", "Viewer Node"}
COLLECTIONS = ("materials", "node_groups", "scenes", "objects", "meshes", "cameras", "lights", "worlds", "images",
               "texts")


@pytest.fixture(scope="module")
def small_library(tmp_path_factory):
    """Two looks with tiny previews (24 px, 2 samples), written once for the module."""
    reset_blender()
    return write_asset_library(tmp_path_factory.mktemp("library"), SMALL, preview_size=24, samples=2)


def datablocks():
    return {c: sorted(b.name for b in getattr(bpy.data, c) if b.name not in SESSION_IMAGES) for c in COLLECTIONS}


def append_materials(path, names=None):
    with bpy.data.libraries.load(str(path), link=False) as (src, dst):
        dst.materials = [n for n in src.materials if names is None or n in names]
    return {m.name: m for m in dst.materials}


def library_names(path):
    with bpy.data.libraries.load(str(path), assets_only=True) as (src, _dst):
        return sorted(src.materials)


def assert_same_params(got: LayeredParams, want: LayeredParams):
    g, w = got.to_dict(), want.to_dict()
    assert g.keys() == w.keys()
    for key, value in w.items():
        if isinstance(value, float):
            assert g[key] == pytest.approx(value, rel=1e-5, abs=1e-6), key
        else:
            assert g[key] == value, key


class Recorder:
    """Stands in for a panel's UILayout: records the operators drawn, accepts everything else."""

    def __init__(self, log):
        self.log = log

    def operator(self, idname, text="", **_):
        self.log.append((idname, text))
        return SimpleNamespace()

    def __getattr__(self, name):
        return lambda *args, **kwargs: Recorder(self.log)


def panel_operators(obj):
    log = []
    ui.draw_material(Recorder(log), SimpleNamespace(object=obj, scene=bpy.context.scene))
    return log


def listing(path):
    return sorted(p.name for p in Path(path).iterdir())


# --- the library ------------------------------------------------------------------------------------
def test_every_preset_and_user_preset_is_a_named_look_in_a_written_catalog(tmp_path, user_dir):
    user_presets.save_user_preset("Blue film", preset("soap_bubble").replace(d_min=300.0))
    libs = bpy.context.preferences.filepaths.asset_libraries
    prefs_before = [(lib.name, lib.path) for lib in libs]
    folder = tmp_path / "looks"
    try:
        assert bpy.ops.layered_brdf.build_asset_library(directory=str(folder), include_user_presets=True,
                                                        register_library=True, preview_size=0) == {"FINISHED"}
        added = registered_library(folder)
        assert added is not None and added.name == LIBRARY_NAME
        assert len(libs) == len(prefs_before) + 1
    finally:
        for lib in list(libs):
            if (lib.name, lib.path) not in prefs_before:
                libs.remove(lib)
    assert [(lib.name, lib.path) for lib in libs] == prefs_before

    assert listing(folder) == sorted([LIBRARY_FILE, CATALOG_FILE, MANIFEST_FILE])
    expected = {preset_label(n): n for n in [*ARTIST_PRESETS, *STACK_PRESETS, *PAPER_PRESETS]} | \
        {"Blue film": "user:Blue film"}
    assert library_names(folder / LIBRARY_FILE) == sorted(expected)
    cats = read_catalogs(folder / CATALOG_FILE)
    assert {path for path, _ in cats.values()} == {"Layered BRDF", "Layered BRDF/Artist looks",
                                                  "Layered BRDF/Paper figures", "Layered BRDF/Structural colours",
                                                  "Layered BRDF/User presets"}
    catalog_of = {"artist": "Layered BRDF/Artist looks", "paper": "Layered BRDF/Paper figures",
                  "structural": "Layered BRDF/Structural colours", "user": "Layered BRDF/User presets"}
    reset_blender()
    looks = append_materials(folder / LIBRARY_FILE)
    assert sorted(looks) == sorted(expected)
    for name, ident in expected.items():
        mat = looks[name]
        data = mat.asset_data
        assert data is not None, name
        assert cats[data.catalog_id][0] == catalog_of[assets.kind_of(ident)], name
        assert data.author == assets.AUTHOR and data.description.startswith(name + ":")
        assert data.license == assets.LICENSE and data.copyright == assets.COPYRIGHT
        assert {t.name for t in data.tags} >= set(assets.BASE_TAGS)
        assert mat.preview is None or tuple(mat.preview.image_size) == (0, 0)  # written without previews
        assert settings(mat).preset == ident
        assert_same_params(params_of(mat), user_presets.preset_params(ident))


def test_previews_show_the_ball_in_colour(small_library):
    assert small_library.assets == {preset_label(n): n for n in SMALL}
    assert len(small_library.preview_seconds) == len(SMALL)
    looks = append_materials(small_library.blend)
    for name, mat in looks.items():
        assert tuple(mat.preview.image_size) == (24, 24), name
        px = np.array(mat.preview.image_pixels_float[:], dtype=np.float64).reshape(24, 24, 4)
        alpha = px[..., 3]
        covered = alpha > 0.99
        assert 0.15 < covered.mean() < 0.9, (name, covered.mean())  # the ball, on a clear background
        assert max(alpha[0, 0], alpha[0, -1], alpha[-1, 0], alpha[-1, -1]) < 0.01, name
        rgb = px[covered][:, :3]
        assert rgb.mean() > 0.05, name  # lit
        assert (rgb.max(axis=1) - rgb.min(axis=1)).max() > 0.05, name  # and coloured, not grey
    pixels = [np.array(m.preview.image_pixels_float[:]) for m in looks.values()]
    assert np.abs(pixels[0] - pixels[1]).max() > 0.1  # each look its own preview


def test_a_look_dropped_on_an_object_carries_its_preset(small_library):
    obj = add_sphere("Teapot")
    mat = append_materials(small_library.blend, {"Anodised titanium"})["Anodised titanium"]
    obj.data.materials.append(mat)
    assert layered_material_of(obj) is mat
    assert_same_params(params_of(mat), preset("anodised_titanium"))
    assert settings(mat).preset == "anodised_titanium"
    assert material_problem(mat) is None
    assert sync_material(mat) is False  # built for its values already: nothing to rebuild
    group = shader_node(mat).node_tree
    assert group.get(STAMP) is not None and group.asset_data is None and not group.use_fake_user
    # Editing it from the panel works as on any layered material.
    assert bpy.ops.layered_brdf.load_preset(preset="oil_slick") == {"FINISHED"}
    assert_same_params(params_of(obj.active_material), preset("oil_slick"))


def test_rewriting_replaces_its_own_files_keeps_other_catalogs_and_the_artists_data(tmp_path):
    folder = tmp_path / "looks"
    # The artist's own material holding a look's name, and the node group the look will share.
    mine = load_preset(add_sphere("Jar", u_segments=8, v_segments=4), "glazed_clay")
    mine.name = "Glazed clay"
    mine["mine"] = 1
    group, values = shader_node(mine).node_tree, params_of(mine)
    before = datablocks()
    first = write_asset_library(folder, ["glazed_clay"], preview_size=0)
    assert datablocks() == before and bpy.data.materials["Glazed clay"] is mine and mine["mine"] == 1
    assert shader_node(mine).node_tree == group and params_of(mine) == values
    assert first.assets == {"Glazed clay": "glazed_clay"}
    cats_path = folder / CATALOG_FILE
    foreign = "0d3b8a3c-2d6e-4f5a-9d4e-9d0b5a1c2e3f:Props/Chairs:Props-Chairs"
    cats_path.write_text(cats_path.read_text() + "\n# the artist's catalogs\n" + foreign + "\n")
    steps = []
    second = write_asset_library(folder, ["glazed_clay", "oil_slick"], preview_size=0,
                                    progress=lambda done, total: steps.append((done, total)))
    assert steps == [(1, 2), (2, 2)]
    assert datablocks() == before
    assert listing(folder) == sorted([LIBRARY_FILE, CATALOG_FILE, MANIFEST_FILE])  # no temporary files
    assert library_names(second.blend) == ["Glazed clay", "Oil slick"]
    text = cats_path.read_text()
    assert text.count(foreign) == 1 and "# the artist's catalogs" in text
    for catalog in all_catalogs():
        assert text.count(catalog.uuid) == 1
    cats = read_catalogs(cats_path)
    assert cats["0d3b8a3c-2d6e-4f5a-9d4e-9d0b5a1c2e3f"] == ("Props/Chairs", "Props-Chairs")
    manifest = json.loads((folder / MANIFEST_FILE).read_text())
    assert manifest["files"][LIBRARY_FILE] == [hashlib.sha256(second.blend.read_bytes()).hexdigest()]


def test_a_blend_the_library_did_not_write_is_refused_and_left_untouched(tmp_path, small_library):
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    artist = bpy.data.materials.new("Artist red")
    bpy.data.libraries.write(str(foreign / LIBRARY_FILE), {artist})
    (foreign / CATALOG_FILE).write_text("VERSION 1\n")
    changed = tmp_path / "changed"
    shutil.copytree(small_library.directory, changed)
    with open(changed / LIBRARY_FILE, "ab") as f:  # the library's file, edited since it was written
        f.write(b"\0")
    for folder in (foreign, changed):
        files = {p.name: p.read_bytes() for p in folder.iterdir()}
        before = datablocks()
        with pytest.raises(ParameterError) as e:
            write_asset_library(folder, ["glazed_clay"], preview_size=0)
        assert e.value.name == "directory" and LIBRARY_FILE in str(e.value)
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == files
        assert datablocks() == before


def test_a_failure_leaves_no_partial_files_and_the_session_as_it_was(tmp_path, monkeypatch, small_library):
    mine = load_preset(add_sphere("Puddle", u_segments=8, v_segments=4), "oil_slick")
    mine.name = "Oil slick"  # the artist's material holding the look's name, sharing its node group
    before = datablocks()

    def broken(*_args, **_kwargs):
        raise RuntimeError("the preview render failed")

    monkeypatch.setattr(assets, "render_previews", broken)
    with pytest.raises(RuntimeError, match="preview render failed"):
        write_asset_library(tmp_path / "new", ["oil_slick"], preview_size=16, samples=1)
    assert not (tmp_path / "new").exists()
    assert datablocks() == before and bpy.data.materials["Oil slick"] is mine
    monkeypatch.undo()
    # Failing after the new .blend was written, over an existing library: the old one stays, whole.
    folder = tmp_path / "existing"
    shutil.copytree(small_library.directory, folder)
    files = {p.name: p.read_bytes() for p in folder.iterdir()}
    real_sha256 = library_folder.sha256

    def sha256_fails_on_the_new_file(path):
        if path.name.startswith(".layered_brdf_partial_"):
            raise OSError("disk full")
        return real_sha256(path)

    monkeypatch.setattr(library_folder, "sha256", sha256_fails_on_the_new_file)
    with pytest.raises(OSError, match="disk full"):
        write_asset_library(folder, ["oil_slick"], preview_size=0)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == files
    assert datablocks() == before


def test_bad_input_names_the_parameter_and_writes_nothing(tmp_path):
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    cases = [(dict(directory=a_file), "directory"), (dict(directory=tmp_path / "no" / "such"), "directory"),
             (dict(directory=tmp_path / "d", presets=["no_such_look"]), "preset"),
             (dict(directory=tmp_path / "d", presets=[]), "presets"),
             (dict(directory=tmp_path / "d", presets="oil_slick"), "presets"),
             (dict(directory=tmp_path / "d", preview_size=4), "preview_size"),
             (dict(directory=tmp_path / "d", preview_size=64, samples=0), "samples")]
    bad_cats = tmp_path / "bad_cats"
    bad_cats.mkdir()
    (bad_cats / CATALOG_FILE).write_text("VERSION 7\n")
    cases.append((dict(directory=bad_cats, presets=["oil_slick"], preview_size=0), "directory"))
    before = datablocks()
    for kwargs, name in cases:
        with pytest.raises(ParameterError) as e:
            write_asset_library(**kwargs)
        assert e.value.name == name, kwargs
    assert sorted(listing(tmp_path)) == ["bad_cats", "file.txt"] and listing(bad_cats) == [CATALOG_FILE]
    assert datablocks() == before


def test_the_command_line_entry(tmp_path):
    out = tmp_path / "cli"
    env_path = str(ROOT)
    proc = subprocess.run([sys.executable, "-m", "layered_brdf_addon.blender.asset_library", str(out),
                           "--presets", "glazed_clay", "--preview-size", "0"], cwd=env_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "1 looks in" in proc.stdout and library_names(out / LIBRARY_FILE) == ["Glazed clay"]
    bad = subprocess.run([sys.executable, "-m", "layered_brdf_addon.blender.asset_library", str(out),
                          "--preview-size", "3"], cwd=env_path, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "'preview_size' = 3" in bad.stderr and "[8, 512]" in bad.stderr


# --- looks in the current file -------------------------------------------------------------------------
def test_mark_material_as_asset_catalogs_by_preset_and_its_preview_follows_the_material(monkeypatch):
    monkeypatch.setattr(assets, "PREVIEW_SIZE", 24)
    monkeypatch.setattr(assets, "PREVIEW_SAMPLES", 2)
    obj = add_sphere("Vase", u_segments=8, v_segments=4)
    assert ("layered_brdf.build_asset_library", "Build Looks Library...") in panel_operators(obj)
    mat = load_preset(obj, "oil_slick")
    assert mat.asset_data is None
    assert ("layered_brdf.mark_asset", "Mark Material as Asset") in panel_operators(obj)
    assert bpy.ops.layered_brdf.mark_asset() == {"FINISHED"}
    drawn = panel_operators(obj)
    assert ("layered_brdf.mark_asset", "Update Asset") in drawn
    assert "layered_brdf.build_asset_library" in [idname for idname, _ in drawn]
    assert mat.asset_data.catalog_id == assets.CATALOGS["artist"].uuid
    assert tuple(mat.preview.image_size) == (24, 24)
    first = np.array(mat.preview.image_pixels_float[:])
    assert first.reshape(24, 24, 4)[..., 3].max() > 0.99
    # Loading a paper figure into the look: catalog and preview follow.
    load_preset(obj, "fig3_clay")
    assert mat.asset_data.catalog_id == assets.CATALOGS["paper"].uuid
    assert np.abs(np.array(mat.preview.image_pixels_float[:]) - first).max() > 0.1
    # Values of no preset: the user catalog (built as a synchronisation does: the preview waits).
    rendered = np.array(mat.preview.image_pixels_float[:])
    apply_to_object(obj, preset("fig3_clay").replace(d_max=120.0), preview=False)
    assert mat.asset_data.catalog_id == assets.CATALOGS["user"].uuid
    assert np.array_equal(np.array(mat.preview.image_pixels_float[:]), rendered)
    assert [s.name for s in bpy.data.scenes] == ["Scene"]  # the preview scene is gone


# --- node groups are not assets ---------------------------------------------------------------------
def test_presets_make_no_asset_groups_and_older_versions_marks_come_off(tmp_path):
    obj = add_sphere("Small", u_segments=8, v_segments=4)
    old = shader_node(load_preset(obj, "fig4_parallel")).node_tree
    old.asset_mark()  # as versions before looks marked the groups
    old.asset_data.catalog_id = assets.LEGACY_CATALOG_ID
    old.asset_data.author = assets.LEGACY_AUTHOR
    old[assets.LEGACY_PREVIEW_KEY] = "stamp"
    own = bpy.data.node_groups.new("My group", "ShaderNodeTree")  # the artist's asset: kept as it is
    own.asset_mark()
    own.asset_data.catalog_id = assets.LEGACY_CATALOG_ID
    path, name = tmp_path / "old.blend", old.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))  # the add-on's groups are released on load
    old = bpy.data.node_groups[name]
    assert old.asset_data is None and not old.use_fake_user and assets.LEGACY_PREVIEW_KEY not in old
    own = bpy.data.node_groups["My group"]
    assert own.asset_data is not None and own.use_fake_user
    # A mark older versions made is also taken off when the add-on next builds (the group stays in use).
    old.asset_mark()
    old.asset_data.author = assets.LEGACY_AUTHOR
    other = add_sphere("Other", u_segments=8, v_segments=4)
    for name in ("fig4_tilted", "oil_slick"):
        load_preset(other, name)
    assert shader_node(bpy.data.objects["Small"].active_material).node_tree == old
    assert old.asset_data is None and not old.use_fake_user
    stamped = [g for g in bpy.data.node_groups if g.get(STAMP) is not None]
    assert len(stamped) == 2 and all(g.asset_data is None and not g.use_fake_user for g in stamped)
    assert [g.name for g in bpy.data.node_groups if g.asset_data is not None] == ["My group"]
