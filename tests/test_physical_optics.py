"""The physical optics' mirror reflection of a smooth film against thin-film optics (tmm), in
CIEDE2000 over a range of thicknesses; the paper's optics as the control that fails."""
import functools

import numpy as np
import pytest

from layered_brdf_reference.film_colours import ANGLES_DEG, CASES, FilmCase, film_errors, model_film_rgb, \
    reference_film_lab
from layered_brdf_reference.thin_film import linear_rec709_to_xyz

# Thicknesses per case: the means are within 0.01 of those of a 2 nm grid
# (benchmarks/physical_optics_table.py).
SAMPLES = 81

# Bounds on the mean CIEDE2000 over thickness at 0°, 30° and 60°, in the analytic mode.
MEAN_BOUNDS = {
    "soap (water on air)": (1.0, 1.0, 3.0),
    "oil on water": (1.0, 1.0, 3.0),
    "chitin on air": (1.0, 1.0, 3.0),
    # goal 1.5 (accepted floor 3.0), measured 1.64, 1.68, 2.05
    "TiO2 on titanium": (2.0, 2.0, 2.5),
    # no goal, measured 1.20, 1.22, 1.79
    "TiO2 on aluminium": (1.3, 1.3, 1.9),
}
PAPER_SOAP_MIN_MEAN = 20.0  # the paper's optics on soap (measured 64-75)
ENERGY_SLACK = 1e-6


def thicknesses(case: FilmCase) -> np.ndarray:
    return case.thicknesses(count=SAMPLES)


@functools.lru_cache(maxsize=None)
def reference(case: FilmCase, theta: float) -> np.ndarray:
    """tmm's Lab of the case at ``theta``, computed once per module run."""
    return reference_film_lab(case.film, case.below, thicknesses(case), theta)


def mean_error(case: FilmCase, theta: float, optics: str) -> float:
    d = thicknesses(case)
    return float(film_errors(case.film, case.below, d, theta, optics, "analytic", reference(case, theta)).mean())


def test_every_case_has_its_bounds():
    assert set(MEAN_BOUNDS) == {c.name for c in CASES}


@pytest.mark.parametrize("theta", ANGLES_DEG, ids=lambda v: f"{v:g}")
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_physical_film_colour_matches_thin_film_optics(case, theta):
    mean = mean_error(case, theta, "physical")
    assert mean <= MEAN_BOUNDS[case.name][ANGLES_DEG.index(theta)], f"{case.name} at {theta:g}°: mean ΔE2000 {mean:.2f}"


@pytest.mark.parametrize("theta", ANGLES_DEG, ids=lambda v: f"{v:g}")
def test_paper_optics_are_far_off_for_soap(theta):
    """The control: the paper's lower mirror without reflection phases gets soap's colours wrong."""
    soap = next(c for c in CASES if c.film == "water" and c.below == "air")
    mean = mean_error(soap, theta, "paper")
    assert mean > PAPER_SOAP_MIN_MEAN, f"paper optics on soap at {theta:g}°: mean ΔE2000 {mean:.2f}"


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_smooth_film_reflects_at_most_what_arrives(case):
    """At the three wavelengths (the "rgb" mode) each channel is a reflectance, in [0, 1]; in
    the analytic mode a channel is a Rec.709 coordinate of a band, negative or above the
    spectrum's largest value for colours outside the gamut (as tmm's are), and the luminance
    Y is the reflectance."""
    d = thicknesses(case)
    for theta in ANGLES_DEG:
        R = model_film_rgb(case.film, case.below, d, theta, "physical", "rgb")
        assert R.min() >= 0.0 and R.max() <= 1.0 + ENERGY_SLACK, (theta, R.min(), R.max())
        Y = linear_rec709_to_xyz(model_film_rgb(case.film, case.below, d, theta, "physical", "analytic"))[:, 1]
        assert Y.min() >= 0.0 and Y.max() <= 1.0 + ENERGY_SLACK, (theta, Y.min(), Y.max())
