"""The three-term engine: its Fourier orders, the split into single and multiple scattering, and the "mixed"
reference built on them (phase="three_term" and "mixed" named where a test is about them; the whole phase
function, the default, is tests/test_true_phase.py)."""

import exact_cache
import numpy as np
import pytest

from fitlab.families.lambert_sphere.exact import (
    albedo,
    brdf,
    brdf_modes,
    doubling_reflection,
    multiple_scattering_modes,
    phase_function,
    single_scattering_albedo,
    single_scattering_modes,
    spherical_albedo,
    three_term_phase_function,
    three_term_single_albedo,
)

MU = np.array([0.0, 1e-12, 1e-6, 0.05, 0.3, 0.7, 1.0])


def eq10_modes(mi, mo, c, n=16):
    """Fourier modes of single scattering, c p3(u) / (mu_i + mu_o) with u = -(mu_i mu_o + s cos phi)
    (paper eq. 10), projected in azimuth here, with the three-term phase function written out:
    p3(u) = (1 - 4u/3 + (5/16) P2(u)) / 4pi.  The integrand is a trigonometric polynomial of degree 2
    in phi, so the n-point midpoint rule is exact (up to rounding) for n > 4."""
    mi, mo = np.asarray(mi, dtype=float), np.asarray(mo, dtype=float)
    phi = (np.arange(n) + 0.5) * 2 * np.pi / n
    u = -(mi * mo)[..., None] - np.sqrt((1 - mi**2) * (1 - mo**2))[..., None] * np.cos(phi)
    p3 = (1 - 4 * u / 3 + 5 / 16 * (3 * u * u - 1) / 2) / (4 * np.pi)
    with np.errstate(divide="ignore", invalid="ignore"):  # inf / NaN at the pole mu_i = mu_o = 0 only
        f = c * p3 / (mi + mo)[..., None]
        return [f.mean(-1)] + [2 * (f * np.cos(m * phi)).mean(-1) for m in (1, 2)]


@pytest.mark.parametrize("c", [0.0, 0.4, 0.95, 1.0])
def test_reciprocity_and_decomposition(c):
    mi, mo = np.meshgrid(MU, MU, indexing="ij")
    f = brdf_modes(mi, mo, c)
    ss = single_scattering_modes(mi, mo, c)
    ms = multiple_scattering_modes(mi, mo, c, phase="three_term")
    direct = eq10_modes(mi, mo, c)
    off = (mi + mo) > 0
    for m in range(3):
        np.testing.assert_allclose(f[m], f[m].T, rtol=1e-14)
        np.testing.assert_allclose(ms[m], ms[m].T, rtol=1e-14)
        assert not np.any(np.isnan(f[m])) and not np.any(np.isnan(ms[m]))
        # the split, against eq. 10 projected here (not fitlab's closed forms): single scattering is
        # eq. 10, multiple scattering the rest (the whole checked against the doubling method below);
        # errors measured against the size of f^(0), the largest mode
        size = 1e-13 * np.abs(f[0][off]) + 1e-300
        err = np.abs(ss[m][off] - direct[m][off])
        assert np.all(err <= size), (m, err.max())
        err = np.abs(ms[m][off] - (f[m][off] - direct[m][off]))
        assert np.all(err <= size), (m, err.max())
    if c == 0.0:
        assert all(np.all(x == 0) for x in f + ms)


def test_multiple_scattering_is_second_order_in_c():
    # single scattering is exactly linear in c; everything else scatters at least twice: ms = O(c^2)
    mi, mo = np.meshgrid(MU[3:], MU[3:], indexing="ij")
    for m in range(3):
        a, b = (single_scattering_modes(mi, mo, c)[m] for c in (1e-4, 2e-4))
        np.testing.assert_allclose(b, 2 * a, rtol=1e-13, atol=1e-300)
        a, b = (multiple_scattering_modes(mi, mo, c, phase="three_term")[m] for c in (1e-4, 2e-4))
        nz = np.abs(a) > 0
        assert nz.sum() >= 6 and np.all(np.abs(b[nz] / a[nz] - 4) < 1e-3), m


def test_brdf_at_tiny_albedos_is_single_scattering_plus_c_squared_multiple_scattering():
    """As c -> 0, f = c p(u)/(mu_i + mu_o) + c^2 L(mu_i, mu_o, phi) (1 + O(c)): at c = 1e-12 and 1e-15 the BRDF
    agrees with that law, L taken from the multiple scattering at c = 1e-9, to 1.2e-10 (bound 1e-8), at grazing
    (mu down to 0, forward scattering included) and elsewhere; it is > 0 wherever mu_i + mu_o > 0, and 0 at
    c = 0.  Formed as a difference of O(c) numerators, the multiple scattering would keep eps c of rounding at
    grazing against a value of O(c^2 mu): -5.1e-24 at c = 1e-12, mu_i = mu_o = 1e-6, phi = pi."""
    grid = np.array(np.meshgrid([0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-2, 0.3, 1.0], [0.0, 1e-9, 1e-6, 1e-4, 1e-2, 0.5, 1.0],
                                [0.0, 1.0, 2.5, 3.0, np.pi], indexing="ij")).reshape(3, -1)  # fmt: skip
    mi, mo, ph = grid[:, grid[0] + grid[1] > 0]
    s = np.sqrt((1.0 - mi * mi) * (1.0 - mo * mo))
    p = phase_function(-(mi * mo + s * np.cos(ph)))
    fm = multiple_scattering_modes(mi, mo, 1e-9, phase="three_term")
    law = (fm[0] + fm[1] * np.cos(ph) + fm[2] * np.cos(2.0 * ph)) / 1e-18
    for c in (1e-12, 1e-15):
        f = brdf(mi, mo, ph, c, phase="mixed")
        assert np.all(f > 0)
        assert np.max(np.abs(f / (c * p / (mi + mo) + c * c * law) - 1)) < 1e-8, c
    assert np.all(brdf(mi, mo, ph, 0.0) == 0.0)
    assert np.all(brdf(mi, mo, ph, 1e-300) >= 0.0)


def test_multiple_scattering_orders_scale_as_c_squared_down_to_1e_15():
    """Each order is c^2 L (1 + O(c)): fm^m / c^2 at c = 1e-12 and 1e-15 against c = 1e-9.  Near grazing
    (mu_i, mu_o in {1e-6, 1e-4}) within 1.8e-6 (bound 1e-5); the stated limit away from grazing, about
    1.5e-16/c relative at mu_i = mu_o = 1 (the r_l - P_l^m beside O(1) coefficients are solved to eps
    absolute), checked at c = 1e-12: 1.5e-4 (bound 1e-3)."""
    mi, mo = (a.ravel() for a in np.meshgrid([1e-6, 1e-4], [1e-6, 1e-4], indexing="ij"))
    ref = [m / 1e-18 for m in multiple_scattering_modes(mi, mo, 1e-9, phase="three_term")]
    for c in (1e-12, 1e-15):
        for m, x in enumerate(multiple_scattering_modes(mi, mo, c, phase="three_term")):
            np.testing.assert_allclose(x / (c * c), ref[m], rtol=1e-5, err_msg=f"order {m}, c = {c}")
    # order 0 (orders 1, 2 have S = 0 there)
    ref = multiple_scattering_modes(1.0, 1.0, 1e-9, phase="three_term")[0] / 1e-18
    at_1e_12 = multiple_scattering_modes(1.0, 1.0, 1e-12, phase="three_term")[0]
    np.testing.assert_allclose(at_1e_12 / 1e-24, ref, rtol=1e-3)


@pytest.mark.parametrize("c", [0.5, 0.999, 1.0])
def test_modes_agree_with_discrete_ordinates(c):
    for m in range(3):
        d = doubling_reflection(m, c)
        sel = d.nodes > 1e-3
        mu = d.nodes[sel]
        mi, mo = mu[:, None], mu[None, :]
        f = brdf_modes(mi, mo, c)
        tol = 3e-7 if c == 1.0 else 1e-11  # doubling at c = 1: sqrt(eps)-level deficit
        ref = d.brdf[np.ix_(sel, sel)]
        np.testing.assert_allclose(ref, f[m], rtol=tol)
        # the split: multiple scattering = the doubling method's reflection - eq. 10's single scattering
        ms = multiple_scattering_modes(mi, mo, c, phase="three_term")[m]
        err = np.abs(ms - (ref - eq10_modes(mi, mo, c)[m]))
        assert np.all(err <= tol * np.abs(f[0])), (m, err.max())


def test_single_scattering_modes_are_the_fourier_series_of_eq10():
    # Direct azimuthal projection of c p3(u)/(mu_i + mu_o): settles 192 pi vs the printed 384 pi (eq. 28)
    rng = np.random.default_rng(1)
    mi, mo, c = rng.uniform(0.01, 1, 3)
    phi = (np.arange(4096) + 0.5) * 2 * np.pi / 4096
    s = np.sqrt((1 - mi**2) * (1 - mo**2))
    f = c * three_term_phase_function(-(mi * mo + s * np.cos(phi))) / (mi + mo)
    got = single_scattering_modes(mi, mo, c)
    for m in range(3):
        proj = f.mean() if m == 0 else 2 * (f * np.cos(m * phi)).mean()
        assert got[m] == pytest.approx(proj, rel=1e-13)
    printed_28 = c * (45 * mi * mo + 64) * s / (384 * np.pi * (mi + mo))
    assert got[1] == pytest.approx(2 * printed_28, rel=1e-14)


def test_conservation_at_c_1():
    a = albedo(MU, 1.0, phase="three_term")
    np.testing.assert_allclose(a, 1.0, atol=1e-13)
    assert spherical_albedo(1.0, phase="three_term") == pytest.approx(1.0, abs=1e-13)


def test_small_c_limit_is_single_scattering():
    c = 1e-6
    a = albedo(MU[1:], c, phase="three_term")
    np.testing.assert_allclose(a / c, three_term_single_albedo(MU[1:]), rtol=1e-5)


def test_single_scattering_albedo_two_routes():
    # the arc-integral route with the three-term phase function vs the Fourier-mode route
    mu = np.array([1e-9, 0.1, 0.5, 1.0])
    got = [single_scattering_albedo(x, "three_term") for x in mu]
    np.testing.assert_allclose(got, three_term_single_albedo(mu), rtol=1e-12)
    # normalisation: at mu_i = 0 every visible direction has weight 1 -> half the phase function
    assert single_scattering_albedo(0.0) == pytest.approx(0.5, abs=1e-13)


def test_albedo_values_are_ordered_and_finite():
    for model in ("true", "three_term"):
        kd = spherical_albedo(np.array([0.0, 0.2, 0.6, 0.95, 1.0]), phase=model)
        assert np.all(np.isfinite(kd)) and np.all(np.diff(kd) > 0) and kd[0] == 0.0
        # a fraction of energy, c = 1 included, where the quadrature's rounding may land above 1 (a loaded c(kd)
        # fit refuses kd > 1)
        assert np.all(kd <= 1.0) and kd[-1] == pytest.approx(1.0, abs=1e-13)


def test_reference_brdf_edges():
    assert np.all(brdf(0.0, 0.0, [0.0, 1.0, np.pi], 0.5) == np.inf)
    assert np.all(brdf(0.0, 0.0, [0.0, np.pi], 0.0) == 0.0)
    rng = np.random.default_rng(2)
    mi, mo = rng.uniform(0, 1, (2, 1000))
    phi = rng.uniform(-np.pi, np.pi, 1000)
    # the three-term engine at 32 albedos (each solves its H-functions once), the edges 0 and 1 among them; the
    # whole-phase engine (about 4 s an albedo) at three: over 1000 random points
    for phase, albedos in (("mixed", np.concatenate(([0.0, 1.0], rng.uniform(0, 1, 30)))), ("true", [0.0, 0.5, 1.0])):
        c = rng.choice(albedos, 1000)
        f = exact_cache.brdf(mi, mo, phi, c, phase=phase)  # exact.brdf, from the seeded cache (tests/exact_cache.py)
        assert np.all(np.isfinite(f)) and np.all(f >= 0)
        np.testing.assert_allclose(f, exact_cache.brdf(mo, mi, phi, c, phase=phase), rtol=1e-13)
        np.testing.assert_allclose(f, exact_cache.brdf(mi, mo, -phi, c, phase=phase), rtol=1e-13)


@pytest.mark.parametrize("mu_i, mu_o", [(0.5, 0.3), (0.0, 0.0), (0.0, 0.4)])
def test_scalar_inputs_give_the_array_values(mu_i, mu_o):
    # Scalars once failed at the pole fix-up (item assignment on a numpy scalar).
    f = brdf(mu_i, mu_o, 0.7, 0.6)
    assert np.shape(f) == ()
    np.testing.assert_array_equal(f, brdf([mu_i], [mu_o], [0.7], [0.6])[0])
    for modes in (single_scattering_modes, multiple_scattering_modes, brdf_modes):
        for scalar, vector in zip(modes(mu_i, mu_o, 0.6), modes([mu_i], [mu_o], [0.6])):
            assert np.shape(scalar) == ()
            np.testing.assert_array_equal(scalar, vector[0])


def test_runtime_model_with_exact_parts_never_needs_the_clamp():
    mu = np.concatenate(([1e-9], np.linspace(0.01, 1, 25)))
    phi = np.linspace(0, np.pi, 13)
    for c in (0.05, 0.5, 0.99, 1.0):
        mi, mo, ph = np.meshgrid(mu, mu, phi, indexing="ij")
        s = np.sqrt((1 - mi**2) * (1 - mo**2))
        f1 = c * phase_function(-(mi * mo + s * np.cos(ph))) / (mi + mo)
        fm0, fm1, _ = multiple_scattering_modes(mi, mo, c, phase="three_term")
        assert np.all(f1 + fm0 + fm1 * np.cos(ph) > 0)


@pytest.mark.parametrize(
    "call",
    [
        lambda: brdf_modes(-0.1, 0.5, 0.5),
        lambda: brdf_modes(0.5, 1.1, 0.5),
        lambda: brdf(0.5, 0.5, np.nan, 0.5),
        lambda: brdf(0.5, 0.5, 0.0, 2.0),
        lambda: albedo(0.5, 0.5, phase="lambert"),
        lambda: spherical_albedo(0.5, phase="x"),
    ],
)
def test_bad_inputs_raise(call):
    with pytest.raises(ValueError):
        call()
