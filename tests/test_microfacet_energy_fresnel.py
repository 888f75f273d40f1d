"""Fresnel factors and Kulla-Conti's coloured energy compensation (fitlab.families.microfacet_energy.exact,
module _fresnel): limits, an independent Fresnel formula (complex amplitudes) and an independent quadrature of
F_avg, the identities the compensation satisfies exactly, and the bounds on what it approximates.

Nothing here is a pasted result: every comparison is between two computations, or against a limit, an identity
or a bound derived in the module docstring.  The per-direction errors of the compensated albedo are printed
(pytest -s) and bounded.

Gold's complex index: P. B. Johnson and R. W. Christy, "Optical constants of the noble metals", Phys. Rev. B 6,
4370 (1972), table for Au, at photon energies 2.01 eV (617 nm), 2.26 eV (549 nm) and 2.75 eV (451 nm):
n = 0.21, 0.43, 1.38 and k = 3.272, 2.455, 1.914 (a red, green and blue channel).
"""

from functools import cache

import mpmath
import numpy as np
import pytest
from scipy import integrate, optimize

from fitlab.families.microfacet_energy.exact import (
    GGX_MODELS,
    average_albedo,
    average_fresnel,
    average_fresnel_conductor,
    average_fresnel_dielectric,
    average_fresnel_schlick,
    compensated_albedo,
    compensated_fresnel_albedo,
    directional_albedo,
    fresnel_compensation_factor,
    fresnel_conductor,
    fresnel_dielectric,
    fresnel_dielectric_transmittance,
    fresnel_multiple_scattering_brdf,
    fresnel_schlick,
    ggx_ndf,
    random_walk_albedo,
    smith_g1,
    visible_fresnel,
)

# Johnson and Christy 1972, gold (module docstring): eta + i k at 2.01, 2.26, 2.75 eV
GOLD_ETA = np.array([0.21, 0.43, 1.38])
GOLD_K = np.array([3.272, 2.455, 1.914])
F0S = (0.04, 0.5, 0.9)
ALPHAS = (0.2, 0.5, 1.0)
MU = np.array([0.0, 0.01, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0])


def complex_fresnel(c, eta, k):
    """Unpolarised reflectance from the complex amplitudes (Born and Wolf): r_s = (c - w) / (c + w),
    r_p = (n^2 c - w) / (n^2 c + w), w = sqrt(n^2 - sin^2) (principal root), n = eta + i k."""
    n2 = (eta + 1j * k) ** 2
    w = np.sqrt(n2 - (1 - c * c) + 0j)
    r_s = (c - w) / (c + w)
    r_p = (n2 * c - w) / (n2 * c + w)
    return (np.abs(r_s) ** 2 + np.abs(r_p) ** 2) / 2


def theta_average(f, points=()):
    """F_avg = int_0^(pi/2) 2 F(cos t) cos t sin t dt by QUADPACK's adaptive rule in theta (not in mu)."""
    value, _ = integrate.quad(
        lambda t: 2 * f(np.cos(t)) * np.cos(t) * np.sin(t),
        0,
        np.pi / 2,
        points=points or None,
        epsabs=1e-13,
        epsrel=1e-13,
        limit=400,
    )
    return value


def graded_rule(n_panels=6, nodes=7, ratio=0.35):
    """Composite Gauss-Legendre on [0, 1] graded towards 0 (E changes on the scale alpha there and has a
    mu log mu term for height-correlated Smith); 42 nodes, cosine-weighted averages of E to 2e-11 for
    alpha >= 0.2 (test_cosine_averaged_total_against_the_series checks it)."""
    edges = np.concatenate(([0.0], ratio ** np.arange(n_panels - 1, -1, -1)))
    x, w = np.polynomial.legendre.leggauss(nodes)
    lo, hi = edges[:-1, None], edges[1:, None]
    return (lo + (hi - lo) * (x + 1) / 2).ravel(), ((hi - lo) * w / 2).ravel()


def schlick(f0):
    return lambda c: fresnel_schlick(c, f0)


def gold(channel):
    e, k = float(GOLD_ETA[channel]), float(GOLD_K[channel])
    return lambda c: fresnel_conductor(c, e, k)


CASES = {**{f"schlick {f0}": schlick(f0) for f0 in F0S}, **{f"gold {rgb}": gold(i) for i, rgb in enumerate("RGB")}}


@cache
def fresnel_range(name):
    """min and max of F over [0, 1]: F(0) = 1 is the maximum (F <= 1); the minimum by a dense scan refined by
    Brent's method (a conductor's F dips below F(1) near grazing)."""
    f = CASES[name]
    c = np.linspace(0, 1, 4001)
    i = int(np.argmin(f(c)))
    res = optimize.minimize_scalar(
        lambda x: float(f(x)),
        bounds=(c[max(i - 1, 0)], c[min(i + 1, c.size - 1)]),
        method="bounded",
        options={"xatol": 1e-12},
    )
    return min(float(res.fun), float(f(c[i]))), float(np.max(f(c)))


@cache
def f_avg_of(name):
    return average_fresnel(CASES[name])


# -- the Fresnel factors --------------------------------------------------------------------------------
def test_schlick_limits_shapes_and_average_in_closed_form():
    sympy = pytest.importorskip("sympy")
    mu, r0 = sympy.symbols("mu r0")
    closed = sympy.integrate(2 * (r0 + (1 - r0) * (1 - mu) ** 5) * mu, (mu, 0, 1))
    assert sympy.simplify(closed - (20 * r0 + 1) / 21) == 0
    f0s = np.array(F0S)
    np.testing.assert_allclose(fresnel_schlick(1.0, f0s), f0s, rtol=0, atol=1e-16)
    np.testing.assert_array_equal(fresnel_schlick(0.0, f0s), 1.0)
    assert fresnel_schlick(np.linspace(0, 1, 5)[:, None], f0s).shape == (5, 3)  # RGB by broadcasting
    for f0 in (0.0, *F0S, 1.0):
        # the adaptive quadrature is exact for the polynomial 2 mu F
        assert abs(average_fresnel(schlick(f0)) - float(average_fresnel_schlick(f0))) < 1e-15
        assert abs(float(average_fresnel_schlick(f0)) - float(closed.subs(r0, f0))) < 1e-15
    np.testing.assert_array_equal(average_fresnel_schlick(1.0), 1.0)


def test_conductor_limits_and_the_complex_amplitudes():
    eta = np.array([0.05, 0.21, 0.43, 1.0, 1.38, 1.5, 2.5, 0.7, 3.0])
    k = np.array([5.0, 3.272, 2.455, 0.5, 1.914, 0.0, 0.0, 0.0, 8.0])
    c = np.concatenate(([0.0, 1e-6, 1e-3], np.linspace(0.01, 1, 100)))[:, None]
    f = fresnel_conductor(c, eta, k)
    assert f.shape == (c.size, eta.size) and np.all((f >= 0) & (f <= 1))
    np.testing.assert_allclose(f[1:], complex_fresnel(c[1:], eta, k), rtol=0, atol=2e-15)
    np.testing.assert_allclose(
        fresnel_conductor(1.0, eta, k), ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2), rtol=1e-15
    )
    np.testing.assert_array_equal(fresnel_conductor(0.0, eta, k), 1.0)
    # k = 0 is the dielectric (an independent formula), with total internal reflection for eta < 1
    eta_d = np.array([0.5, 0.9, 1.0, 1.0001, 1.33, 1.5, 2.4, 4.0])
    np.testing.assert_allclose(fresnel_conductor(c, eta_d, 0.0), fresnel_dielectric(c, eta_d), rtol=0, atol=2e-15)
    critical = np.sqrt(1 - 0.5**2)
    np.testing.assert_array_equal(fresnel_dielectric(np.linspace(0, critical, 7), 0.5), 1.0)
    # the matched interface reflects nothing, and its grazing limit is 0
    np.testing.assert_array_equal(fresnel_conductor(c, 1.0, 0.0), 0.0)
    np.testing.assert_array_equal(fresnel_dielectric(c, 1.0), 0.0)
    # large k reflects everything: 1 - R_s = 4 a c / ((c + a)^2 + b^2) <= 4 a / b^2 and, with R_p = R_s X,
    # 1 - X = 4 a c s2 / ((a c + s2)^2 + (b c)^2) <= 2 a / b (s2^2 + (b c)^2 >= 2 s2 b c), where a = eta k / b
    # <= eta and b >= k; so 1 - F <= 4 eta / k^2 + eta / k, the second from p's dip at c ~ 1/k
    for e, kk in [(0.21, 1e3), (0.21, 1e6), (1.5, 1e4)]:
        loss = 1 - fresnel_conductor(np.concatenate((c, np.geomspace(1e-9, 1e-2, 200)[:, None])), e, kk)
        assert np.all(loss <= 4 * e / kk**2 + e / kk) and loss.max() > e / kk / 2  # the dip is there


def snell_transmittance_mp(cos_i, cos_t, eta, from_incident: bool):
    """1 - F at 40 digits (mpmath): Snell's other cosine from the given one (cos_i when ``from_incident``,
    else cos_t), then 1 - (r_s^2 + r_p^2) / 2 with the textbook amplitudes."""
    with mpmath.workdps(40):
        e = mpmath.mpf(eta)
        out = []
        for ci, ct in zip(cos_i, cos_t):
            if from_incident:
                ci = mpmath.mpf(ci)
                ct = mpmath.sqrt(1 - (1 - ci * ci) / (e * e))
            else:
                ct = mpmath.mpf(ct)
                ci = mpmath.sqrt(1 - e * e * (1 - ct * ct))
            if ci + e * ct == 0:
                out.append(0.0)
                continue
            r_s, r_p = (ci - e * ct) / (ci + e * ct), (e * ci - ct) / (e * ci + ct)
            out.append(float(1 - (r_s * r_s + r_p * r_p) / 2))
        return np.array(out)


@pytest.mark.parametrize("eta", [1.0 / 3.0, 0.5, 1.0 / 1.5, 1.0001, 1.5, 3.0])
def test_transmittance_from_both_cosines(eta):
    """1 - F from both cosines against Snell's textbook form at 40 digits, to 1e-14 relative everywhere,
    down to the critical angle (eta < 1, cos_t -> 0) and grazing (cos_i -> 0) where 1 - F -> 0 and
    ``1 - fresnel_dielectric`` loses its relative accuracy; symmetric under (cos_i, cos_t, eta) -> (cos_t,
    cos_i, 1 / eta); 0 at grazing on either side; float32 to float32 rounding."""
    # both cosines without cancellation: the other from the side of the larger index (eta sin_t = sin_i)
    given = np.concatenate((np.linspace(0.0, 1.0, 201), np.geomspace(1e-12, 1e-3, 40)))
    if eta > 1:  # cos_t^2 = ((eta - 1)(eta + 1) + cos_i^2) / eta^2, free of cancellation
        cos_i, cos_t = given, np.sqrt(((eta - 1) * (eta + 1) + given**2) / eta**2)
    else:
        cos_t, cos_i = given, np.sqrt((1 - eta) * (1 + eta) + eta**2 * given**2)
    t = fresnel_dielectric_transmittance(cos_i, cos_t, eta)
    np.testing.assert_allclose(t, snell_transmittance_mp(cos_i, cos_t, eta, from_incident=eta > 1), rtol=1e-14, atol=0)
    np.testing.assert_allclose(fresnel_dielectric_transmittance(cos_t, cos_i, 1 / eta), t, rtol=4e-15, atol=0)
    assert np.all((t >= 0) & (t <= 1))
    np.testing.assert_array_equal(fresnel_dielectric_transmittance([0.0, 0.3], [0.3, 0.0], eta), 0.0)
    # the one-cosine form near the critical angle: its 1 - F is off by far more than 1e-14 relative there
    if eta < 1:
        near = (cos_t > 0) & (cos_t < 1e-6)
        one_cosine = 1 - fresnel_dielectric(cos_i[near], eta)
        assert np.max(np.abs(one_cosine / t[near] - 1)) > 1e-9
    t32 = fresnel_dielectric_transmittance(cos_i.astype(np.float32), cos_t.astype(np.float32), np.float32(eta))
    assert t32.dtype == np.float32
    np.testing.assert_allclose(t32, t, rtol=0, atol=2e-6)


def test_float32_evaluation_and_edges():
    c = np.concatenate(([0.0, 1e-7], np.linspace(0.001, 1, 60)))
    cases = [
        (fresnel_schlick, (0.04,)),
        (fresnel_schlick, (0.9,)),
        (fresnel_dielectric, (1.5,)),
        (fresnel_dielectric, (0.6,)),
        *[(fresnel_conductor, (e, k)) for e, k in zip(GOLD_ETA, GOLD_K)],
        (fresnel_conductor, (1.2, 7.0)),
        (fresnel_conductor, (1e-3, 1e4)),
        (fresnel_conductor, (1e3, 0.0)),
    ]
    for fn, params in cases:
        single = fn(c.astype(np.float32), *[np.float32(p) for p in params])
        double = fn(c, *params)
        assert single.dtype == np.float32 and double.dtype == np.float64
        assert np.all(np.isfinite(single)) and np.all(np.isfinite(double))
        np.testing.assert_allclose(single, double, rtol=0, atol=2e-6, err_msg=f"{fn.__name__}{params}")
    # the far ends of the indices stay finite
    for e, k in [(1e-300, 0.0), (1e-300, 1e150), (1e150, 1e150), (1e150, 0.0), (0.5, 1e-300)]:
        assert np.all(np.isfinite(fresnel_conductor(c, e, k)))


def test_cosines_outside_the_domain():
    # rounding just above 1 and the zero-weight nodes just below 0 that directional_albedo passes are clipped
    assert fresnel_schlick(1 + 2e-16, 0.04) == fresnel_schlick(1.0, 0.04)
    assert fresnel_conductor(-1e-9, 0.21, 3.272) == fresnel_conductor(0.0, 0.21, 3.272)
    for call, error in [
        (lambda: fresnel_schlick(1.01, 0.04), ValueError),
        (lambda: fresnel_schlick(-1.5, 0.04), ValueError),
        (lambda: fresnel_schlick(0.5, 1.2), ValueError),
        (lambda: fresnel_conductor(0.5, 0.0, 3.0), ValueError),
        (lambda: fresnel_conductor(0.5, 0.2, -1.0), ValueError),
        (lambda: fresnel_conductor(0.5, np.inf, 1.0), ValueError),
        (lambda: fresnel_dielectric(np.nan, 1.5), ValueError),
        (lambda: fresnel_dielectric(0.5, "glass"), TypeError),
        (lambda: average_fresnel(0.04), TypeError),
        (lambda: average_fresnel(lambda c: c / 0), ValueError),
        (lambda: fresnel_compensation_factor(0.5, 0.5, form="other"), ValueError),
        (lambda: random_walk_albedo(0.5, 0.5, schlick(0.04), first_bounce="other"), ValueError),
    ]:
        with np.errstate(divide="ignore", invalid="ignore"), pytest.raises(error):
            call()


# -- the average Fresnel ----------------------------------------------------------------------------------
def test_average_fresnel_against_an_independent_quadrature():
    # conductors: gold (Johnson and Christy), and indices chosen for their shapes: a sharp bend at t0 = 0
    # inside [0, 1] (eta > k, small eta k), an aluminium-like large k
    eta = np.array([*GOLD_ETA, 0.8, 0.6, 1.2, 2.0])
    k = np.array([*GOLD_K, 0.01, 0.3, 7.0, 0.0])
    ours = average_fresnel_conductor(eta, k)
    for e, kk, value in zip(eta, k, ours):
        m2 = 1 - (e * e - kk * kk)
        bend = (np.arccos(np.sqrt(m2)),) if 0 < m2 < 1 else ()
        assert abs(value - theta_average(lambda c, e=e, kk=kk: complex_fresnel(c, e, kk), bend)) < 1e-12, (e, kk)
    # dielectrics, from outside (eta > 1) and from inside (eta < 1, the critical angle a square-root kink)
    eta_d = np.array([1.0001, 1.33, 1.5, 2.4, 0.5, 0.75, 1 / 1.5])
    for e, value in zip(eta_d, average_fresnel_dielectric(eta_d)):
        bend = (np.arcsin(e),) if e < 1 else ()
        assert abs(value - theta_average(lambda c, e=e: complex_fresnel(c, e, 0.0), bend)) < 1e-12, e
    # from inside, everything beyond the critical angle is reflected: F_avg >= 1 - eta^2 (the cosine-weighted
    # share of the cone sin(theta) > eta); and the matched interface averages to 0, large k to 1
    inside = eta_d < 1
    assert np.all(average_fresnel_dielectric(eta_d[inside]) >= 1 - eta_d[inside] ** 2)
    assert float(average_fresnel_dielectric(1.0)) < 1e-20
    assert 1 - float(average_fresnel_conductor(0.21, 1e6)) < 1e-11
    assert average_fresnel_conductor(GOLD_ETA[:, None], GOLD_K[:, None]).shape == (3, 1)


# -- the coloured factor ----------------------------------------------------------------------------------
def test_compensation_factor_is_the_sum_of_its_series():
    f = np.array([0.0, 0.04, 0.0857, 0.5, 0.9, 0.99, 1.0])[:, None]
    e = np.array([0.05, 0.37, 0.69, 0.91, 1.0])[None, :]
    # sum_{k>=1} F^(k+1) E (1 - E)^k, term by term, over the F = 1 lobe's energy 1 - E
    series = np.zeros(np.broadcast(f, e).shape)
    term = f * f * e * (1 - e)
    for _ in range(3000):
        series += term
        term = term * f * (1 - e)
    with np.errstate(invalid="ignore", divide="ignore"):
        expected = np.where(e < 1, series / (1 - e), f * f)  # E_avg = 1: the limit F^2 (no lobe there anyway)
    kc = fresnel_compensation_factor(f, e)
    np.testing.assert_allclose(kc, expected, rtol=1e-13, atol=1e-16)
    np.testing.assert_array_equal(fresnel_compensation_factor(1.0, e), 1.0)  # F = 1: exactly 1
    assert fresnel_compensation_factor(1.0, 0.0) == 1.0  # the limit along F = 1
    other = fresnel_compensation_factor(f, e, form="unweighted_first")
    np.testing.assert_allclose(other * f, kc, rtol=1e-15, atol=0)  # one Fresnel factor fewer
    assert np.all(kc <= f * f + 1e-16) and np.all(other <= f + 1e-16)
    # RGB by broadcasting
    assert fresnel_compensation_factor(average_fresnel_conductor(GOLD_ETA, GOLD_K), 0.7).shape == (3,)


@pytest.mark.parametrize("model", GGX_MODELS)
def test_white_furnace_with_fresnel_equal_to_one(model):
    metal = lambda c: fresnel_conductor(c, 0.21, 1e6)  # noqa: E731  (k -> infinity)
    f_avg = average_fresnel(metal)
    for alpha in ALPHAS:
        one = compensated_fresnel_albedo(MU, alpha, schlick(1.0), model)  # F0 = 1: F = 1 exactly, f_add = 1
        np.testing.assert_allclose(one, 1.0, rtol=0, atol=1e-6)
        if alpha == 0.5:
            np.testing.assert_allclose(one, compensated_albedo(MU, alpha, model), rtol=0, atol=1e-14)
        assert 1 - float(fresnel_compensation_factor(f_avg, average_albedo(alpha, model))) < 1e-9
        np.testing.assert_allclose(
            compensated_fresnel_albedo(MU, alpha, metal, model, f_avg=f_avg), 1.0, rtol=0, atol=1e-6
        )


@pytest.mark.parametrize("model", GGX_MODELS)
def test_lobe_albedo_is_f_add_times_the_missing_energy(model):
    # integrate the coloured lobe over mu_i with this file's own rule: 2 pi int f_ms_F mu_i dmu_i, RGB at once
    nodes, weights = graded_rule()
    f_avg = np.array([average_fresnel_schlick(0.04), *average_fresnel_conductor(GOLD_ETA, GOLD_K)])
    for alpha in ALPHAS:
        e_o = directional_albedo(MU, alpha, model)
        f_add = fresnel_compensation_factor(f_avg, average_albedo(alpha, model))
        lobe = fresnel_multiple_scattering_brdf(MU[:, None, None], nodes[None, :, None], alpha, f_avg, model)
        albedo = 2 * np.pi * np.einsum("ijc,j->ic", lobe, weights * nodes)
        np.testing.assert_allclose(albedo, f_add * (1 - e_o[:, None]), rtol=0, atol=1e-10)
        if alpha == 0.5:  # reciprocal
            swapped = fresnel_multiple_scattering_brdf(nodes[None, :, None], MU[:, None, None], alpha, f_avg, model)
            np.testing.assert_allclose(lobe, swapped, rtol=1e-14, atol=0)


@pytest.mark.parametrize("model", GGX_MODELS)
def test_constant_fresnel_is_exact_under_the_model(model):
    c = 0.3
    const = lambda x: np.full(np.shape(x), c)  # noqa: E731
    assert abs(average_fresnel(const) - c) < 1e-15
    for alpha in ALPHAS:
        e = directional_albedo(MU, alpha, model)
        e_avg = float(average_albedo(alpha, model))
        # sum over paths of c^n P_n: P_1 = E(mu_o), P_n = (1 - E(mu_o)) (1 - E_avg)^(n-2) E_avg (A1-A2)
        paths = c * e
        term = c * c * (1 - e) * e_avg
        for _ in range(400):
            paths = paths + term
            term = term * c * (1 - e_avg)
        total = compensated_fresnel_albedo(MU, alpha, const, model)
        np.testing.assert_allclose(total, paths, rtol=0, atol=1e-10)
        # the reference with the exact first reflection agrees (R = c), so does the model's own total
        np.testing.assert_allclose(random_walk_albedo(MU, alpha, const, model), paths, rtol=0, atol=1e-10)
        np.testing.assert_allclose(
            random_walk_albedo(MU, alpha, const, model, first_bounce="averaged"), paths, rtol=0, atol=1e-12
        )
        # the form with a Fresnel factor fewer makes the lobe 1/c too bright
        other = compensated_fresnel_albedo(MU, alpha, const, model, form="unweighted_first")
        np.testing.assert_allclose(other - c * e, (paths - c * e) / c, rtol=1e-9, atol=1e-12)


# -- the first reflection ---------------------------------------------------------------------------------
def test_visible_fresnel_normalisation_limits_and_an_independent_quadrature():
    mu = np.concatenate(([0.0, 1e-6, 1e-3], np.linspace(0.05, 1, 20)))
    alpha = np.array([1e-4, 0.01, 0.2, 0.5, 1.0])[:, None]
    np.testing.assert_allclose(visible_fresnel(mu, alpha), 1.0, rtol=0, atol=1e-10)  # G1 normalises D_o
    f = gold(0)
    np.testing.assert_allclose(visible_fresnel(mu, 0.0, f), f(mu), rtol=0, atol=0)  # the mirror
    # alpha = 1 (D = 1/pi) at mu_o = 1: D_o is the cosine lobe about n, so R = F_avg; at mu_o = 0 the quarter
    # sphere {m_z > 0, w_o . m > 0} mirrors onto the other half of the lobe about w_o: R = F_avg again
    for name in ("schlick 0.04", "gold R"):
        np.testing.assert_allclose(visible_fresnel([0.0, 1.0], 1.0, CASES[name]), f_avg_of(name), rtol=0, atol=1e-11)

    # direct quadrature over (theta_m, phi): R = G1 / mu_o int max(0, w_o . m) D F sin(theta_m) dphi dtheta_m
    def direct(mu_o, alpha, fresnel):
        s_o = np.sqrt(1 - mu_o * mu_o)

        def inner(theta):
            ct, st = np.cos(theta), np.sin(theta)
            # w_o . m >= 0 for cos(phi) >= -mu_o ct / (s_o st)
            edge = np.pi if s_o * st <= mu_o * ct else np.arccos(-mu_o * ct / (s_o * st))

            def g(phi):
                om = mu_o * ct + s_o * st * np.cos(phi)
                return om * float(fresnel(min(max(om, 0.0), 1.0)))

            return 2 * integrate.quad(g, 0, edge, epsabs=1e-13, epsrel=1e-12)[0] * float(ggx_ndf(ct, alpha)) * st

        theta_c = np.pi / 2 - np.arccos(mu_o)
        value = integrate.quad(inner, 0, np.pi / 2, points=[theta_c], epsabs=1e-12, epsrel=1e-11, limit=200)[0]
        return float(smith_g1(mu_o, alpha)) / mu_o * value

    for mu_o, a, name in [(0.5, 0.5, "gold R"), (0.15, 0.3, "schlick 0.04")]:
        assert abs(float(visible_fresnel(mu_o, a, CASES[name])) - direct(mu_o, a, CASES[name])) < 1e-9


@pytest.mark.parametrize("model", GGX_MODELS)
def test_fresnel_routes_agree_with_the_conductor(model):
    mu, alpha = np.array([0.0, 0.05, 0.5, 1.0]), np.array([[0.01], [0.3], [1.0]])
    for f in (gold(2), lambda c: fresnel_dielectric(c, 1.5)):
        a = directional_albedo(mu, alpha, model, fresnel=f)
        b = directional_albedo(mu, alpha, model, method="direction", fresnel=f)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)


# -- what is conserved on average, and the per-direction errors -----------------------------------------
# the per-direction grid: the nodes of graded_rule (so that cosine-weighted averages come with it) and both ends
NODES, WEIGHTS = graded_rule()
GRID = np.concatenate(([0.0], NODES, [1.0]))
WM = np.concatenate(([0.0], 2 * WEIGHTS * NODES, [0.0]))  # 2 int_0^1 . mu dmu on GRID


@cache
def albedo_on_grid(alpha, model):
    return directional_albedo(GRID, alpha, model)


@cache
def visible_on_grid(name, alpha):
    return visible_fresnel(GRID, alpha, CASES[name])  # the same for both Smith forms


@cache
def per_direction(name, alpha, model):
    """On GRID: E, E_F, R, f_add, g, Kulla-Conti's total E_F + f_add (1 - E) and the two references of the
    module docstring, from their formulas (random_walk_albedo is checked against them separately)."""
    f_avg = f_avg_of(name)
    e, r = albedo_on_grid(alpha, model), visible_on_grid(name, alpha)
    e_f = directional_albedo(GRID, alpha, model, fresnel=CASES[name])
    e_avg = float(average_albedo(alpha, model))
    f_add = float(fresnel_compensation_factor(f_avg, e_avg))
    g = f_avg * e_avg / (1 - f_avg * (1 - e_avg))
    return dict(
        e=e,
        e_f=e_f,
        r=r,
        f_avg=f_avg,
        e_avg=e_avg,
        f_add=f_add,
        g=g,
        total=e_f + f_add * (1 - e),
        exact=e_f + g * (r - e_f),
        averaged=f_avg * e + g * f_avg * (1 - e),
    )


def test_random_walk_albedo_is_its_formula():
    f, f_avg = CASES["gold G"], f_avg_of("gold G")
    for model in GGX_MODELS:
        e, e_f = directional_albedo(MU, 0.5, model), directional_albedo(MU, 0.5, model, fresnel=f)
        e_avg = float(average_albedo(0.5, model))
        g = f_avg * e_avg / (1 - f_avg * (1 - e_avg))
        np.testing.assert_allclose(
            random_walk_albedo(MU, 0.5, f, model, f_avg=f_avg),
            e_f + g * (visible_fresnel(MU, 0.5, f) - e_f),
            rtol=0,
            atol=1e-15,
        )
        np.testing.assert_allclose(
            random_walk_albedo(MU, 0.5, f, model, first_bounce="averaged"),
            f_avg * e + g * f_avg * (1 - e),
            rtol=0,
            atol=1e-15,
        )
        # and both are 1 with F = 1
        np.testing.assert_allclose(random_walk_albedo(MU, 0.5, schlick(1.0), model), 1.0, rtol=0, atol=1e-10)


@pytest.mark.parametrize("model", GGX_MODELS)
def test_cosine_averaged_total_against_the_series(model):
    rows = []
    for alpha in ALPHAS:
        e_avg = float(average_albedo(alpha, model))
        assert abs(WM @ albedo_on_grid(alpha, model) - e_avg) < 1e-10  # this file's rule against the package's
        # the lobe integrated numerically twice (over mu_i by compensated_fresnel_albedo, over mu_o here), once
        # per model: the average of E_F + f_add (1 - E) is E_F,avg + f_add (1 - E_avg)
        if alpha == 0.5:
            d = per_direction("gold R", alpha, model)
            total = compensated_fresnel_albedo(NODES, alpha, CASES["gold R"], model, f_avg=d["f_avg"])
            assert abs(2 * (WEIGHTS * NODES) @ total - (WM @ d["e_f"] + d["f_add"] * (1 - e_avg))) < 1e-10
        for name in CASES:
            d = per_direction(name, alpha, model)
            f_avg, e_f_avg, total_avg = d["f_avg"], WM @ d["e_f"], WM @ d["total"]
            # the model's total, sum_{n>=1} F_avg^n E_avg (1 - E_avg)^(n-1) term by term
            series, term = 0.0, f_avg * e_avg
            while term > 1e-18:
                series, term = series + term, term * f_avg * (1 - e_avg)
            assert abs(WM @ d["averaged"] - series) < 1e-10
            # Kulla-Conti's multiple scattering is the series' exactly; the totals differ by the single scattering
            assert abs((total_avg - series) - (e_f_avg - f_avg * e_avg)) < 1e-10
            rows.append((name, alpha, total_avg, series, e_f_avg - f_avg * e_avg, WM @ d["exact"]))
    print(
        f"\n{model}: cosine-averaged albedo of f_F + f_ms_F; the series' F_avg E_avg / (1 - F_avg (1 - E_avg)); "
        "their difference E_F,avg - F_avg E_avg; the exact-first-bounce reference's average"
    )
    for name, alpha, tot, ser, diff, ref in rows:
        print(f"  {name:13s} alpha {alpha:3.1f}: {tot:.6f} {ser:.6f} {diff:+.2e} {ref:.6f}")


@pytest.mark.parametrize("model", GGX_MODELS)
def test_per_direction_errors_are_within_their_bounds(model):
    print(
        f"\n{model}: max over mu_o of |total - reference (exact first bounce)| and of |E_F - F_avg E| (at mu_o), f_add"
    )
    for name in CASES:
        f_min, f_max = fresnel_range(name)
        spread = f_max - f_min + 1e-12
        for alpha in ALPHAS:
            d = per_direction(name, alpha, model)
            # the first reflection reflects R, of which E_F leaves: E_F <= R <= 1, and R - E_F, like
            # F_avg (1 - E), lies in [F_min, F_max] (1 - E)
            assert np.all(d["e_f"] <= d["r"] + 1e-12) and np.all(d["r"] <= 1 + 1e-12)
            lost = d["r"] - d["e_f"]
            assert np.all(lost >= f_min * (1 - d["e"]) - 1e-12) and np.all(lost <= f_max * (1 - d["e"]) + 1e-12)
            # Kulla-Conti against the reference with the exact first reflection: g (F_avg (1 - E) - (R - E_F))
            err = d["total"] - d["exact"]
            np.testing.assert_allclose(err, d["g"] * (d["f_avg"] * (1 - d["e"]) - lost), rtol=0, atol=1e-14)
            assert np.all(np.abs(err) <= d["g"] * spread * (1 - d["e"]) + 1e-14)
            # against the model itself (every reflection F_avg): the single scattering E_F - F_avg E only
            ss = d["e_f"] - d["f_avg"] * d["e"]
            np.testing.assert_allclose(d["total"] - d["averaged"], ss, rtol=0, atol=1e-14)
            assert np.all(np.abs(ss) <= spread * d["e"] + 1e-14)
            # E_F <= E and f_add <= 1: the compensated albedo never exceeds 1
            assert np.all(d["total"] <= 1 + 1e-12)
            i, j = int(np.argmax(np.abs(err))), int(np.argmax(np.abs(ss)))
            print(
                f"  {name:13s} alpha {alpha:3.1f}: {err[i]:+.2e} ({GRID[i]:.3f})   {ss[j]:+.2e} ({GRID[j]:.3f})"
                f"   {d['f_add']:.4f}"
            )
