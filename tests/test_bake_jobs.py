"""A stack's tables baked beside the interface (blender/bake_jobs.py): with the interface, an edit of a stack's
material returns before its bake and the material takes the tables when the timer finds them done; a drag
bakes the values it settles on, not every one it passed; a render, started from the main thread or from a
render's own thread, waits for the bake and renders the edited look; without the interface (a batch
render) an edit bakes at once."""
from __future__ import annotations

import threading
import time

import bpy
import numpy as np
import pytest

import layered_brdf_addon

from layered_brdf_addon.blender import bake_jobs, freshness
from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_addon.blender.material_values import params_of, settings
from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, render_passes, reset_blender
from layered_brdf_addon.blender.sync import desired
from layered_brdf_addon.blender.tables import tables_current
from layered_brdf_addon.model import preset, table_check

from blender_helpers import addon  # noqa: F401 (the fixture: registered, then unregistered)

pytestmark = pytest.mark.slow

# A disordered stack (its bake: a few tenths of a second) that renders as a clear colour under the sun
STACK = preset("jewel_beetle").replace(e0=300.0)
STACK = STACK.replace(stack=STACK.stack.to_dict() | {"disorder": 0.05, "periods": 4})
HEIGHT = 32


def _scene():
    reset_blender()
    layered_brdf_addon.register()  # the panel's settings, whose edits sync the material
    (obj,) = build_scene(SceneSpec(camera=camera_for(1, HEIGHT), samples=1))
    return obj


def _current(mat) -> bool:
    params, _, plan = desired(mat)
    return tables_current(shader_node(mat).node_tree, params, plan)


def _forget_bakes():
    table_check._checked.clear()


def test_an_edit_returns_before_its_bake_and_the_material_takes_the_tables_when_done():
    mat = apply_layered_material(_scene(), STACK, "nodes")
    _forget_bakes()
    with bake_jobs.deferred():
        settings(mat).stack_disorder = 0.1
        assert params_of(mat).stack.disorder == pytest.approx(0.1)
        assert bake_jobs.baking_any() and not _current(mat)  # the edit did not wait for the bake
        assert bake_jobs.finish(timeout=60.0)
    assert _current(mat) and not bake_jobs.baking_any()
    edited, stack = render_passes().beauty, params_of(mat).stack.to_dict()
    reference = apply_layered_material(_scene(), STACK.replace(stack=stack), "nodes")
    assert _current(reference)
    assert edited.max() > 0.05  # a lit sphere
    np.testing.assert_allclose(edited, render_passes().beauty, rtol=0, atol=1e-6)


def test_a_drag_bakes_the_values_it_settles_on():
    mat = apply_layered_material(_scene(), STACK, "nodes")
    _forget_bakes()
    baked = []
    real = table_check.bake

    def counting(params, plan):
        baked.append(params.stack.disorder)
        return real(params, plan)

    table_check.bake = counting
    try:
        with bake_jobs.deferred():
            for k in range(1, 9):
                settings(mat).stack_disorder = 0.02 * k
            assert bake_jobs.finish(timeout=120.0)
    finally:
        table_check.bake = real
    print(f"baked the disorders {baked} of 8 asked for")
    assert baked[-1] == pytest.approx(0.16) and len(baked) <= 3  # the first (it had started), maybe one, the last
    assert _current(mat) and params_of(mat).stack.disorder == pytest.approx(0.16)


def test_a_render_from_another_thread_waits_for_the_bake_and_the_main_thread_s_timer():
    """As a render started from the interface: its handler, on the render's thread, holds it until the timer on
    the main thread has given the material its tables."""
    mat = apply_layered_material(_scene(), STACK, "nodes")
    _forget_bakes()
    with bake_jobs.deferred():
        settings(mat).stack_disorder = 0.15
        assert not _current(mat)
        render_thread = threading.Thread(target=freshness.before_render, args=(bpy.context.scene,))
        render_thread.start()
        deadline = time.monotonic() + 60.0
        while render_thread.is_alive() and time.monotonic() < deadline:  # the interface's event loop
            if bake_jobs.baking_any():
                bake_jobs.poll()
            time.sleep(0.02)
        render_thread.join(timeout=1.0)
        assert not render_thread.is_alive()
        assert _current(mat)  # when the render's thread went on, the tables were there


def test_a_render_on_the_main_thread_waits_for_the_bake():
    mat = apply_layered_material(_scene(), STACK, "nodes")
    _forget_bakes()
    with bake_jobs.deferred():
        settings(mat).stack_disorder = 0.12
        assert not _current(mat)
        freshness.before_render(bpy.context.scene)
        assert _current(mat)


def test_without_the_interface_an_edit_bakes_at_once():
    mat = apply_layered_material(_scene(), STACK, "nodes")
    assert bpy.app.background and not bake_jobs.deferring(desired(mat)[2])
    settings(mat).stack_disorder = 0.07
    assert _current(mat) and not bake_jobs.baking_any()
