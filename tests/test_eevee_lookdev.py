"""EEVEE renders the layered node group with Cycles' colours on the look-dev shader ball.

Principled BSDF's Thin Film is Cycles-only; the layered material is not.  The bound is
the measured difference with a margin (docs/looks.md#eevee-and-cycles): mean CIEDE2000
over the ball's pixels, both renders encoded by Blender with AgX, Cycles' own noise at
these samples included.
"""
from __future__ import annotations

import numpy as np
import pytest

import eevee_lookdev

SIZE = 64
CYCLES_SAMPLES = 32
EEVEE_SAMPLES = 16
PRESETS = ("beetle_shell", "glazed_clay", "labradorite")
MAX_MEAN_DELTA_E = 7.0  # measured 4.9 (beetle_shell), 2.7 (glazed_clay) and 2.5 (labradorite's lamellae) on Blender 5.2


@pytest.mark.slow
def test_eevee_colours_stay_within_the_stated_delta_e_of_cycles(tmp_path):
    r = eevee_lookdev.run(tmp_path / "r.npz", SIZE, CYCLES_SAMPLES, EEVEE_SAMPLES, PRESETS, timeout=300)
    assert str(r["view_transform"]) == "AgX"
    for name in PRESETS:
        mask = r[f"{name}/mask"]
        assert mask.sum() > 0.2 * SIZE * SIZE, name  # the ball fills the middle of the frame
        assert not r[f"{name}/eevee_failed"][mask].any(), f"{name}: EEVEE's shader failed (magenta)"
        de = eevee_lookdev.delta_e2000(r[f"{name}/cycles"], r[f"{name}/eevee"], mask)
        print(f"{name}: mean CIEDE2000 EEVEE vs Cycles {de.mean():.2f} (p95 {np.percentile(de, 95):.2f}); "
              f"EEVEE {float(r[f'{name}/eevee_seconds']):.1f} s")
        assert de.mean() <= MAX_MEAN_DELTA_E, (name, float(de.mean()))
