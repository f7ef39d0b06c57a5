"""The OSL shader reading a material's baked tables, rendered: as the shader computing its closures and
as the node group reading the same tables, per pixel; and averaging over the pixel's footprint in the
analytic mode as the computing shader does.  Without the add-on registered, so that no handler
re-plans the plans these tests force."""
from __future__ import annotations

import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender import osl, scene
from layered_brdf_addon.blender.material import apply_layered_material, shader_node
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.sphere import Sun
from layered_brdf_reference.compare import agreement

from constants import MAX_FAILING, REL_TOL, SUN_40

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import bench_aliasing as alias  # noqa: E402

pytestmark = pytest.mark.slow

PRESETS = ("oil_slick", "anodised_titanium", "old_metal", "beetle_shell")


def _render(params_list, backend="osl"):
    scene.reset_blender()
    n = len(params_list)
    spheres = scene.build_scene(scene.SceneSpec(camera=scene.camera_for(n, 64), sun=SUN_40,
                                                centers=scene.row_of_spheres(n), samples=1, osl=True))
    mats = [apply_layered_material(o, p, backend, name=f"M{k}") for k, (o, p) in enumerate(zip(spheres, params_list))]
    return mats, scene.render_passes_osl()


def test_osl_tables_render_as_the_shader_computing_and_as_the_node_group():
    """Four artist presets under a sun: OSL reading tables vs OSL computing, and vs the node group reading
    the same tables (Cycles' Image Texture), per pixel."""
    params = [preset(n) for n in PRESETS]
    mats, tab = _render(params)
    assert all(osl.TABLES_KEY in shader_node(m).script for m in mats)
    _, computed = _render([p.replace(evaluation="arithmetic") for p in params])
    _, nodes = _render(params, "nodes")
    mask = computed.beauty[..., :3].sum(axis=-1) > 1e-3
    for other, name in ((computed, "computed"), (nodes, "node group")):
        ag = agreement(tab.beauty, other.beauty, mask, rel_tol=REL_TOL)
        print(f"OSL tables vs {name}: {ag}")
        assert ag.failing_fraction <= MAX_FAILING, (name, str(ag))


def test_osl_tables_average_over_the_pixel_footprint():
    """A far-away sphere of fine noise thickness (several features per pixel) at 4 samples: reading tables,
    the analytic mode's footprint filter keeps the pixel noise far below that of the same tables read
    without it, as it does when the shader computes."""
    (_, p, plan), (_, pc, plan_c), (_, _, band_only) = alias.variants()[:3]
    assert plan.tables and plan.footprint and not plan_c.tables and band_only.tables

    def noise(params, plan_):
        scene.reset_blender()
        sun = Sun(direction=(0.0, -np.cos(np.radians(40.0)), np.sin(np.radians(40.0))), strength=3.0)
        spheres = scene.build_scene(scene.SceneSpec(camera=scene.camera_for(1, alias.HEIGHT), sun=sun, osl=True))
        bpy.context.scene.cycles.filter_width = alias.FILTER_WIDTH
        apply_layered_material(spheres[0], params, "osl", plan=plan_, name="Aliasing")
        low = np.stack([alias.render(scene, alias.LOW_SPP, s) for s in alias.SEEDS[:3]])
        mask = low.mean(axis=0).sum(axis=-1) > 1e-4
        return float(low[:, mask].var(axis=0, ddof=1).sum(axis=-1).mean())

    filtered, unfiltered, computed = noise(p, plan), noise(p, band_only), noise(pc, plan_c)
    print(f"pixel variance at {alias.LOW_SPP} spp: tables {filtered:.3g}, tables without the footprint "
          f"{unfiltered:.3g}, computed {computed:.3g}")
    assert filtered < unfiltered / 3.0, (filtered, unfiltered, computed)
    assert filtered < 2.0 * computed
