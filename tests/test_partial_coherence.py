"""A disordered stack summed partially coherently (the top's films coherent, the deeper ones' light added as
power: layered_brdf_addon/model/partial_coherence.py) against physics no one here wrote, tmm's mixed
coherent and incoherent layers (``inc_tmm``), and against the average of many draws of the whole stack
summed coherently (what the partial sum approximates, and what the coherent 8 draws hold better)."""
from __future__ import annotations

import numpy as np
import pytest
import tmm

from layered_brdf_addon.model import stack_optics as so
from layered_brdf_addon.model.incoherent import over, over_sides
from layered_brdf_addon.model.partial_coherence import _gaps, deep_start, partial_colour, stack_colour_partial
from layered_brdf_addon.model.presets import preset
from layered_brdf_addon.model.stack import FilmStack
from layered_brdf_reference import thin_film
from layered_brdf_reference.film_colours import rgb_to_lab

INC_TMM_TOL = 0.05  # CIEDE2000 (measured: at most 0.027 against tmm every 4 nm, 0.018 every 2 nm)
LOWER = ((1.63,) * 3, (0.0,) * 3)
REFERENCE_NM = np.arange(380.0, 781.0, 4.0)


def _tablets(k: float) -> FilmStack:
    """Nacre's tablets and organic films (k: the tablets' extinction), 8 periods at 10% disorder: the spread
    passes coherence below the second period."""
    return FilmStack.from_dict({"films": [{"ior": 1.63, "thickness_nm": 425.0, "k": k},
                                          {"ior": 1.43, "thickness_nm": 25.0}], "periods": 8, "disorder": 0.1})


def _inc_tmm_lab(stack: FilmStack, mode: str, theta: float) -> np.ndarray:
    """tmm's colour of the stack with the model's draws, the top's films and each deep unit's coherent ('c'), the
    gap films below the top incoherent ('i'), both polarisations' intensities averaged."""
    start, gap = deep_start(stack, mode), _gaps(stack, mode)[0]
    flags = ["i"] + ["c" if j < start or not gap(j) else "i" for j in range(stack.count)] + ["i"]
    lower = so.lower_index(*LOWER, REFERENCE_NM)
    R = np.zeros(REFERENCE_NM.size)
    for draw in so.disorder_draws(stack):
        d = [np.inf] + [f.thickness_nm * x for f, x in zip(stack.layers, draw)] + [np.inf]
        for i, lam in enumerate(REFERENCE_NM):
            n = [1.0] + [so.film_index(f, [lam])[0] for f in stack.layers] + [lower[i]]
            R[i] += sum(tmm.inc_tmm(pol, n, d, flags, np.radians(theta), lam)["R"] for pol in "sp") / 2
    R /= len(so.disorder_draws(stack))
    return thin_film.xyz_to_lab(thin_film.spectrum_to_xyz(REFERENCE_NM, R))


@pytest.mark.slow
@pytest.mark.parametrize("k", [0.0, 0.02], ids=["clear", "absorbing"])
@pytest.mark.parametrize("mode", ["films", "periods"])
def test_the_partial_sum_is_tmm_with_the_deep_films_incoherent(mode, k):
    stack = _tablets(k)
    assert deep_start(stack, mode) < stack.count
    for theta in (0.0, 45.0):
        R = partial_colour(stack, 1.0, LOWER, np.cos(np.radians(theta)), 1.0, "analytic", "custom", 1.0, mode)[0]
        error = float(thin_film.delta_e_2000(rgb_to_lab(R), _inc_tmm_lab(stack, mode, theta)))
        print(f"{mode}, k {k:g}, {theta:g} deg: CIEDE2000 {error:.3f} from inc_tmm")
        assert error <= INC_TMM_TOL


def test_an_absorbing_slab_reflects_differently_from_each_side_when_piled():
    """over_sides against the bounces summed one by one (an absorbing slab over a mirror-like one), and
    over as its symmetric case."""
    upper, lower = (0.3, 0.5, 0.1, 0.5), (0.6, 0.2, 0.4, 0.2)
    R = upper[0] + sum(upper[1] * lower[0] * (upper[2] * lower[0]) ** n * upper[3] for n in range(200))
    Rb = lower[2] + sum(lower[3] * upper[2] * (lower[0] * upper[2]) ** n * lower[1] for n in range(200))
    out = over_sides(upper, lower)
    assert out[0] == pytest.approx(R) and out[2] == pytest.approx(Rb)
    assert out[1] == pytest.approx(upper[1] * lower[1] / (1 - upper[2] * lower[0]))
    assert over((0.3, 0.5), (0.6, 0.2)) == over_sides((0.3, 0.5, 0.3, 0.5), (0.6, 0.2, 0.6, 0.2))[:2]


def test_a_stack_whose_spread_stays_within_coherence_is_summed_as_before():
    ordered = preset("jewel_beetle").stack
    bragg = FilmStack.from_dict({"films": [{"ior": 1.56, "thickness_nm": 90.0}, {"medium": "air",
                                                                             "thickness_nm": 97.5}],
                                 "periods": 8, "disorder": 0.05})
    cosines = np.linspace(0.1, 1.0, 4)
    for stack in (ordered, bragg):
        for mode in ("blocks", "periods", "films"):
            assert deep_start(stack, mode) == stack.count
            assert np.array_equal(stack_colour_partial(stack, 1.0, LOWER, cosines, 1.0, mode)[0],
                                  so.stack_colour(stack, 1.0, LOWER, cosines, 1.0, gamut=False)[0])


# Mean CIEDE2000 at 0, 30 and 60 degrees from 1024 draws of nacre summed coherently (measured: the 8 coherent
# draws 0.34, the partial sums 0.84 (blocks), 5.56 (periods), 11.25 (films))
NACRE_BLOCKS = 1.0


@pytest.mark.slow
def test_nacre_partially_coherent_against_the_average_of_many_draws():
    p = preset("nacre")
    cosines = np.cos(np.radians([0.0, 30.0, 60.0]))

    def mean_error(colour, reference):
        return float(np.mean(thin_film.delta_e_2000(rgb_to_lab(colour), rgb_to_lab(reference))))

    def colour(partial=""):
        if partial:
            return stack_colour_partial(p.stack, p.r0, (p.r2, p.k2), cosines, np.ones(3), partial)[0]
        return so.stack_colour(p.stack, p.r0, (p.r2, p.k2), cosines, np.ones(3), gamut=False)[0]

    kept = so.DISORDER_DRAWS
    so.DISORDER_DRAWS = 1024
    try:
        reference = colour()
    finally:
        so.DISORDER_DRAWS = kept
    errors = {mode: mean_error(colour(mode), reference) for mode in ("", "blocks", "periods", "films")}
    print({mode or "coherent": round(e, 2) for mode, e in errors.items()})
    assert errors["blocks"] <= NACRE_BLOCKS
    # The deep part is no pile: neighbouring periods a coherence length down still interfere
    assert errors[""] < min(errors[mode] for mode in ("blocks", "periods", "films"))
