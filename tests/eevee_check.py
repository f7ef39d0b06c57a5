"""Render one sphere carrying the add-on's node-group material with Cycles, then with EEVEE.

Run as a subprocess by tests/test_ui.py (EEVEE needs a GL context: headless, EGL with
Mesa's software rasteriser).  Usage: ``python tests/eevee_check.py OUT.npz [ACCURACY]``;
writes the two beauty passes (rows top to bottom) and the EEVEE render time.  With an
accuracy mode (``spectral32``...) the material is the preset in that mode, applied through
``apply_layered_material``; without, the panel's preset operator applies it in RGB.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
PRESET = "fig4_parallel"
HEIGHT = 64
SUN_DIRECTION = (0.0, -np.cos(np.radians(40.0)), np.sin(np.radians(40.0)))


def configure_eevee(scene) -> None:
    """EEVEE at its cheapest: one sample, no shadows, ray tracing, GI or motion blur (the
    highlight needs none of them; software GL spends minutes on them otherwise)."""
    scene.render.engine = "BLENDER_EEVEE"
    e = scene.eevee
    e.taa_render_samples = 1
    e.use_shadows = False
    e.use_raytracing = False
    e.use_fast_gi = False
    e.shadow_pool_size = "16"
    e.gi_irradiance_pool_size = "16"
    scene.render.use_motion_blur = False


def main(out: str, accuracy: str | None = None) -> None:
    sys.path.insert(0, str(ROOT))
    import bpy

    import layered_brdf_addon
    from layered_brdf_addon.blender.scene import SceneSpec, build_scene, camera_for, render_passes, reset_blender
    from layered_brdf_addon.model.sphere import Sun

    reset_blender()
    layered_brdf_addon.register()
    cam = camera_for(1, HEIGHT)
    [sphere] = build_scene(SceneSpec(camera=cam, sun=Sun(direction=SUN_DIRECTION, strength=1.0)))
    bpy.context.view_layer.objects.active = sphere
    if accuracy is None:
        bpy.ops.layered_brdf.load_preset(preset=PRESET)
    else:
        from layered_brdf_addon.blender.material import apply_layered_material
        from layered_brdf_addon.model import preset

        apply_layered_material(sphere, preset(PRESET).replace(accuracy=accuracy), "nodes")
    cycles = render_passes()
    configure_eevee(bpy.context.scene)
    t0 = time.perf_counter()
    eevee = render_passes()
    seconds = time.perf_counter() - t0
    layered_brdf_addon.unregister()
    np.savez(out, cycles=cycles.beauty, eevee=eevee.beauty, eevee_seconds=seconds)


if __name__ == "__main__":
    main(sys.argv[1], *sys.argv[2:3])
