"""The policy module: backends and their lobes, and effect planning with animated parameters.

An animated parameter (keyframed, driven or linked) may take any value of its range on some
frame, so the planner keeps every effect it could switch on; the render test checks that
a thick spectral layer animated down to a thin one keeps its interference colours.
"""
from __future__ import annotations

from dataclasses import replace
from functools import partial

import numpy as np
import pytest

from layered_brdf_addon.model import preset
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.policy import (BACKENDS, DECIDING_PARAMETERS, LOBES_BY_BACKEND, THICKNESS_LINKED,
                                             check_backend,
                                             plan_effects)

BASE = preset("fig4_parallel")
THICK = 8000.0  # nm: past the band-averaging cut-off for r1 ~ 1.4 (optical ~ 7,800 nm > 4,146 nm)
THIN = 200.0

# For each effect, parameters that switch it off, and how the plan shows whether it is on.
OFF = {
    "specular": (BASE.replace(ks=0.0), lambda plan: plan.specular),
    "diffuse": (BASE.replace(kd=0.0), lambda plan: plan.diffuse),
    "thickness": (BASE.replace(d_min=70.0, d_max=70.0), lambda plan: plan.thickness != "constant"),
    "tilt": (BASE.replace(normal_mode="tilted", tilt=0.0), lambda plan: plan.normals == "tilted"),
    "bump": (BASE.replace(normal_mode="correlated", bump_strength=0.0), lambda plan: plan.normals == "correlated"),
    "dispersion": (BASE.replace(r1_r=1.45, r1_g=1.45, r1_b=1.45), lambda plan: plan.dispersion),
    "interference": (BASE.replace(accuracy="spectral16", d_min=THICK, d_max=THICK),
                     lambda plan: plan.interference),
    # A soap-like film over a dielectric: the second harmonic is below MULTIBEAM_CONTRAST.
    # A film barely denser than the air around it: its boundaries reflect little even at the rim.
    "multibeam": (BASE.replace(optics="physical", r1_r=1.01, r1_g=1.01, r1_b=1.01, r2_r=1.0, r2_g=1.0, r2_b=1.0),
                  lambda plan: plan.multibeam),
    # A metal under the film keeps what enters it: nothing to hand to the Base Shader.
    "passes": (BASE.replace(optics="physical", lower_medium="titanium"), lambda plan: plan.passes),
}
DECIDING = [(effect, name) for effect, names in DECIDING_PARAMETERS.items() for name in names]


def test_every_effect_has_a_case():
    assert set(OFF) == set(DECIDING_PARAMETERS)


@pytest.mark.parametrize("effect,name", DECIDING, ids=[f"{e}-{n}" for e, n in DECIDING])
def test_an_animated_deciding_parameter_keeps_its_effect(effect, name):
    params, on = OFF[effect]
    assert not on(plan_effects(params)), "the case must switch the effect off when nothing is animated"
    assert on(plan_effects(params, {name}))
    assert on(plan_effects(params, set(DECIDING_PARAMETERS[effect])))


@pytest.mark.parametrize("effect", sorted(OFF))
def test_animating_other_parameters_changes_nothing(effect):
    params, _ = OFF[effect]
    others = {"e0", "e1", "noise_scale", "noise_phase", "base_r", "tilt_azimuth"}
    # Only the choice of baked tables changes: an animated value cannot be baked.
    assert plan_effects(params, others) == replace(plan_effects(params), tables=False)


def test_tables_only_for_constant_values():
    """Baked tables where every value is a constant, the boundaries are parallel (or, in the node group,
    tilted by a constant angle, within the tables' budget), the thickness is the pattern's and the lobes
    Beckmann; anything animated, Effects 'all', Evaluation 'arithmetic', OSL's Phong lobes, a boundary
    that follows the thickness or a linked thickness compute instead."""
    p = preset("oil_slick")
    assert plan_effects(p).tables and plan_effects(p).key.endswith("Tb")
    assert not plan_effects(p, {"e0"}).tables
    # The pattern's values are not in the tables: a flowing noise keeps them.
    assert plan_effects(p, {"noise_phase", "noise_scale"}) == plan_effects(p)
    # A tilted boundary's tables hold its tilt, not the tilt's azimuth (turned point by point).
    tilted = p.replace(normal_mode="tilted", tilt=10.0, d_min=300.0, d_max=330.0)
    assert plan_effects(tilted).tables and plan_effects(tilted, {"noise_phase", "tilt_azimuth"}).tables
    assert plan_effects(p, {"tilt"}).tables and not plan_effects(tilted, {"tilt"}).tables
    assert not plan_effects(tilted, backend="osl").tables  # OSL reads tables of parallel boundaries only
    # Many fringes over the thickness need more slices than the budget: computed.
    assert not plan_effects(tilted.replace(d_max=900.0)).tables
    assert not plan_effects(preset("fig5_correlated")).tables  # the lower normal follows the thickness
    assert not plan_effects(p, {THICKNESS_LINKED}).tables
    assert plan_effects(p, backend="osl") == plan_effects(p)
    assert not plan_effects(p.replace(lobe="phong"), backend="osl").tables
    assert not plan_effects(p.replace(effects="all")).tables
    assert not plan_effects(p.replace(evaluation="arithmetic")).tables
    assert plan_effects(p.replace(d_max=p.d_min)).tables  # a constant thickness: one row
    assert plan_effects(tilted.replace(d_max=tilted.d_min)).tables


def test_animation_only_adds_effects():
    """Planning with every socket animated gives the fullest shader the enums allow."""
    every = {name for names in DECIDING_PARAMETERS.values() for name in names}
    for params, _ in OFF.values():
        still, moving = plan_effects(params), plan_effects(params, every)
        assert moving.specular >= still.specular and moving.diffuse >= still.diffuse
        assert moving.dispersion >= still.dispersion and moving.interference >= still.interference
        assert (moving.lobe, moving.spectral) == (still.lobe, still.spectral)


def test_backends_and_lobes():
    assert set(LOBES_BY_BACKEND) == set(BACKENDS)
    for backend in BACKENDS:
        for lobe in LOBES_BY_BACKEND[backend]:
            check_backend(backend, lobe)
    with pytest.raises(ParameterError) as e:
        check_backend("eevee")
    assert e.value.name == "backend"
    with pytest.raises(ParameterError, match="osl backend") as e:
        check_backend("nodes", "phong")
    assert e.value.name == "lobe"


def test_command_line_offers_the_policy_backends():
    from layered_brdf_addon.cli import commands

    parser = commands.build_parser()
    for command in ("render", "gallery"):
        ns = parser.parse_args([command, "--backend", BACKENDS[-1]])
        assert ns.backend == BACKENDS[-1]
        with pytest.raises(SystemExit):
            parser.parse_args([command, "--backend", "eevee"])


@pytest.mark.slow
def test_thick_layer_keyframed_thin_keeps_interference_on_both_frames():
    """A spectral layer so thick that interference averages out, keyframed down to a thin one
    on frame 2: re-applying keeps interference in the shader (the thickness sockets are
    animated), and both frames render as the closure form of that shader predicts."""
    import bpy

    from layered_brdf_addon.blender.scene import (SceneSpec, build_scene, camera_for, render_passes, reset_blender,
                                                  row_of_spheres)
    from layered_brdf_addon.blender.material import animated_parameters, apply_layered_material, input_value, param_socket, shader_node
    from layered_brdf_reference.closures import closure_shading
    from layered_brdf_reference.compare import agreement, lit_mask
    from layered_brdf_addon.model.sphere import render_spheres
    from render_helpers import SUN_40

    p = BASE.replace(accuracy="spectral16", d_min=THICK, d_max=THICK)
    dropped = plan_effects(p)
    assert dropped.interference is False  # what a still thick layer gets
    reset_blender()
    cam = camera_for(1, 48)
    centers = row_of_spheres(1)
    [obj] = build_scene(SceneSpec(camera=cam, sun=SUN_40, centers=centers))
    mat = apply_layered_material(obj, p, "nodes")
    assert mat["layered_brdf_build"] == f"nodes:{dropped.key}:{p.base_layer}"
    node = shader_node(mat)
    frames = {1: THICK, 2: THIN}
    for frame, d in frames.items():
        for name in ("d_min", "d_max"):
            sock = param_socket(node, name)[0]
            sock.default_value = d
            sock.keyframe_insert("default_value", frame=frame)
    assert {"d_min", "d_max"} <= animated_parameters(mat)

    bpy.context.view_layer.update()  # as after a keyframe in the UI (a rebuild before any update drops the
    mat = apply_layered_material(obj, p, "nodes")  # animation); then what the panel does after a change
    kept = plan_effects(p, {"d_min", "d_max"})
    assert kept.interference is True
    assert mat["layered_brdf_build"] == f"nodes:{kept.key}:{p.base_layer}"

    scene = bpy.context.scene
    shaded = partial(closure_shading, plan=kept)
    without = partial(closure_shading, plan=dropped)
    means = []
    for frame, d in frames.items():
        scene.frame_set(frame)
        assert input_value(shader_node(mat), "d_min") == pytest.approx(d)
        beauty = render_passes().beauty
        params = p.replace(d_min=d, d_max=d)
        expected, geo = render_spheres([params], cam, SUN_40, centers, shading=shaded)
        mask = lit_mask(geo, SUN_40.l)
        ag = agreement(beauty, expected, mask, rel_tol=0.02)
        assert ag.failing_fraction <= 0.01, f"frame {frame} (d = {d:g} nm): {ag}"
        if d == THIN:  # the test tells the plans apart: without interference the thin frame is wrong
            wrong, _ = render_spheres([params], cam, SUN_40, centers, shading=without)
            assert agreement(beauty, wrong, mask, rel_tol=0.02).failing_fraction > 0.2
        means.append(beauty[mask].mean(axis=0))
    hue = [m / m.sum() for m in means]
    assert np.abs(hue[0] - hue[1]).max() > 0.02, hue  # the thin frame has interference colours


def test_second_harmonic_only_where_the_layer_bounces_light_back():
    """TiO2 on titanium keeps the light bouncing inside the layer (|r01 r12| about 0.24): the
    plan adds the second harmonic; the paper's optics never do."""
    from layered_brdf_addon.model.media import layer_index_values, lower_medium_values

    film = BASE.replace(optics="physical", **layer_index_values("tio2_amorphous"), **lower_medium_values("titanium"))
    assert plan_effects(film).multibeam and "T2o" in plan_effects(film, backend="osl").key  # o: absorbs
    assert not plan_effects(film.replace(optics="paper")).multibeam
    assert not plan_effects(film.replace(r2_r=2.4, r2_g=2.47, r2_b=2.55, k2_r=0.0, k2_g=0.0, k2_b=0.0)).multibeam
