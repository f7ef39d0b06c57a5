"""Film stacks from the command line: ``--stack`` takes a .json file or the JSON itself, and a render's
sidecar holds the stack it rendered (a bad stack exits 2 naming the film and field and writes nothing:
tests/test_cli.py)."""
from __future__ import annotations

import json

import pytest

from layered_brdf_addon.io.sidecar import read_sidecar
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.presets import preset

from constants import MAX_FAILING, REL_TOL
from process_helpers import run_cli

COATING = {"kind": "list", "films": [{"medium": "mgf2", "thickness_nm": 99.7}, {"medium": "alumina",
                                                                               "thickness_nm": 77.7}]}


@pytest.mark.slow
def test_a_stack_from_a_file_renders_and_its_sidecar_renders_it_again(tmp_path):
    from layered_brdf_addon.blender.scene import passes_from_exr
    from layered_brdf_addon.fit.cycles_closures import closure_shading
    from layered_brdf_addon.io.sidecar import scene_from_sidecar
    from layered_brdf_addon.model.sphere import render_spheres
    from layered_brdf_reference.compare import agreement, lit_mask

    (tmp_path / "coating.json").write_text(json.dumps(COATING))
    res = run_cli("render", "--preset", "coated_lens", "--stack", "coating.json", "--base-layer", "none",
                  "--d-min", "170", "--d-max", "185", "--e0", "150", "--resolution", 48,
                  "--output", "out/coat", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    side = read_sidecar(tmp_path / "out" / "coat.json")
    params = LayeredParams.from_dict(side["params"])
    assert params.stack.to_dict() == LayeredParams.from_dict({"optics": "physical", "stack": COATING}).stack.to_dict()
    assert side["plan"]["stack"] and side["plan"]["tables"]
    passes = passes_from_exr(tmp_path / "out" / "coat.exr")
    sc = scene_from_sidecar(side)
    expected, geo = render_spheres(sc.params, sc.camera, sc.sun, sc.centers, thickness=passes.thickness,
                                   prefer_analytic=True, shading=closure_shading)
    mask = lit_mask(geo, sc.sun.l)
    ag = agreement(passes.beauty, expected, mask, rel_tol=REL_TOL)
    assert ag.failing_fraction <= MAX_FAILING, str(ag)
    again = run_cli("render", "--params", "out/coat.json", "--resolution", 48, "--output", "out/again", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert read_sidecar(tmp_path / "out" / "again.json")["params"] == side["params"]
    assert preset("coated_lens").stack != params.stack
