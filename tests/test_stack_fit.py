"""The fit recovers a film stack's period from thin-film optics no one here wrote: tmm's reflectance of a
preset's stack made thicker or thinner, fitted from the preset by ``fit --reflectance``, gives back the
stack's total thickness (its period: the films keep their proportions)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from layered_brdf_addon.cli import commands as cli
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.stack_optics import lower_index
from layered_brdf_reference.stack_colours import tmm_spectrum

ANGLES = (0.0, 30.0, 60.0)
WAVES = np.arange(380.0, 781.0, 5.0)
PERIOD_TOL = 0.002  # of the true total thickness (measured within 0.01%)
COLOUR_TOL = 0.3  # mean CIEDE2000 of the fit (measured 0.004-0.07)


def _table(path, name: str, scale: float) -> float:
    p = preset(name)
    lower = lower_index(p.r2, p.k2, WAVES, p.lower_medium)
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(["angle_deg", "wavelength_nm", "reflectance"])
        for angle in ANGLES:
            R, _ = tmm_spectrum(p.stack, float(p.r0), lower, angle, scale, WAVES)
            out.writerows([angle, lam, f"{r:.6f}"] for lam, r in zip(WAVES, R))
    return p.stack.total_nm * scale


@pytest.mark.parametrize("name, scale", [("jewel_beetle", 1.07), ("jewel_beetle", 0.94), ("dichroic_glass", 1.05)])
def test_the_fit_recovers_a_stack_s_period_from_tmm(tmp_path, name, scale):
    total = _table(tmp_path / "stack.csv", name, scale)
    code = cli.main(["fit", "--reflectance", str(tmp_path / "stack.csv"), "--start", name,
                     "--output", str(tmp_path / "out" / "fit"), "--no-progress"])
    assert code == 0
    record = json.loads((tmp_path / "out" / "fit.json").read_text())
    params, fit = record["params"], record["fit"]
    print(f"{name} x{scale}: total {params['d_min']:.1f} nm (truth {total:.1f}), CIEDE2000 "
          f"{fit['mean_delta_e_2000']:.3f}, vary {fit['vary']}")
    assert fit["vary"] == ["d_min"] and params["stack"] == preset(name).stack.to_dict()
    assert abs(params["d_min"] - total) <= PERIOD_TOL * total and params["d_max"] == params["d_min"]
    assert fit["mean_delta_e_2000"] <= COLOUR_TOL


@pytest.mark.parametrize("name, scale", [("morpho_blue", 0.93), ("dichroic_glass", 1.05)])
def test_a_fit_with_no_start_chooses_the_stack_and_its_period(tmp_path, name, scale):
    """With no start the fit tries every structural preset's stack beside the films: tmm's reflectance of a
    stack is given back as that stack (its films' media and proportions), at its period."""
    total = _table(tmp_path / "stack.csv", name, scale)
    code = cli.main(["fit", "--reflectance", str(tmp_path / "stack.csv"), "--output", str(tmp_path / "out" / "fit"),
                     "--no-progress"])
    assert code == 0
    record = json.loads((tmp_path / "out" / "fit.json").read_text())
    params, fit = record["params"], record["fit"]
    print(f"{name} x{scale}: total {params['d_min']:.1f} nm (truth {total:.1f}), CIEDE2000 "
          f"{fit['mean_delta_e_2000']:.3f}")
    assert params["stack"] == preset(name).stack.to_dict()
    assert abs(params["d_min"] - total) <= PERIOD_TOL * total and fit["mean_delta_e_2000"] <= COLOUR_TOL


@pytest.mark.parametrize("extra, said", [
    (["--layer", "stacks"], ["'layer'", "'stacks'", "film, stack"]),
    (["--layer", "stack", "--start", "nacre"], ["'layer'", "no value with --start"]),
    (["--layer", "stack", "--principled", "look.blend", "--material", "M"], ["'layer'", "'film' for a render"]),
    (["--start", "labradorite"], ["'start'", "'labradorite'", "mirror direction", "tilted lamellae"]),
])
def test_a_bad_layer_or_start_is_refused_naming_it_and_writes_nothing(tmp_path, capsys, extra, said):
    _table(tmp_path / "stack.csv", "jewel_beetle", 1.0)
    (tmp_path / "look.blend").write_bytes(b"")
    target = [] if "--principled" in extra else ["--reflectance", str(tmp_path / "stack.csv")]
    code = cli.main(["fit", *target, *[str(tmp_path / a) if a.endswith(".blend") else a for a in extra],
                     "--output", str(tmp_path / "out" / "fit"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2, err
    for text in said:
        assert text in err, (text, err)
    assert not (tmp_path / "out").exists()
