"""The thin-film reference against textbook optics and colorimetry: Fresnel reflectance of
bare interfaces, zero-thickness, quarter-wave and half-wave films, energy conservation,
and the D65 / Rec.709 / CIEDE2000 colour pipeline."""
import colour
import numpy as np
import pytest

from layered_brdf_reference import thin_film as tf

LAMS = np.array([400.0, 480.0, 550.0, 633.0, 700.0])
GOLD = 0.2 + 3.5j


def normal_fresnel(n):
    """Textbook normal-incidence reflectance from air: ((n-1)^2 + k^2) / ((n+1)^2 + k^2)."""
    return ((n.real - 1) ** 2 + n.imag ** 2) / ((n.real + 1) ** 2 + n.imag ** 2)


@pytest.mark.parametrize("n, expected", [(1.5, 0.04), (GOLD, 12.89 / 13.69)])
def test_bare_interface_is_fresnel_at_normal_incidence(n, expected):
    assert normal_fresnel(complex(n)) == pytest.approx(expected, rel=1e-12)
    bare = tf.film_reflectance(1.0, 1.0, n, 0.0, 0.0, LAMS)
    same_as_outside = tf.film_reflectance(1.0, 1.0, n, 250.0, 0.0, LAMS)
    np.testing.assert_allclose(bare, expected, rtol=1e-12)
    np.testing.assert_allclose(same_as_outside, expected, rtol=1e-12)


def test_bare_dielectric_at_brewster_reflects_only_half_of_s():
    n = 1.5
    theta = np.arctan(n)
    cos_t = np.sqrt(1 - (np.sin(theta) / n) ** 2)
    rs = ((np.cos(theta) - n * cos_t) / (np.cos(theta) + n * cos_t)) ** 2
    r = tf.film_reflectance(1.0, 1.0, n, 0.0, np.degrees(theta), LAMS)
    np.testing.assert_allclose(r, rs / 2, rtol=1e-12)


@pytest.mark.parametrize("n_film", [1.33, 2.0 + 0.3j])
@pytest.mark.parametrize("n_below", [1.5, GOLD])
def test_zero_thickness_film_is_the_bare_interface(n_film, n_below):
    for theta in (0.0, 35.0, 70.0):
        np.testing.assert_allclose(tf.film_reflectance(1.0, n_film, n_below, 0.0, theta, LAMS),
                                   tf.film_reflectance(1.0, 1.0, n_below, 0.0, theta, LAMS), rtol=1e-12)


def test_quarter_wave_film_of_index_sqrt_n_cancels_reflection():
    n_sub, lam = 1.5, 550.0
    n_film = np.sqrt(n_sub)
    r = tf.film_reflectance(1.0, n_film, n_sub, lam / (4 * n_film), 0.0, LAMS)
    assert r[LAMS == lam][0] < 1e-12
    assert np.all(r < 0.04)


def test_half_wave_film_is_absent_at_its_design_wavelength():
    lam, n_film = 550.0, 2.0
    r = tf.film_reflectance(1.0, n_film, 1.5, lam / (2 * n_film), 0.0, [lam])
    assert r[0] == pytest.approx(0.04, rel=1e-12)


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 85.0])
def test_lossless_film_conserves_energy(theta):
    lams = np.arange(380.0, 781.0, 20.0)
    r, t = tf.film_reflectance_transmittance(1.0, 1.33, 1.5, 310.0, theta, lams)
    assert np.all((r >= 0) & (r <= 1))
    np.testing.assert_allclose(r + t, 1.0, atol=1e-12)


def test_positive_k_absorbs_and_negative_k_is_refused():
    r, t = tf.film_reflectance_transmittance(1.0, 1.5 + 0.1j, 1.5, 300.0, 20.0, LAMS)
    assert np.all(r + t < 1 - 1e-3)
    with pytest.raises(ValueError):
        tf.film_reflectance(1.0, 1.5 - 0.1j, 1.5, 300.0, 0.0, LAMS)


def test_indices_per_wavelength_match_scalar_calls():
    n_film = 1.4 + 0.01 * np.arange(LAMS.size)
    r = tf.film_reflectance(1.0, n_film, GOLD, 200.0, 40.0, LAMS)
    expected = [tf.film_reflectance(1.0, n, GOLD, 200.0, 40.0, [lam])[0] for n, lam in zip(n_film, LAMS)]
    np.testing.assert_allclose(r, expected, rtol=1e-14)


def test_perfect_white_is_y_one_and_lab_100():
    lams = tf.WAVELENGTHS_NM
    xyz = tf.spectrum_to_xyz(lams, np.ones(lams.size))
    assert xyz[1] == pytest.approx(1.0, rel=1e-14)
    np.testing.assert_allclose(tf.xyz_to_lab(xyz), [100.0, 0.0, 0.0], atol=0.1)


def test_spectrum_to_xyz_is_colour_science_integration():
    lams = tf.WAVELENGTHS_NM
    spectrum = 0.3 + 0.5 * np.sin(lams / 40.0) ** 2
    shape = colour.SpectralShape(380, 780, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    sd = colour.SpectralDistribution(spectrum, lams)
    expected = colour.sd_to_XYZ(sd, cmfs, d65, method="Integration") / 100
    np.testing.assert_allclose(tf.spectrum_to_xyz(lams, spectrum), expected, rtol=1e-12)


def test_rec709_white_is_lab_100_and_vectorised():
    np.testing.assert_allclose(tf.xyz_to_lab(tf.linear_rec709_to_xyz([1.0, 1.0, 1.0])), [100.0, 0.0, 0.0],
                               atol=1e-9)
    rgb = np.random.default_rng(3).random((2, 4, 3))
    lab = tf.xyz_to_lab(tf.linear_rec709_to_xyz(rgb))
    assert lab.shape == (2, 4, 3)
    np.testing.assert_allclose(lab[1, 2], tf.xyz_to_lab(tf.linear_rec709_to_xyz(rgb[1, 2])))


def test_delta_e_2000():
    lab = np.array([[50.0, 2.6772, -79.7751], [70.0, -10.0, 20.0]])
    np.testing.assert_array_equal(tf.delta_e_2000(lab, lab), [0.0, 0.0])
    # Sharma, Wu & Dalal (2005), test pair 1.
    assert tf.delta_e_2000(lab[0], [50.0, 0.0, -82.7485]) == pytest.approx(2.0425, abs=1e-4)


def test_film_lab_rows_per_thickness():
    lab = tf.film_lab(1.0, 1.33, 1.5, [0.0, 150.0, 300.0], 0.0)
    assert lab.shape == (3, 3)
    bare = tf.xyz_to_lab(tf.spectrum_to_xyz(tf.WAVELENGTHS_NM, np.full(tf.WAVELENGTHS_NM.size, 0.04)))
    np.testing.assert_allclose(lab[0], bare, atol=1e-9)
    assert np.all(tf.delta_e_2000(lab[1:], lab[0]) > 1.0)
