"""A stack of films against thin-film optics no one here wrote (tmm's transfer matrices): reflectance and
transmittance of random stacks of 2-64 films, dielectric and absorbing (k up to 10), at 0-80 degrees;
every structural preset's colour in CIEDE2000; energy, disorder and hard cases."""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.model.presets import STACK_PRESETS, preset
from layered_brdf_addon.model.stack import FilmStack
from layered_brdf_addon.model.stack_amplitudes import periodic_reflect_transmit, reflect_transmit
from layered_brdf_addon.model.stack_optics import LEAST_WAVELENGTH_NODES, SPECTRUM_NM, StackResponse, stack_colour
from layered_brdf_reference.stack_colours import stack_error
from layered_brdf_reference.thin_film import stack_reflectance_transmittance

WAVES = np.arange(380.0, 781.0, 40.0)
ANGLES = (0.0, 30.0, 60.0, 80.0)
OPTICS_TOL = 1e-4  # the sum runs in single precision (measured: within 2e-6 of tmm)
COLOUR_BOUND = 1.0  # mean CIEDE2000 at 0, 30 and 60 degrees, analytic mode (the goal)


def _random_stack(rng, absorbing: bool):
    films = int(rng.integers(2, 65))
    indices = [complex(rng.uniform(1.0, 2.6), rng.uniform(0.0, 10.0) if absorbing and rng.random() < 0.3 else 0.0)
               for _ in range(films)]
    thicknesses = list(rng.uniform(5.0, 400.0, films))
    lower = complex(rng.uniform(1.0, 3.0), rng.uniform(0.0, 4.0) if absorbing else 0.0)
    return indices, thicknesses, lower


def _tmm(indices, thicknesses, lower, theta):
    return stack_reflectance_transmittance(1.0, indices, thicknesses, lower, theta, WAVES)


@pytest.mark.parametrize("absorbing", [False, True], ids=["dielectric", "absorbing"])
@pytest.mark.parametrize("seed", range(4))
def test_random_stacks_reflect_and_pass_what_tmm_says(seed, absorbing):
    rng = np.random.default_rng(seed + 100 * absorbing)
    indices, thicknesses, lower = _random_stack(rng, absorbing)
    for theta in ANGLES:
        R, T = reflect_transmit(1.0, [np.full(WAVES.shape, n) for n in indices], thicknesses,
                                np.full(WAVES.shape, lower), np.cos(np.radians(theta)), WAVES)
        R_ref, T_ref = _tmm(indices, thicknesses, lower, theta)
        assert np.abs(R - R_ref).max() <= OPTICS_TOL, f"{len(indices)} films at {theta:g} deg: R"
        assert np.abs(T - T_ref).max() <= OPTICS_TOL, f"{len(indices)} films at {theta:g} deg: T"


@pytest.mark.parametrize("absorbing", [False, True], ids=["dielectric", "absorbing"])
def test_films_summed_once_over_many_lower_indices_reflect_and_pass_what_tmm_says(absorbing):
    """The films at one wavelength, summed once as the map of the lowest boundary's amplitude, over a lower medium
    given at several indices (a metal's, over the band): each index's R and T, as tmm gives them."""
    rng = np.random.default_rng(11 + absorbing)
    indices, thicknesses, _ = _random_stack(rng, absorbing)
    lowers = np.array([0.2 + 3.4j, 0.5 + 2.4j, 1.2 + 1.8j, 1.5 + 0.0j, 2.9 + 0.3j])
    lam = np.array([550.0])
    for theta in ANGLES:
        cos0 = np.cos(np.radians(theta))
        R, T = reflect_transmit(1.0, [np.full(1, n) for n in indices], thicknesses, lowers, cos0, lam)
        assert R.shape == T.shape == lowers.shape
        for j, lower in enumerate(lowers):
            R_ref, T_ref = stack_reflectance_transmittance(1.0, indices, thicknesses, lower, theta, lam)
            assert abs(R[j] - R_ref[0]) <= OPTICS_TOL and abs(T[j] - T_ref[0]) <= OPTICS_TOL, f"{lower} at {theta:g}"


def test_films_summed_once_over_many_lower_indices_hold_near_grazing():
    """A 64-film chitin-air mirror (air of the outside's index: near grazing every boundary reflects almost all)
    summed once over five lower indices, from 89.99 to 84 degrees: each index's R as its own sum gives it
    (measured: within 3e-4; carried from r_b = 1 and 0 instead, 0.15 off)."""
    lowers = np.array([0.47 + 2.4j, 1.56 + 0.0j, 0.2 + 3.4j, 1.2 + 1.8j, 2.9 + 0.3j])
    films, lam = [np.full(1, 1.56 + 0j), np.full(1, 1.0 + 0j)] * 32, np.array([500.0])
    scales = np.linspace(0.5, 1.5, 101)[None, :]
    thicknesses = [scales * d for d in (90.0, 97.5) * 32]
    cos0 = np.array([1e-4, 1e-3, 1e-2, 0.1])[:, None]
    R, _ = reflect_transmit(1.0, films, thicknesses, lowers, cos0, lam)
    for j in range(len(lowers)):
        own, _ = reflect_transmit(1.0, films, thicknesses, lowers[j:j + 1], cos0, lam)
        assert np.abs(R[..., j] - own[..., 0]).max() < 1e-3, lowers[j]


def test_a_period_raised_to_its_power_is_the_films_one_by_one():
    rng = np.random.default_rng(7)
    for films, periods in ((1, 64), (2, 32), (3, 21), (2, 1)):
        indices = [np.full(WAVES.shape, complex(rng.uniform(1.0, 2.5), rng.uniform(0.0, 3.0))) for _ in range(films)]
        thicknesses = list(rng.uniform(0.0, 300.0, films))
        lower = np.full(WAVES.shape, complex(1.5, 0.5))
        cosines = np.cos(np.radians(np.linspace(0.0, 89.0, 7)))
        a = reflect_transmit(1.0, indices * periods, thicknesses * periods, lower, cosines, WAVES)
        b = periodic_reflect_transmit(1.0, indices, thicknesses, periods, lower, cosines, WAVES)
        assert np.abs(a[0] - b[0]).max() < OPTICS_TOL and np.abs(a[1] - b[1]).max() < OPTICS_TOL


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0])
@pytest.mark.parametrize("name", sorted(STACK_PRESETS))
def test_every_structural_preset_has_thin_film_optics_colour(name, theta):
    error = stack_error(preset(name), theta)
    print(f"{name} at {theta:g} deg: CIEDE2000 {error:.3f}")
    assert error <= COLOUR_BOUND


def test_a_lossless_stack_reflects_and_passes_all_it_receives():
    stack = FilmStack.from_dict({"films": [{"ior": 2.4, "thickness_nm": 57.0}, {"medium": "silica",
                                                                            "thickness_nm": 94.0}], "periods": 7})
    cosines = np.linspace(0.0, 1.0, 21)
    R, T = stack_colour(stack, 1.0, ((1.52,) * 3, (0.0,) * 3), cosines, np.array(1.0), gamut=False)
    assert np.abs(R + T - 1.0).max() < 1e-3
    R, T = stack_colour(stack, 1.0, ((1.52,) * 3, (0.0,) * 3), cosines, np.array(1.0))
    assert np.abs(R + T - 1.0).max() < 1e-3 and R.min() >= 0.0 and T.min() >= 0.0  # within the gamut


def test_disorder_pales_a_bragg_peak_and_is_the_same_every_time():
    films = [{"ior": 1.68, "thickness_nm": 79.0}, {"ior": 1.55, "thickness_nm": 85.5}]
    ordered = FilmStack.from_dict({"films": films, "periods": 16})
    disordered = FilmStack.from_dict({"films": films, "periods": 16, "disorder": 0.15})
    lower = ((1.55,) * 3, (0.0,) * 3)
    green = [stack_colour(s, 1.0, lower, 1.0, 1.0)[0][1] for s in (ordered, disordered)]
    assert green[1] < 0.9 * green[0]  # measured 0.81
    again = stack_colour(disordered, 1.0, lower, 1.0, 1.0)[0]
    assert np.array_equal(again, stack_colour(disordered, 1.0, lower, 1.0, 1.0)[0])


HARD = {
    "64 metal films": {"films": [{"ior": 1.2, "k": 10.0, "thickness_nm": 80.0}], "periods": 64},
    "a film of 100 um": {"kind": "list", "films": [{"ior": 1.5, "thickness_nm": 1.0e5},
                                                   {"ior": 2.0, "thickness_nm": 50.0}]},
    "films of no thickness": {"films": [{"ior": 2.0, "thickness_nm": 0.0}, {"medium": "air", "thickness_nm": 90.0}],
                              "periods": 32},
    "total internal reflection": {"films": [{"ior": 1.0, "thickness_nm": 100.0}, {"ior": 5.0, "thickness_nm": 1.0}],
                                  "periods": 16},
}


@pytest.mark.parametrize("name", list(HARD))
def test_hard_stacks_stay_finite_and_within_what_arrives(name):
    stack = FilmStack.from_dict(HARD[name])
    response = StackResponse(stack, 1.33, ((1.5, 1.5, 1.5), (0.0, 0.0, 0.0)))
    cosines = np.array([0.0, 1e-7, 1e-4, 0.01, 0.5, 1.0])
    R, T = response.colour(cosines[:, None], stack.total_nm * np.array([0.0, 0.5, 1.0, 2.0]))
    assert np.isfinite(R).all() and np.isfinite(T).all()
    assert (R >= 0).all() and (T >= 0).all() and (R + T <= 1.0 + 1e-6).all()


def test_the_colour_sums_the_band_finely_where_the_stack_is_thick():
    thin = FilmStack.from_dict({"films": [{"ior": 1.5, "thickness_nm": 100.0}]})
    thick = FilmStack.from_dict({"films": [{"ior": 1.63, "thickness_nm": 425.0}, {"ior": 1.43, "thickness_nm": 25.0}],
                                 "periods": 32})
    from layered_brdf_addon.model.stack_optics import coherent_optical, spectral_step
    assert spectral_step(coherent_optical(thin)) == 5.0 and SPECTRUM_NM[1] - SPECTRUM_NM[0] == 5.0
    assert spectral_step(coherent_optical(thick)) < 1.0


SCALE_FREE = {  # stack, lower medium, whether its media disperse
    "labradorite's lamellae": ({"films": [{"ior": 1.559, "thickness_nm": 80.0}, {"ior": 1.573, "thickness_nm": 80.0}],
                                "periods": 32, "domains": 4}, 1.566, False),
    "nacre, disordered": ({"films": [{"ior": 1.63, "thickness_nm": 425.0}, {"ior": 1.43, "thickness_nm": 25.0}],
                           "periods": 8, "disorder": 0.05}, 1.63, False),
    "absorbing films": ({"kind": "list", "films": [{"ior": 2.0, "k": 0.5, "thickness_nm": 40.0},
                                                   {"ior": 1.4, "thickness_nm": 300.0}] * 3}, 1.5, False),
    "chitin and air over chitin": ({"films": [{"ior": 1.56, "thickness_nm": 90.0},
                                              {"medium": "air", "thickness_nm": 97.5}], "periods": 8}, "chitin", True),
    "titania and silica": ({"films": [{"medium": "tio2_amorphous", "thickness_nm": 60.0},
                                      {"medium": "silica", "thickness_nm": 95.0}], "periods": 4}, 1.5, True),
}


@pytest.mark.parametrize("name", list(SCALE_FREE))
def test_a_grid_is_read_along_thickness_over_wavelength_as_every_pair_computes_it(name, monkeypatch):
    """On a grid of cosines and scales (a table's texels), the stack is computed along s / lambda (at one
    wavelength where no medium disperses, at a few where they do, or every pair where that costs less) and
    read between: within 2e-3 of every pair computed on its own (measured: 1e-4 without dispersion, 1e-3
    for a 16-film chitin-air mirror over chitin)."""
    from layered_brdf_addon.model import stack_optics
    spec, below, disperses = SCALE_FREE[name]
    stack = FilmStack.from_dict(spec)
    medium = below if isinstance(below, str) else "custom"
    lower = ((1.5 if medium != "custom" else below,) * 3, (0.0,) * 3)
    cos, scale = np.linspace(0.05, 1.0, 7), np.linspace(0.9, 1.1, 40)
    step = stack_optics.colour_step(stack, 1.1)
    seen = []
    inner = stack_optics.stack_spectra
    monkeypatch.setattr(stack_optics, "stack_spectra", lambda *a, **k: seen.append(len(a[5])) or inner(*a, **k))
    grid = stack_colour(stack, 1.0, lower, cos[:, None], scale[None, :], lower_medium=medium, step_nm=step)
    if not disperses:  # one wavelength (for each draw, and each domain's part)
        assert seen and set(seen) == {1}
    C, S = np.meshgrid(cos, scale, indexing="ij")
    pairs = stack_colour(stack, 1.0, lower, C.ravel(), S.ravel(), lower_medium=medium, step_nm=step)
    for g, p in zip(grid, pairs):
        assert np.abs(g.reshape(-1, 3) - p).max() < 2e-3


@pytest.mark.parametrize("medium,disorder", [("gold", 0.0), ("copper", 0.05), ("silver", 0.0), ("aluminium", 0.05)])
def test_a_grid_over_a_metal_holds_its_steep_spectrum(medium, disorder, monkeypatch):
    """Over a metal (n and k moving by several units over the band), a grid's films are summed once, at one
    wavelength, as a map of the metal's boundary, applied at wavelengths as close as its index calls for: as close
    to the band summed four times more finely as every pair at the colour's own step is (measured: 0.002-0.007 off
    it at 87 degrees, where the mirror's resonances are sharpest; 5 wavelengths read between were 0.04-0.11 off)."""
    from layered_brdf_addon.model import stack_optics
    films = [{"ior": 1.56, "thickness_nm": 90.0}, {"medium": "air", "thickness_nm": 97.5}]
    stack = FilmStack.from_dict({"films": films, "periods": 8, "disorder": disorder})
    lower = ((1.5,) * 3, (0.0,) * 3)
    cos, scale = np.linspace(0.05, 1.0, 9), np.linspace(0.8, 1.2, 64)
    step = stack_optics.colour_step(stack, 1.2)
    seen = []
    inner = stack_optics.stack_spectra
    monkeypatch.setattr(stack_optics, "stack_spectra",
                        lambda *a, **k: seen.append((len(a[5]), np.size(a[2]))) or inner(*a, **k))
    grid = stack_colour(stack, 1.0, lower, cos[:, None], scale[None, :], lower_medium=medium, step_nm=step)[0]
    assert seen and all(lams == 1 and lowers > LEAST_WAVELENGTH_NODES for lams, lowers in seen)  # summed once, mapped
    monkeypatch.setattr(stack_optics, "stack_spectra", inner)
    C, S = np.meshgrid(cos, scale, indexing="ij")
    pairs = stack_colour(stack, 1.0, lower, C.ravel(), S.ravel(), lower_medium=medium, step_nm=step)[0]
    fine = stack_colour(stack, 1.0, lower, C.ravel(), S.ravel(), lower_medium=medium, step_nm=step / 4)[0]
    grid = grid.reshape(-1, 3)
    assert np.abs(grid - fine).max() <= np.abs(pairs - fine).max() + 1e-3


@pytest.mark.parametrize("scale", [0.0, 1.0])
def test_a_grid_of_one_thickness_reads_as_its_pairs(scale):
    """A constant thickness (one row), none included: the grid's colour is every pair's, finite."""
    stack = FilmStack.from_dict(SCALE_FREE["labradorite's lamellae"][0])
    lower = ((1.5,) * 3, (0.0,) * 3)
    cos = np.linspace(0.0, 1.0, 128)
    grid = stack_colour(stack, 1.0, lower, cos[:, None], np.array([[scale]]))
    pairs = stack_colour(stack, 1.0, lower, cos, np.full(cos.shape, scale))
    for g, p in zip(grid, pairs):
        assert np.isfinite(g).all() and np.abs(g[:, 0] - p).max() < 2e-3
