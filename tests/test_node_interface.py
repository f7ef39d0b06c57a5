"""The node's interface speaks Blender: every input socket named for people (no unit or exponent in
its name), with a subtype where Blender has one, a range and a tooltip; the group named for what it
simulates, with a description."""
from __future__ import annotations

import bpy
import pytest

from layered_brdf_addon.backends import node_group as node_group_builder
from layered_brdf_addon.model import preset
from layered_brdf_addon.model.params import iter_sockets, socket_units
from layered_brdf_addon.model.policy import plan_effects


@pytest.fixture
def group():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return node_group_builder.ensure_group(plan_effects(preset("oil_slick").replace(evaluation="arithmetic")))


def test_every_input_socket_is_named_for_people_with_a_subtype_range_and_tooltip(group):
    items = [i for i in group.interface.items_tree if i.item_type == "SOCKET" and i.in_out == "INPUT"]
    assert len(items) >= 25
    for item in items:
        assert item.description, item.name
        assert not any(c in item.name for c in "()_°"), item.name  # units live in subtypes and tooltips
        assert "Exponent" not in item.name
    by_name = {i.name: i for i in items}
    for spec in iter_sockets():
        if spec.component is not None:
            continue
        item = next(i for i in items if i.name in (spec.socket_label or spec.name,))
        assert item.min_value < item.max_value, item.name
        if item.min_value == 0.0 and item.max_value == 1.0:
            assert item.subtype == "FACTOR", item.name
        if spec.unit == "deg":
            assert item.subtype == "ANGLE" and socket_units(spec, "nodes") == "radians", item.name
        if spec.unit == "nm":
            assert item.subtype == "WAVELENGTH", item.name
    assert by_name["Upper Roughness"].subtype == "FACTOR" and by_name["Thickness"].hide_value
    assert by_name["Base Color"].socket_type == "NodeSocketColor"


def test_the_group_is_named_for_what_it_simulates_and_described(group):
    assert group.name.startswith("Layered BRDF \u2014 Physical film, analytic colour, noise thickness")
    assert "thin-film optics" in group.description and "Properties > Material > Layered BRDF" in group.description
