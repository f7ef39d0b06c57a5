"""Sidecars no render can have: a reference render whose sidecar records a camera, a sun or sphere centres that
cannot be (an ortho scale of 0, a zero or NaN direction, a dark sun, no centres) is refused, naming the field,
exit 2 and nothing written, instead of being fitted to a scene that does not exist."""
from __future__ import annotations

import json

import pytest

from layered_brdf_addon.io.sidecar import write_json

from test_fit_cli import _render_set, run_fit

NAN = float("nan")
SIDECAR_FAULTS = [("camera", "ortho_scale", 0, "> 0"), ("camera", "ortho_scale", -2.2, "> 0"),
                  ("camera", "view", [0, 0, 0], "not all zero"), ("camera", "view", [NAN, -1, 0], "not all zero"),
                  ("sun", "direction", [0, 0, 0], "not all zero"), ("sun", "direction", [0, NAN, 1], "not all zero"),
                  ("sun", "strength", 0, "> 0"), ("sun", "strength", -3, "> 0"),
                  (None, "centers", [], "non-empty list"), (None, "centers", "abc", "three finite numbers")]


@pytest.mark.parametrize("part, key, value, said", SIDECAR_FAULTS)
def test_a_sidecar_no_render_can_have_is_refused_naming_the_field(part, key, value, said, tmp_path, capsys):
    inputs = tmp_path / "in"
    inputs.mkdir()
    _render_set(inputs)
    side = json.loads((inputs / "t.json").read_text())
    (side if part is None else side[part])[key] = value
    write_json(inputs / "t.json", side)
    before = {p: p.read_bytes() for p in inputs.iterdir()}
    code, out, err = run_fit(inputs / "t", "--output", tmp_path / "out" / "fit", capsys=capsys)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert f"'{part + '.' if part else ''}{key}'" in err and said in err, err
    assert not (tmp_path / "out").exists() and {p: p.read_bytes() for p in inputs.iterdir()} == before
