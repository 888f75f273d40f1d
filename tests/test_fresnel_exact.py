"""The Fresnel family's exact engine: limits, energy, two independent forms of the Fresnel equations, the
colour weights, two quadratures of F_avg, float32, and the published facts it must reproduce."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitlab.families.fresnel import exact
from fitlab.families.fresnel.targets import tabulate
from fitlab.families.microfacet_energy.exact import fresnel_conductor, fresnel_dielectric
from fitlab.resources import packaged_tables

CONDUCTORS = [k for k, m in exact.MATERIALS.items() if m.kind == "conductor"]
DIELECTRICS = [k for k, m in exact.MATERIALS.items() if m.kind == "dielectric"]
MU = np.concatenate(([0.0, 1e-12, 1e-6, 1.0 / 7.0, 1.0 - 1e-12, 1.0], np.linspace(0, 1, 101)))


@pytest.mark.parametrize("material", list(exact.MATERIALS))
def test_limits_per_wavelength(material):
    lam = exact.WAVELENGTHS
    eta = exact.get_material(material).index(lam)
    f = exact.fresnel_reflectance(np.array([0.0, 1.0])[:, None], eta[None, :])
    np.testing.assert_allclose(f[0], 1.0, rtol=0, atol=1e-15)  # grazing: F = 1
    n, k = eta.real, eta.imag
    np.testing.assert_allclose(f[1], ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2), rtol=1e-14)  # RTR4 eq. 9.17


def complex_amplitudes(mu, eta):
    """F = (|r_s|^2 + |r_p|^2) / 2 from the complex amplitudes r_s = (mu - w) / (mu + w), r_p = (eta^2 mu - w) /
    (eta^2 mu + w), w = sqrt(eta^2 - sin^2 theta) (numpy's principal complex root): the equations evaluated
    independently of fitlab.physics's real form."""
    w = np.sqrt(eta * eta - (1 - mu) * (1 + mu))
    r_s = (mu - w) / (mu + w)
    r_p = (eta * eta * mu - w) / (eta * eta * mu + w)
    return 0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)


@pytest.mark.parametrize("material", CONDUCTORS)
def test_complex_amplitudes_agree_with_the_real_form(material):
    # two independent forms of the same equations: complex r_s, r_p here, Born and Wolf's real form in the engine
    # (fitlab.physics.fresnel, which the microfacet family's engine evaluates too)
    eta = exact.get_material(material).index(exact.WAVELENGTHS)
    mu = MU[:, None]
    got = exact.fresnel_reflectance(mu, eta[None, :])
    np.testing.assert_allclose(got, complex_amplitudes(mu, eta[None, :].astype(complex)), rtol=0, atol=2e-15)
    np.testing.assert_array_equal(got, fresnel_conductor(mu, eta.real[None, :], eta.imag[None, :]))


@pytest.mark.parametrize("material", DIELECTRICS)
def test_dielectrics_agree_with_snells_law_form(material):
    eta = exact.get_material(material).index(exact.WAVELENGTHS).real
    got = exact.fresnel_reflectance(MU[:, None], eta[None, :] + 0j)
    np.testing.assert_allclose(got, fresnel_dielectric(MU[:, None], eta[None, :]), rtol=0, atol=2e-15)


@settings(max_examples=300, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.05, 20.0), st.floats(0.0, 20.0))
def test_reflectance_is_a_fraction_of_energy(mu, n, k):
    if n == 1.0 and k == 0.0:
        return  # the matched interface (eta = 1) is outside the domain
    f = float(exact.fresnel_reflectance(mu, n + 1j * k))
    assert 0.0 <= f <= 1.0 + 1e-15
    # and normal incidence is the closed form at every index
    f0 = float(exact.normal_reflectance(n + 1j * k))
    assert float(exact.fresnel_reflectance(1.0, n + 1j * k)) == pytest.approx(f0, rel=1e-13, abs=1e-16)


def test_float32_follows_float64_at_the_edges():
    mu = np.array([0.0, 1e-7, 0.5, 1.0 - 1e-7, 1.0])
    for material in ("cu", "au", "glass"):
        eta = exact.get_material(material).index(np.array([450.0, 550.0, 650.0]))
        f64 = exact.fresnel_reflectance(mu[:, None], eta[None, :])
        f32 = exact.fresnel_reflectance(mu.astype(np.float32)[:, None], eta[None, :])
        assert f32.dtype == np.float32 and np.all(np.isfinite(f32))
        np.testing.assert_allclose(f32, f64, rtol=0, atol=3e-6)


def test_bad_inputs_are_refused_in_one_line():
    with pytest.raises(ValueError, match="mu must be"):
        exact.fresnel_reflectance(1.5, 1.5)
    with pytest.raises(ValueError, match="eta must"):
        exact.fresnel_reflectance(0.5, 1.0)
    with pytest.raises(ValueError, match="material must be one of"):
        exact.reflectance("unobtainium", 0.5)
    with pytest.raises(ValueError, match="space must be one of"):
        exact.reflectance("cu", 0.5, space="xyz")


@pytest.mark.parametrize("space", exact.SPACES)
def test_a_constant_spectrum_gives_that_constant_in_every_channel(space):
    lam, w = exact.channel_weights(space)
    assert w.shape == (3, lam.size)
    for value in (0.0, 0.04, 0.5, 1.0):
        np.testing.assert_allclose(w @ np.full(lam.size, value), value, rtol=0, atol=1e-14)


def test_the_packaged_weights_are_what_colour_science_computes():
    pytest.importorskip("colour")
    assert tabulate.check_tables(packaged_tables("fresnel"), show_progress=False) == []


def test_the_weights_check_catches_a_wrong_value(tmp_path):
    pytest.importorskip("colour")
    text = (packaged_tables("fresnel") / exact.WEIGHTS_FILE).read_text().splitlines()
    row = next(i for i, line in enumerate(text) if line.startswith("550.0,"))
    fields = text[row].split(",")
    fields[1] = repr(float(fields[1]) + 1e-9)
    text[row] = ",".join(fields)
    (tmp_path / exact.WEIGHTS_FILE).write_text("\n".join(text) + "\n")
    (failure,) = tabulate.check_tables(tmp_path, show_progress=False)
    assert "srgb_r at 550 nm" in failure


@pytest.mark.parametrize("material", list(exact.MATERIALS))
def test_two_quadratures_of_the_average_agree(material):
    for space in exact.SPACES:
        by_mu = exact.average_reflectance(material, space, "mu")
        by_theta = exact.average_reflectance(material, space, "theta")
        np.testing.assert_allclose(by_mu, by_theta, rtol=0, atol=1e-10)
        f = exact.reflectance(material, np.linspace(0, 1, 2001), space)
        assert np.all(by_mu >= f.min(axis=0)) and np.all(by_mu <= f.max(axis=0))  # an average of F


def test_average_of_schlick_is_its_closed_form():
    # the quadrature of the average on a function with a closed form: (20 F0 + 1)/21 (SPEC section 9)
    for f0 in (0.04, 0.5, 0.95):
        for route in exact.AVERAGE_ROUTES:
            got = exact.cosine_average(lambda mu, f0=f0: f0 + (1 - f0) * (1 - mu) ** 5, route)
            assert float(got) == pytest.approx((20 * f0 + 1) / 21, abs=1e-14)


def test_rgb_reflectance_is_the_spectrum_weighted():
    mu = np.array([0.0, 0.3, 1.0])
    f = exact.reflectance("cu", mu)
    lam, w = exact.channel_weights("srgb")
    spectral = exact.fresnel_reflectance(mu[:, None], exact.get_material("cu").index(lam)[None, :])
    np.testing.assert_allclose(f, spectral @ w.T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(f[0], 1.0, atol=1e-14)  # grazing is white in every space
    np.testing.assert_allclose(exact.reflectance("cu", 0.0, "acescg"), 1.0, atol=1e-14)


@pytest.mark.parametrize("material", list(exact.MATERIALS))
def test_reflectance_does_not_depend_on_the_cosines_beside_it(material):
    """F(mu) is the same float whatever else a call holds: the presets' F0 = F(1) (stored in the fit files) was
    once a BLAS product whose last bits changed with the number of cosines and the BLAS build."""
    alone = exact.reflectance(material, 1.0)
    many = exact.reflectance(material, np.linspace(0.0, 1.0, 3001))  # mu = 1 in the second block of 2048
    pair = exact.reflectance(material, np.array([1.0, 0.5]))
    assert np.array_equal(alone, many[-1]) and np.array_equal(alone, pair[0])


def test_published_facts_of_rtr4():
    # RTR4 section 9.5: glass's F0 is 0.04 (n = 1.5); "metals have F0 almost always 0.5 or above"; gold's red
    # value is slightly above 1, outside sRGB's gamut, and its blue "the only value in Table 9.2
    # significantly below 0.5"
    np.testing.assert_allclose(exact.reflectance("glass", 1.0), 0.04, rtol=1e-14)
    f0 = {m: exact.reflectance(m, 1.0) for m in CONDUCTORS}
    assert 1.0 < f0["au"][0] < 1.05
    lowest = min((v, m, c) for m, f in f0.items() for c, v in enumerate(f))
    assert lowest[1:] == ("au", 2) and lowest[0] < 0.4
    # every other channel of these metals is at least 0.45 (tungsten's blue, 0.47, is the next lowest)
    assert min(v for m, f in f0.items() for c, v in enumerate(f) if (m, c) != ("au", 2)) >= 0.45


@settings(max_examples=200, deadline=None)
@given(st.floats(0.001, 0.98), st.floats(0.0, 1.0))
def test_gulbrandsen_map_round_trips(r, g):
    n, k = exact.gulbrandsen_index(r, g)
    assert float(exact.normal_reflectance(n + 1j * k)) == pytest.approx(r, rel=1e-9)
    r2, g2 = exact.gulbrandsen_parameters(n, k)
    assert float(r2) == pytest.approx(r, rel=1e-9) and float(g2) == pytest.approx(g, abs=1e-7)
