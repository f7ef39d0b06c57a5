"""The fitting core: round trips of parameter sets never in the presets, a reflectance
table from thin-film optics (tmm), and tables that cannot be fitted."""
from __future__ import annotations

import numpy as np
import pytest

from layered_brdf_addon.fit import colour_space
from layered_brdf_addon.fit.free import FreeParameters, check_vary, default_vary, film_vary, vary_for
from layered_brdf_addon.fit.solve import FitCancelled, fit
from layered_brdf_addon.fit.targets import (DARKEST_WHITE, ReflectanceTarget, SphereTarget, SphereView, TargetError,
                                              noise_levels)
from layered_brdf_addon.model.params import ParameterError
from layered_brdf_addon.model.presets import preset
from layered_brdf_reference.fit_cases import CAMERA, FILMS, SUNS, held_out, image_delta_e, tmm_rows, views_of

ROUND_TRIP_DELTA_E = 1.0  # mean CIEDE2000 between the target and the fit's render
HELD_OUT = held_out()


@pytest.mark.parametrize("case", sorted(HELD_OUT))
def test_a_held_out_material_is_found_again(case):
    truth, start = HELD_OUT[case]
    target = SphereTarget(views_of(truth))
    result = fit(target, preset(start).replace(thickness_mode=truth.thickness_mode))
    assert result.mean_delta_e <= ROUND_TRIP_DELTA_E
    assert image_delta_e(target, result.params) <= ROUND_TRIP_DELTA_E
    assert set(result.vary) == set(default_vary(truth))


def test_two_suns_pin_the_material_down():
    truth = preset("soap_bubble").replace(d_min=300, d_max=700, e0=800, e1=1400, kd=0.2, base_r=0.3, base_g=0.1,
                                          base_b=0.05, base_layer="none")
    target = SphereTarget(views_of(truth, SUNS))
    result = fit(target, preset("soap_bubble").replace(base_layer="none"))
    assert image_delta_e(target, result.params) <= ROUND_TRIP_DELTA_E
    for name in ("d_min", "d_max"):
        assert getattr(result.params, name) == pytest.approx(getattr(truth, name), rel=0.05)
    # The Roughness (the artist's unit, e0 = (Roughness^-4 - 1) / 2) within 3%.
    assert result.params.e0 ** -0.25 == pytest.approx(truth.e0 ** -0.25, rel=0.03)


def test_each_view_is_measured_on_its_own_white():
    # Two views of one material; the second rendered 8 times brighter (a stronger light): each is put
    # on the CIELAB scale by its own bright end, so a fit's difference in one view does not change
    # with another view's exposure, and the darker view keeps its weight.
    truth = preset("oil_slick").replace(thickness_mode="height")
    other = truth.replace(d_min=150, d_max=900)
    [a, b] = views_of(truth, SUNS)

    def per_view(exposure: float) -> list[np.ndarray]:
        """Each view's CIEDE2000 between the target and ``other``, the first view ``exposure`` times brighter."""
        target = SphereTarget([SphereView(a.image * exposure, a.camera, a.sun), b])
        assert target.view_whites[0] == pytest.approx(colour_space.white_of(target._points[0]["observed"]))
        return target.images_delta_e([target.render(other, 0) * exposure, target.render(other, 1)])

    for now, then in zip(per_view(8.0), per_view(1.0)):
        assert now == pytest.approx(then, rel=1e-9, abs=1e-12)
        assert then.max() > 5.0  # two different films, where the sun lights them


def test_a_view_almost_black_is_measured_on_a_share_of_the_brightest_white():
    [a, b] = views_of(preset("soap_bubble"), SUNS)
    target = SphereTarget([a, SphereView(b.image * 1e-4, b.camera, b.sun)])
    assert target.view_whites[1] == pytest.approx(DARKEST_WHITE * target.view_whites[0])
    assert target.white_y.shape == (len(target.observed),)


def test_a_film_of_one_thickness_varies_its_thickness_as_one():
    start = preset("oil_slick").replace(thickness_mode="height")
    uniform = SphereTarget(views_of(start.replace(d_min=350.0, d_max=350.0)), uniform_film=True)
    assert "d_max" not in vary_for(uniform, start) and "d_min" in vary_for(uniform, start)
    assert vary_for(uniform, start, ["d_min", "d_max", "e0"]) == ("d_min", "e0")
    with pytest.raises(ParameterError, match="'vary'.*d_min for a film of one thickness"):
        vary_for(uniform, start, ["d_max"])
    free = FreeParameters(("d_min", "e0"), start, uniform=True)
    moved = free.params(free.vector(start.replace(d_min=420.0)))
    assert moved.d_min == moved.d_max == pytest.approx(420.0)
    result = fit(uniform, start, starts=1)  # from the middle of the start's 100-600 nm
    assert result.params.d_min == result.params.d_max == pytest.approx(350.0, rel=0.03)
    assert result.mean_delta_e <= ROUND_TRIP_DELTA_E


def test_only_the_named_parameters_move():
    truth = preset("oil_slick").replace(d_min=250, d_max=500, thickness_mode="height")
    start = preset("oil_slick").replace(thickness_mode="height")
    result = fit(SphereTarget(views_of(truth)), start, vary=["d_min", "d_max"], starts=1)
    moved = {k for k, v in result.params.to_dict().items() if v != start.to_dict()[k]}
    assert moved <= {"d_min", "d_max"}
    assert result.mean_delta_e <= ROUND_TRIP_DELTA_E


def test_a_cancelled_fit_stops():
    truth = preset("oil_slick").replace(thickness_mode="height")
    calls = []
    with pytest.raises(FitCancelled):
        fit(SphereTarget(views_of(truth)), truth, should_stop=lambda: len(calls) > 5, progress=calls.append)
    assert len(calls) == 6


def test_the_free_parameters_follow_the_modes_and_the_table():
    assert "tilt" in default_vary(preset("fig4_tilted")) and "tilt" not in default_vary(preset("fig4_parallel"))
    assert "r2_r" in default_vary(preset("soap_bubble").replace(lower_medium="custom"))
    assert "r2_r" not in default_vary(preset("soap_bubble"))
    assert film_vary(preset("anodised_titanium")) == ("r1_r", "r1_g", "r1_b", "d_min")
    with pytest.raises(ParameterError, match="'vary'"):
        check_vary(["d_min", "thickness_mode"])
    with pytest.raises(ParameterError, match="'vary'"):
        check_vary([])
    start = preset("soap_bubble")
    free = FreeParameters(default_vary(start), start)
    lo, hi = free.bounds()
    assert np.all(lo < hi)
    x = free.vector(start)
    x[free.names.index("d_min")], x[free.names.index("d_max")] = np.log(900.0), np.log(150.0)
    flipped = free.params(x)
    assert (flipped.d_min, flipped.d_max) == pytest.approx((150.0, 900.0))


def test_noise_levels_follow_the_measured_distribution():
    for detail in (0.0, 2.0, 5.0, 8.0, 15.0):
        u = noise_levels(detail)
        assert np.all(np.diff(u) > 0) and 0.2 < u[0] and u[-1] < 0.8
        assert u[len(u) // 2] == pytest.approx(0.48, abs=0.02)


# -- reflectance tables ----------------------------------------------------------------------
@pytest.mark.parametrize("film, below, thickness, start", FILMS)
def test_a_thin_film_optics_table_is_matched(film, below, thickness, start):
    from layered_brdf_addon.model.media import layer_index_values

    target = ReflectanceTarget.from_rows(tmm_rows(film, below, thickness))
    result = fit(target, preset(start))
    assert result.mean_delta_e <= 2.0
    assert result.params.d_min == result.params.d_max
    # Interference fixes the optical thickness n d, not n and d apart.
    n_true = np.mean(list(layer_index_values(film).values()))
    assert np.mean(result.params.r1) * result.params.d_min == pytest.approx(n_true * thickness, rel=0.1)


@pytest.mark.parametrize("rows, said", [
    ([], "empty"),
    ([(0, 450, float("nan"))], "not a finite number"),
    ([(0, "r", -0.1), (0, "g", 0.1), (0, "b", 0.1)], "outside [0, 1]"),
    ([(0, "r", 0.1), (0, "g", 0.1)], "needs the channels r, g and b"),
    ([(0, 450, 0.1), (0, 550, 0.1)], "needs at least 8"),
    ([(95, "r", 0.1)], "outside [0, 90)"),
    ([(0, "ultraviolet", 0.1)], "not a number"),
    ([(0, "r", 0.1), (0, "g", 0.1), (0, "b", 0.1), (0, 500, 0.1)], "mixed"),
])
def test_a_table_that_cannot_be_fitted_says_why(rows, said):
    with pytest.raises(TargetError, match=re_escape(said)):
        ReflectanceTarget.from_rows(rows)


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def test_a_target_that_cannot_be_fitted_says_why():
    view = views_of(preset("oil_slick").replace(thickness_mode="height"))[0]
    with pytest.raises(TargetError, match="NaN"):
        SphereTarget([SphereView(np.full_like(view.image, np.nan), CAMERA, view.sun)])
    with pytest.raises(TargetError, match="black"):
        SphereTarget([SphereView(np.zeros_like(view.image), CAMERA, view.sun)])
    with pytest.raises(TargetError, match="pixels"):
        SphereTarget([SphereView(view.image[:10], CAMERA, view.sun)])
    with pytest.raises(TargetError, match="no image"):
        SphereTarget([])


def test_a_noise_fit_that_passes_through_a_uniform_film_keeps_the_target_s_statistics():
    """A noise start whose range closes (d_min = d_max: the plan renders a uniform film) is still compared
    by the target's statistics, not pixel by pixel (the rows would not line up)."""
    from layered_brdf_addon.fit.solve import model_features, features_observed

    start = preset("glazed_clay")
    assert start.thickness_mode == "noise"
    target = SphereTarget(views_of(start.replace(thickness_mode="height")))  # any image: its statistics are compared
    closed = start.replace(d_min=80.0, d_max=80.0)
    assert model_features(target, closed).shape == features_observed(target, start).shape
