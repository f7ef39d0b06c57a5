"""A film stack as a parameter: read from JSON and written back, every bad value refused naming the film and
its field, nothing of a bad stack taken; what a stack needs of the other settings; its plan and tables."""
from __future__ import annotations

import json
import math

import pytest

from layered_brdf_addon.model import stack_tables
from layered_brdf_addon.model.errors import ParameterError
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.policy import plan_effects, render_plan
from layered_brdf_addon.model.presets import STACK_PRESETS, preset
from layered_brdf_addon.model.stack import MAX_FILMS, FilmStack
from layered_brdf_addon.model.table_bake import table_digest, table_layout

GOOD = {"kind": "periodic", "periods": 8, "disorder": 0.05,
        "films": [{"medium": "chitin", "thickness_nm": 90.0}, {"ior": 1.68, "k": 0.03, "thickness_nm": 79.0}]}


def test_a_stack_reads_back_what_it_wrote():
    stack = FilmStack.from_dict(GOOD)
    assert stack.count == 16 and math.isclose(stack.total_nm, 8 * 169.0)
    assert FilmStack.from_dict(stack.to_dict()) == stack
    p = LayeredParams.from_dict({"optics": "physical", "stack": GOOD})
    assert LayeredParams.from_dict(json.loads(p.to_json())) == p
    assert LayeredParams.from_dict({"optics": "physical", "stack": json.dumps(GOOD)}) == p  # JSON text too
    assert LayeredParams.from_dict({"stack": None}).stack is None and LayeredParams.from_dict({"stack": ""}).stack \
        is None


BAD = [
    ({"films": []}, "stack.films", "1 to 64 films"),
    ({"films": [{"ior": 1.5, "thickness_nm": 10.0}] * (MAX_FILMS + 1)}, "stack.films", "1 to 64 films"),
    ({"films": [{"ior": 1.5, "thickness_nm": 10.0}] * 2, "periods": 33}, "stack.periods", "[1, 32]"),
    ({"films": [{"ior": 1.5, "thickness_nm": 0.0}, {"medium": "air", "thickness_nm": 0.0}], "periods": 4},
     "stack.films", "more than 0 nm"),
    ({"films": [{"ior": 1.5, "thickness_nm": -5.0}]}, "stack.films[0].thickness_nm", "[0, 100000] nm"),
    ({"films": [{"ior": 1.5, "thickness_nm": 5.0}, {"ior": 1.5, "thickness_nm": float("nan")}]},
     "stack.films[1].thickness_nm", "[0, 100000] nm"),
    ({"films": [{"ior": 1.5, "k": 10.5, "thickness_nm": 5.0}]}, "stack.films[0].k", "[0, 10]"),
    ({"films": [{"medium": "unobtainium", "thickness_nm": 5.0}]}, "stack.films[0].medium", "one of air"),
    ({"films": [{"thickness_nm": 5.0}]}, "stack.films[0].medium", "an 'ior'"),
    ({"films": [{"ior": 1.5}]}, "stack.films[0].thickness_nm", "required"),
    ({"films": [{"medium": "water", "ior": 1.4, "thickness_nm": 5.0}]}, "stack.films[0].ior", "named medium"),
    ({"films": [{"ior": 1.5, "thickness_nm": 5.0, "colour": "red"}]}, "stack.films[0].colour", "a film's field"),
    ({"films": [{"ior": 1.5, "thickness_nm": 5.0}], "periods": 2.5}, "stack.periods", "a whole number"),
    ({"films": [{"ior": 1.5, "thickness_nm": 5.0}], "disorder": 0.9}, "stack.disorder", "[0, 0.5]"),
    ({"kind": "list", "films": [{"ior": 1.5, "thickness_nm": 5.0}], "periods": 3}, "stack.periods", "1 for a list"),
    ({"kind": "helix", "films": [{"ior": 1.5, "thickness_nm": 5.0}]}, "stack.kind", "'periodic', 'list'"),
    ("[not json", "stack", "JSON"),
]


@pytest.mark.parametrize("stack, name, allowed", BAD, ids=[b[1] + ":" + b[2] for b in BAD])
def test_a_bad_stack_is_refused_naming_the_film_and_field(stack, name, allowed):
    with pytest.raises(ParameterError) as e:
        LayeredParams.from_dict({"optics": "physical", "stack": stack})
    assert e.value.name == name and allowed in e.value.allowed, str(e.value)


def test_k_up_to_ten_is_a_film():
    assert FilmStack.from_dict({"films": [{"ior": 1.2, "k": 10.0, "thickness_nm": 30.0}]}).films[0].k == 10.0


@pytest.mark.parametrize("setting, value", [("optics", "paper"), ("lobe", "phong"), ("normal_mode", "correlated")])
def test_a_stack_names_the_setting_it_cannot_go_with(setting, value):
    with pytest.raises(ParameterError) as e:
        preset("jewel_beetle").replace(**{setting: value})
    assert e.value.name == setting


@pytest.mark.parametrize("name", sorted(STACK_PRESETS))
def test_a_stack_reads_tables_whatever_else_the_material_says(name):
    p = preset(name)
    for variant in (p, p.replace(evaluation="arithmetic"), p.replace(effects="all")):
        plan = render_plan(variant)
        assert plan.stack and plan.tables and plan.key.endswith("TbM")
    assert plan_effects(p, {"ks"}).tables  # an animated value: the tables follow it frame by frame
    layout = table_layout(p, plan_effects(p))
    if p.normal_mode == "tilted":  # clear lamellae: their optics (2 images: what they pass is what they do not
        # reflect) and their geometry (3), not closures
        assert layout.closures == () and layout.images == 5 and layout.geometry_image == 2 and not layout.sliced
    else:
        assert [c for c, _ in layout.closures] == ["reflect"]


def test_the_tables_follow_the_stack():
    p = preset("jewel_beetle")
    plan = plan_effects(p)
    moved = p.replace(stack={**p.stack.to_dict(), "periods": 7})
    medium = p.replace(lower_medium="water")
    digests = {table_digest(q, plan) for q in (p, moved, medium)}
    assert len(digests) == 3


def test_a_disordered_stacks_tables_follow_how_its_draws_sample_the_band(monkeypatch):
    nacre, beetle = preset("nacre"), preset("jewel_beetle")
    before = {name: table_digest(p, plan_effects(p)) for name, p in (("nacre", nacre), ("beetle", beetle))}
    monkeypatch.setattr(stack_tables, "DISORDERED_SAMPLES", stack_tables.DISORDERED_SAMPLES * 2)
    assert table_digest(nacre, plan_effects(nacre)) != before["nacre"]  # baked before: baked again
    assert table_digest(beetle, plan_effects(beetle)) == before["beetle"]  # no disorder: no draws
