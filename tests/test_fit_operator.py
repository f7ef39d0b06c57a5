"""*Fit to Render...*: the panel's fit of a layered material to a render or a Principled material.

The fits here are short (a few free parameters, one thickness order): what is tested is the
operator's path -- the target read or rendered, the fit in its own thread or at once, the
result applied as a preset is, a cancel that changes nothing.  That the installed extension fits
in a Python without SciPy or colour-science is tests/test_extension.py's.  How well fits match is
tests/test_fit.py's and tests/test_principled_target.py's.
"""
from __future__ import annotations

import json
import time
from types import SimpleNamespace

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender import fit_operator, lookdev, tables, ui
from layered_brdf_addon.fit import structures
from layered_brdf_addon.blender.material_values import is_layered, params_of, settings
from layered_brdf_addon.blender.stored_keys import BUILD_KEY
from layered_brdf_addon.blender.sync import apply_to_object
from layered_brdf_addon.blender.material import input_value, shader_node
from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_to_exr, reset_blender,
                                              row_of_spheres)
from layered_brdf_addon.io.sidecar import SIDECAR_FORMAT, camera_to_dict, sun_to_dict, write_json
from layered_brdf_addon.blender.sidecar_views import sidecar_views
from layered_brdf_addon.fit.solve import FitCancelled
from layered_brdf_addon.fit.targets import TargetError
from layered_brdf_addon.model.presets import preset
from layered_brdf_reference.fit_cases import SUNS, views_of

from blender_helpers import addon, add_sphere, load_preset

SHORT = {"starts": 1, "steps_per_start": 15, "vary": ("d_min", "d_max", "kd")}
START = preset("oil_slick").replace(thickness_mode="height")
TRUTH = START.replace(d_min=250.0, d_max=420.0, kd=0.5)


def layered_object(name="oil_slick"):
    obj = add_sphere()
    mat = load_preset(obj, name)
    return obj, mat


def state(mat):
    """What a fit may change: the parameters, the build and the shader node."""
    node = shader_node(mat)
    return params_of(mat).to_dict(), mat.get(BUILD_KEY), node.as_pointer()


def test_the_function_fits_a_numpy_target_and_applies_the_result():
    _, mat = layered_object()
    result = fit_operator.fit_material_to(mat, views_of(TRUTH, SUNS), START, **SHORT)
    assert result.mean_delta_e <= 0.5
    fitted = params_of(mat)
    node = shader_node(mat)
    for name in ("d_min", "d_max", "kd"):
        assert input_value(node, name) == pytest.approx(getattr(result.params, name), rel=1e-5)
        assert getattr(fitted, name) == pytest.approx(getattr(TRUTH, name), rel=0.05)
    assert fitted.thickness_mode == "height" and settings(mat).thickness_mode == "height"
    assert settings(mat).preset == ""
    bpy.context.view_layer.update()  # the panel's handler finds the material in step with its settings
    assert params_of(mat).to_dict() == fitted.to_dict()


def test_a_cancelled_fit_changes_nothing():
    _, mat = layered_object()
    before = state(mat)
    with pytest.raises(FitCancelled):
        fit_operator.fit_material_to(mat, views_of(TRUTH), START, should_stop=lambda: True, **SHORT)
    assert state(mat) == before
    # The operator's thread, stopped by the main thread while it runs (Esc).
    job = fit_operator.FitJob(views_of(TRUTH), START, dict(SHORT)).begin()
    while job.evaluations < 3 and not job.done:
        time.sleep(0.01)
    job.stop()
    job.wait()
    assert isinstance(job.error, FitCancelled) and job.result is None
    assert state(mat) == before


class Recorder:
    """Stands in for the window manager and the workspace: records the calls made to it."""

    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *args, **kw: self.calls.append((name, *args))


class RunningFit:
    """The operator as Blender runs it modally, with its own methods (no event loop here)."""

    Op = fit_operator.LAYERED_BRDF_OT_fit_to_render
    modal, cancel, _status, _end_progress, _finish = Op.modal, Op.cancel, Op._status, Op._end_progress, Op._finish

    def __init__(self, mat, options, start=START):
        self._job = fit_operator.FitJob(views_of(TRUTH), start, options).begin()
        self._timer = "timer"
        self._total = None if start is None else fit_operator.expected_evaluations(start, **options)
        self._target_kind, self._target_pointer, self._target_name = "materials", mat.as_pointer(), mat.name
        self.reports = []

    def report(self, kind, text):
        self.reports.append((next(iter(kind)), text))

    def run(self, context, events=()):
        """Events, then timer ticks until the operator ends; what it returned last."""
        for event in events:
            self.modal(context, event)
        while True:
            time.sleep(0.05)
            result = self.modal(context, SimpleNamespace(type="TIMER", value="NOTHING"))
            if result != {"PASS_THROUGH"}:
                return result


def modal_context():
    return SimpleNamespace(window_manager=Recorder(), workspace=Recorder())


def test_the_modal_fit_shows_its_progress_and_applies_the_result():
    _, mat = layered_object()
    context = modal_context()
    op = RunningFit(mat, {"starts": 0, "steps_per_start": 4, "vary": ("kd",)})
    assert op.run(context) == {"FINISHED"}
    assert params_of(mat).kd == pytest.approx(op._job.result.params.kd)
    [(kind, text)] = op.reports
    assert kind == "INFO" and "mean CIEDE2000" in text
    wm = [c[0] for c in context.window_manager.calls]
    assert wm[-2:] == ["event_timer_remove", "progress_end"] and set(wm[:-2]) <= {"progress_update"}
    assert context.workspace.calls[-1] == ("status_text_set", None)


def test_choosing_the_structure_shows_its_stages_and_applies_the_closest(monkeypatch):
    """With no start (the dialog's "Choose the Structure") the fit screens the structures and fits the
    finalists; the status bar says which stage, the bar only moves forward, the closest is applied."""
    _, mat = layered_object("soap_bubble")
    pool = [c for c in structures.candidates(thickness_mode="height")
            if c.preset in ("oil_slick", "soap_bubble", "fig4_parallel") and c.start.normal_mode == "parallel"
            and c.start.lower_medium in ("water", "air", "custom")]
    assert len(pool) == 3, [c.label for c in pool]
    monkeypatch.setattr(structures, "structure_pool", lambda **kw: pool)
    context = modal_context()
    op = RunningFit(mat, {"starts": 1, "steps_per_start": 8}, start=None)
    assert op.run(context) == {"FINISHED"}
    fitted = params_of(mat)
    assert (fitted.optics, fitted.lower_medium) == (TRUTH.optics, TRUTH.lower_medium)  # the oil film's structure
    shares = [c[1] for c in context.window_manager.calls if c[0] == "progress_update"]
    assert shares == sorted(shares) and all(0.0 <= x < 1.0 for x in shares)
    texts = [c[1] for c in context.workspace.calls if c[0] == "status_text_set" and c[1]]
    assert any("screening structure" in t for t in texts), texts


def test_the_selection_s_share_of_the_bar_grows_with_its_stages():
    stages = ([f"screen {k}/45" for k in range(1, 46)] + [f"fit {k}/3" for k in range(1, 4)]
              + [f"refine {k}/3" for k in range(1, 4)] + ["noise 1/1"])
    shares = [fit_operator.selection_share(s) for s in stages]
    assert shares == sorted(shares) and len(set(shares)) == len(shares) and shares[0] == 0.0 and shares[-1] < 1.0
    assert fit_operator.selection_share("") == 0.0 and fit_operator.selection_share("later 1/2") == 0.0
    assert fit_operator.stage_words("refine 2/3") == "refining finalist 2/3"


def test_esc_stops_the_modal_fit_with_nothing_changed():
    _, mat = layered_object()
    before = state(mat)
    context = modal_context()
    op = RunningFit(mat, dict(SHORT))
    esc = SimpleNamespace(type="ESC", value="PRESS")
    assert op.modal(context, SimpleNamespace(type="MOUSEMOVE", value="NOTHING")) == {"PASS_THROUGH"}
    assert op.run(context, [esc]) == {"CANCELLED"}
    assert op.reports == [("WARNING", f"Fit cancelled: '{mat.name}' is unchanged")]
    assert ("status_text_set", "Layered BRDF: stopping the fit...") in context.workspace.calls
    assert context.workspace.calls[-1] == ("status_text_set", None)
    assert state(mat) == before


def test_the_panel_offers_the_fit_and_its_dialog_draws_the_operator_s_own_settings():
    log = []
    layout = SimpleNamespace(operator=lambda idname, **kw: log.append(idname))
    ui.draw_fit_row(layout)
    assert log == ["layered_brdf.fit_to_render"]
    op = fit_operator.LAYERED_BRDF_OT_fit_to_render
    for source, shown in (("RENDER", ["source", "filepath", "sphere", "start"]),
                          ("PRINCIPLED", ["source", "principled", "start"])):
        drawn = []
        dialog = SimpleNamespace(use_property_split=False, prop=lambda data, name, **kw: drawn.append(name))
        dialog.row = lambda **kw: dialog
        op.draw(SimpleNamespace(layout=dialog, source=source), bpy.context)
        assert drawn == shown
        assert all(name in bpy.ops.layered_brdf.fit_to_render.get_rna_type().properties for name in drawn)


def reference_render(tmp_path, params, name="target"):
    """A Cycles render of ``params`` on the reference sphere, with its sidecar: the files of
    ``layered-brdf render`` (a multilayer EXR and STEM.json)."""
    from layered_brdf_addon.blender.material import apply_layered_material

    camera, sun = camera_for(1, 64), SUNS[1]
    [sphere] = build_scene(SceneSpec(camera=camera, sun=sun))
    apply_layered_material(sphere, params)
    stem = tmp_path / name
    render_to_exr(stem.with_suffix(".exr"))
    write_json(stem.with_suffix(".json"), {
        "format": SIDECAR_FORMAT, "version": 1, "scene": "reference", "params": params.to_dict(),
        "camera": camera_to_dict(camera), "sun": sun_to_dict(sun), "centers": [[0.0, 0.0, 0.0]],
        "outputs": {"exr": stem.with_suffix(".exr"), "json": stem.with_suffix(".json")}})
    return stem.with_suffix(".json")


@pytest.mark.slow
def test_the_operator_fits_to_a_render_s_sidecar(tmp_path, monkeypatch):
    sidecar = reference_render(tmp_path, TRUTH)
    [view] = sidecar_views(sidecar)
    assert view.image.shape == (64, 64, 3) and view.image.max() > 0.0
    reset_blender()
    obj, mat = layered_object()
    apply_to_object(obj, START)
    monkeypatch.setattr(fit_operator, "FIT_OPTIONS", SHORT)
    assert bpy.ops.layered_brdf.fit_to_render(source="RENDER", filepath=str(sidecar), start="CURRENT") == {"FINISHED"}
    fitted = params_of(mat)
    # One sun shows the film's mean thickness (its order), less so how far it spreads.
    assert fitted.d_min + fitted.d_max == pytest.approx(TRUTH.d_min + TRUTH.d_max, rel=0.1)
    assert (fitted.d_min, fitted.d_max) != (START.d_min, START.d_max)


@pytest.mark.slow
def test_the_operator_fits_to_a_principled_material_of_the_file(monkeypatch):
    obj = add_sphere()
    film = lookdev.principled_thin_film("Oil film", 300.0, 1.47, (0.05, 0.05, 0.06), 0.0, 0.2)
    assert obj.active_material is None
    kinds = ("scenes", "objects", "meshes", "cameras", "lights", "worlds", "images")
    before = {k: {b.as_pointer() for b in getattr(bpy.data, k)} for k in kinds}
    monkeypatch.setattr(fit_operator, "FIT_OPTIONS", SHORT)
    result = bpy.ops.layered_brdf.fit_to_render(source="PRINCIPLED", principled=film.name, start="oil_slick")
    assert result == {"FINISHED"}
    mat = obj.active_material
    assert is_layered(mat) and params_of(mat).thickness_mode == "height"
    after = {k: {b.as_pointer() for b in getattr(bpy.data, k)} for k in kinds}
    # The fitted material's baked tables are its own (stamped); nothing else is left.
    after["images"] -= {i.as_pointer() for i in bpy.data.images if tables.DIGEST_KEY in i and i.users > 0}
    assert after == before
    assert film.users == 0  # lent to the target's sphere, given back


@pytest.mark.slow
def test_choosing_the_structure_for_a_principled_material_tries_the_structures_of_its_surface(monkeypatch):
    """A metallic Principled BSDF: the selection is told the surface is a metal (only films over a metal
    are screened); a stop there leaves nothing applied."""
    obj = add_sphere()
    film = lookdev.principled_thin_film("Metal film", 200.0, 2.4, (0.54, 0.5, 0.45), 1.0, 0.2)
    heard = {}

    def selection(views, **options):
        heard.update(options)
        raise FitCancelled()

    monkeypatch.setattr(fit_operator, "run_selection", selection)
    result = bpy.ops.layered_brdf.fit_to_render(source="PRINCIPLED", principled=film.name, start="CHOOSE")
    assert result == {"CANCELLED"} and heard["surface"] == "metal" and heard["try_noise"] is False
    assert heard["uniform_film"] is True  # a film of one thickness: fitted as one, over a parallel boundary
    assert obj.active_material is None


def test_a_target_that_cannot_be_fitted_is_refused_with_nothing_changed(tmp_path):
    obj, mat = layered_object()
    before = state(mat)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(RuntimeError, match="bad.json"):
        bpy.ops.layered_brdf.fit_to_render(source="RENDER", filepath=str(bad), start="CURRENT")
    black = lookdev.principled_thin_film("Black", 0.0, 1.0, (0.0, 0.0, 0.0), 0.0, 1.0)
    black.node_tree.nodes["Principled BSDF"].inputs["Specular IOR Level"].default_value = 0.0
    with pytest.raises(RuntimeError, match="black"):
        bpy.ops.layered_brdf.fit_to_render(source="PRINCIPLED", principled=black.name, start="CURRENT")
    assert state(mat) == before


def test_a_sidecar_that_is_not_a_reference_render_says_why(tmp_path):
    cases = {"garbled.json": "{not json", "blend.json": json.dumps({"format": SIDECAR_FORMAT, "scene": "blend"})}
    for name, text in cases.items():
        (tmp_path / name).write_text(text)
    with pytest.raises(TargetError, match="not JSON"):
        sidecar_views(tmp_path / "garbled.json")
    with pytest.raises(TargetError, match="reference-sphere"):
        sidecar_views(tmp_path / "blend.json")
    with pytest.raises(TargetError, match="missing.json"):
        sidecar_views(tmp_path / "missing.json")
    camera, sun = camera_for(2, 16), SUNS[0]
    write_json(tmp_path / "gallery.json", {
        "format": SIDECAR_FORMAT, "scene": "gallery", "tiles": [{"params": {}}, {"params": {}}],
        "camera": camera_to_dict(camera), "sun": sun_to_dict(sun), "centers": row_of_spheres(2)})
    with pytest.raises(TargetError, match="2 sphere"):
        sidecar_views(tmp_path / "gallery.json", sphere=2)
    with pytest.raises(TargetError, match="EXR"):
        sidecar_views(tmp_path / "gallery.json", sphere=1)
    (tmp_path / "gallery.exr").write_bytes(b"")
    [view] = sidecar_views(tmp_path / "gallery.json", sphere=1, read_beauty=lambda p: np.ones((16, 32, 3)))
    assert view.sphere == 1 and view.camera.width == 32
