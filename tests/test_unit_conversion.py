"""What fed an older socket, carried into a socket of other units: values, curves, and a linked
thickness that must not upset the planner or the lower normal."""
from __future__ import annotations

import bpy
import numpy as np
import pytest

from layered_brdf_addon.blender.unit_conversion import convert_fcurve, convert_value
from layered_brdf_addon.model import preset, program
from layered_brdf_addon.model.ops_numpy import ShadingPoint
from layered_brdf_addon.model.params import socket_values
from layered_brdf_addon.model.policy import THICKNESS_LINKED, plan_effects
from layered_brdf_addon.model.socket_units import RADIANS, ROUGHNESS, to_socket


def test_values_convert_and_a_negative_exponent_is_fully_rough():
    assert convert_value("", ROUGHNESS, 90.0) == pytest.approx(181.0 ** -0.25)
    assert convert_value("", ROUGHNESS, -600.0) == 1.0  # the shader clamped it to 0: Roughness 1
    assert convert_value(ROUGHNESS, "", convert_value("", ROUGHNESS, 250.0)) == pytest.approx(250.0, rel=1e-9)
    assert convert_value("", RADIANS, 90.0) == pytest.approx(np.pi / 2)
    assert convert_value(RADIANS, "", np.pi) == pytest.approx(180.0)


def test_keyframes_of_an_exponent_become_a_roughness_on_every_frame():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = bpy.data.objects.new("Keyed", None)
    bpy.context.scene.collection.objects.link(obj)
    obj["exponent"] = 10.0
    for frame, value in ((1, 10.0), (12, 100.0), (30, 2000.0)):  # auto-clamped handles reach below 0
        obj["exponent"] = value
        obj.keyframe_insert('["exponent"]', frame=frame)
    fc = obj.animation_data.action.layers[0].strips[0].channelbags[0].fcurves[0]
    before = {f: fc.evaluate(f) for f in range(1, 31)}
    convert_fcurve(fc, "", ROUGHNESS, is_driver=False)
    for f, e in before.items():
        assert fc.evaluate(f) == pytest.approx(to_socket(ROUGHNESS, max(e, 0.0)), rel=2e-4, abs=1e-4), f


def test_a_linked_thickness_keeps_interference_and_the_patterns_own_gradient():
    thick = preset("fig4_parallel").replace(accuracy="analytic", d_min=20000.0, d_max=21000.0)
    assert not plan_effects(thick).interference
    assert plan_effects(thick, {THICKNESS_LINKED}).interference  # the link's thickness is not Thickness Min's
    p = preset("fig5_correlated").replace(thickness_mode="height")
    plan = plan_effects(p)
    n0 = np.array([[0.0, 0.6, 0.8], [0.3, 0.0, 0.954]])
    n0 /= np.linalg.norm(n0, axis=-1, keepdims=True)
    results = []
    for linked in (None, np.array([300.0, 310.0])):
        inputs = socket_values(p.to_dict())
        if linked is not None:
            inputs["Thickness"] = linked
        pt = ShadingPoint(inputs, n0, (0.0, 0.0, 1.0), n0)
        results.append(program.layered_surface(pt, plan).extras)
    assert np.asarray(results[1]["thickness"]) == pytest.approx([300.0, 310.0])
    assert np.asarray(results[1]["lower_normal"]) == pytest.approx(np.asarray(results[0]["lower_normal"]))
