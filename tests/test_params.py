"""The single parameter definition: defaults, presets, and validation messages."""
import math

import pytest

from layered_brdf_addon.model import PARAM_SPECS, PRESETS, LayeredParams, ParameterError, preset


def test_defaults_validate_and_every_spec_is_complete():
    LayeredParams().validate()
    for s in PARAM_SPECS:
        assert s.label and s.description
        if s.kind == "float":
            assert s.min <= s.default <= s.max


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_every_preset_validates(name):
    p = preset(name)
    assert p.d_min <= p.d_max


@pytest.mark.parametrize("field,value", [
    ("d_min", -1.0), ("d_max", -5.0), ("d_min", math.nan), ("d_max", math.inf), ("d_max", 2.0e6),
    ("r1_r", 0.0), ("r1_g", -1.5), ("r0", 0.0), ("e0", -1.0), ("e1", -0.5), ("ks", 1.5), ("kd", -0.1),
    ("base_r", 2.0), ("normal_mode", "sideways"), ("thickness_mode", "waves"), ("lobe", "ggx2"),
    ("tilt", 200.0), ("ks", "a lot"), ("kd", True),
])
def test_bad_values_name_the_parameter_and_range(field, value):
    with pytest.raises(ParameterError) as err:
        LayeredParams(**{field: value}).validate()
    msg = str(err.value)
    assert f"'{field}'" in msg
    assert "allowed" in msg
    assert err.value.name == field


def test_thickness_order():
    with pytest.raises(ParameterError, match=r"'d_min'.*at most d_max = 10 nm"):
        LayeredParams(d_min=20.0, d_max=10.0).validate()


def test_range_is_in_message():
    with pytest.raises(ParameterError, match=r"\[0, 1\]"):
        LayeredParams(ks=2.0).validate()
    with pytest.raises(ParameterError, match=r"'parallel', 'tilted', 'correlated'"):
        LayeredParams(normal_mode="x").validate()


def test_unknown_names_are_rejected():
    with pytest.raises(ParameterError, match="'thicknes'"):
        LayeredParams.from_dict({"thicknes": 3})
    with pytest.raises(ParameterError, match="'preset'"):
        preset("no_such_preset")


def test_round_trip_dict():
    p = preset("fig6_medium")
    assert LayeredParams.from_dict(p.to_dict()) == p


def test_every_enum_option_and_preset_has_a_label_for_people():
    from layered_brdf_addon.model.params import OPTION_LABELS, option_label
    from layered_brdf_addon.model.presets import PRESET_LABELS, PRESETS, preset_label

    for spec in LayeredParams.specs():
        if spec.kind == "enum":
            labels = [option_label(o) for o in spec.options]
            assert all(o in OPTION_LABELS for o in spec.options), spec.name
            assert len(set(labels)) == len(labels), spec.name
    assert set(PRESET_LABELS) == set(PRESETS)
    assert preset_label("fig3_old_metal") == "Fig. 3 old metal"
    assert option_label("rgb") == "RGB (the paper's 3 wavelengths)"
