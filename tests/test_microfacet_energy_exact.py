"""The exact engine of the microfacet_energy family (fitlab.families.microfacet_energy.exact) and its tables.

Every value is checked against an independent computation: the two quadrature routes of E against each
other, closed forms (GGX at alpha = 1, Oren-Nayar everywhere, derived again here with sympy), mpmath at
high precision, limits and identities.  Numbers from the blog article are used only as the claims under
test, named as such.
"""

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from fitlab.families.microfacet_energy.exact import (
    GGX_MODELS,
    MODEL_NAMES,
    OREN_NAYAR_MODELS,
    average_albedo,
    brdf,
    compensated_albedo,
    crossover_alpha,
    directional_albedo,
    energy_integrals,
    get_model,
    ggx_brdf,
    ggx_ndf,
    multiple_scattering_brdf,
    oren_nayar_brdf,
    oren_nayar_coefficients,
    smith_g1,
    smith_g2,
    smith_lambda,
)
from fitlab.families.microfacet_energy.targets import tabulate
from fitlab.store import read_table

DATA = Path(__file__).resolve().parents[1] / "fitlab" / "data" / "microfacet_energy"

# grid of the route comparison: both ends of mu, grazing and near-normal, small and large alpha
MU_EDGES = np.array([0.0, 1e-9, 1e-4, 0.01, 0.2, 0.5, 0.8, 0.99, 1 - 1e-9, 1.0])
ALPHA_EDGES = np.array([1e-5, 1e-3, 0.02, 0.1, 0.4, 0.75, 1.0])


@cache
def routes(model: str):
    """E on MU_EDGES x ALPHA_EDGES by both routes of ``model``."""
    mu, alpha = np.meshgrid(MU_EDGES, ALPHA_EDGES)
    methods = ("half_vector", "direction") if model in GGX_MODELS else ("closed_form", "direction")
    return tuple(directional_albedo(mu, alpha, model, method=m) for m in methods)


def gauss_legendre(n, lo=0.0, hi=1.0):
    x, w = np.polynomial.legendre.leggauss(n)
    return lo + (hi - lo) * (x + 1) / 2, (hi - lo) * w / 2


# -- the two routes ---------------------------------------------------------------------------------
@pytest.mark.parametrize("model", MODEL_NAMES)
def test_two_routes_agree_on_a_grid_with_its_edges(model):
    first, second = routes(model)
    assert np.all(np.isfinite(first)) and np.all(first > 0)
    if model in GGX_MODELS:
        assert np.all(first <= 1 + 1e-12)  # (Oren-Nayar may exceed 1: test_oren_nayar_gains_energy_at_grazing)
    np.testing.assert_allclose(first, second, rtol=0, atol=1e-9)


@pytest.mark.parametrize("smith", ["separable", "correlated"])
def test_routes_agree_down_to_alpha_1e_6(smith):
    # the peak is 1e-6 wide; at normal incidence it lies within alpha^2 = 1e-12 of mu_i = 1
    mu = np.array([1e-3, 0.3, 0.9, 1.0])
    a = directional_albedo(mu, 1e-6, f"ggx_{smith}", method="half_vector")
    b = directional_albedo(mu, 1e-6, f"ggx_{smith}", method="direction")
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)


@pytest.mark.parametrize("model", GGX_MODELS)
def test_routes_agree_with_a_fresnel_factor(model):
    def schlick(cos_d):
        return 0.04 + 0.96 * (1 - cos_d) ** 5

    mu, alpha = np.array([0.0, 0.05, 0.5, 1.0]), np.array([[0.01], [0.3], [1.0]])
    a = directional_albedo(mu, alpha, model, fresnel=schlick)
    b = directional_albedo(mu, alpha, model, method="direction", fresnel=schlick)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)
    # a constant factor scales E, and alpha = 0 (the mirror, w_o . h = mu) gives F(mu)
    np.testing.assert_allclose(
        directional_albedo(mu, alpha, model, fresnel=lambda c: 0.25 + 0 * c),
        0.25 * directional_albedo(mu, alpha, model),
        rtol=1e-14,
    )
    np.testing.assert_allclose(directional_albedo(mu, 0.0, model, fresnel=schlick), schlick(mu), rtol=1e-15)


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_average_albedo_by_both_routes(model):
    alpha = np.array([0.0, 0.3, 1.0])
    default = average_albedo(alpha, model)
    other = average_albedo(alpha, model, method="direction")
    np.testing.assert_allclose(default, other, rtol=0, atol=1e-9)
    assert default[0] == 1.0  # alpha = 0: the mirror, or Lambert
    np.testing.assert_allclose(average_albedo(alpha, model, convention="blog"), np.pi * default, rtol=1e-15)


# -- high precision -------------------------------------------------------------------------------------
def test_mpmath_at_normal_incidence_and_at_one_oblique_point():
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 20

    def blog_ggx(mu_o, mu_i, phi, a):
        # the blog's three brackets, with its mu_h given the square root it lacks in print
        mu_h = (mu_o + mu_i) / mp.sqrt(2 * (1 + mu_o * mu_i + mp.sqrt((1 - mu_o**2) * (1 - mu_i**2)) * mp.cos(phi)))
        d = a**2 / (mp.pi * (mu_h**2 * (a**2 - 1) + 1) ** 2)
        return d / ((mu_i + mp.sqrt(a**2 + (1 - a**2) * mu_i**2)) * (mu_o + mp.sqrt(a**2 + (1 - a**2) * mu_o**2)))

    for alpha in ("0.01", "0.3"):
        a = mp.mpf(alpha)
        # mu_o = 1: no azimuthal dependence; split where the peak (width ~ alpha^2 in mu_i) sits
        cuts = sorted({p for p in (0, 1 - 64 * a**2, 1 - 4 * a**2, 1 - a**2 / 4, 1) if p >= 0})
        exact = mp.quad(lambda mu, a=a: 2 * mp.pi * blog_ggx(mp.mpf(1), mu, mp.pi, a) * mu, cuts)
        assert abs(directional_albedo(1.0, float(alpha)) - float(exact)) < 1e-12
    mp.mp.dps = 15
    a, mu_o = mp.mpf("0.6"), mp.mpf("0.5")
    exact = mp.quad(lambda mu, phi: 2 * blog_ggx(mu_o, mu, phi, a) * mu, [0, mu_o, 1], [0, 3 * mp.pi / 4, mp.pi])
    assert abs(directional_albedo(0.5, 0.6) - float(exact)) < 1e-11


# -- closed forms, limits and identities ---------------------------------------------------------------
def test_ggx_at_alpha_1_in_closed_form():
    # alpha = 1: D = 1/pi and S(mu) = 1, so E is an elementary integral over mu_i
    mu = np.concatenate(([0.0, 1e-12], np.linspace(0.05, 1, 20)))
    separable = 2 * (1 - np.log(2)) / (1 + mu)  # 2/(1 + mu_o) int_0^1 mu_i/(1 + mu_i) dmu_i
    with np.errstate(divide="ignore", invalid="ignore"):
        correlated = np.where(mu > 0, 1 - mu * np.log1p(1 / mu), 1.0)  # int_0^1 mu_i/(mu_o + mu_i) dmu_i
    np.testing.assert_allclose(directional_albedo(mu, 1.0, "ggx_separable"), separable, rtol=0, atol=1e-12)
    np.testing.assert_allclose(directional_albedo(mu, 1.0, "ggx_correlated"), correlated, rtol=0, atol=1e-12)
    assert abs(average_albedo(1.0, "ggx_separable") - 4 * (1 - np.log(2)) ** 2) < 1e-12


def test_smith_forms_agree_at_normal_incidence_and_correlated_is_1_at_grazing():
    alpha = np.array([1e-3, 0.05, 0.3, 0.7, 1.0])
    # G1(w_o) = 1 at mu_o = 1, so both G2 / (4 mu_i mu_o) are 1 / (2 (mu_i + S(mu_i)))
    np.testing.assert_allclose(
        directional_albedo(1.0, alpha, "ggx_separable"),
        directional_albedo(1.0, alpha, "ggx_correlated"),
        rtol=0,
        atol=1e-12,
    )
    # at grazing every visible facet reflects upwards and G2/G1(w_o) -> 1 (height-correlated only)
    np.testing.assert_allclose(directional_albedo(0.0, alpha, "ggx_correlated"), 1.0, rtol=0, atol=1e-10)
    assert np.all(directional_albedo(0.0, alpha, "ggx_separable") < 0.95)


@pytest.mark.parametrize("model", GGX_MODELS)
def test_ggx_mirror_limit(model):
    mu = np.array([0.0, 1e-3, 0.5, 1.0])
    assert np.all(directional_albedo(mu, 0.0, model) == 1.0)  # alpha = 0 is defined as the mirror
    # E -> 1 as alpha -> 0 at fixed mu > 0 (the masking loss is O(alpha^2 tan^2 theta))
    assert np.all(np.abs(directional_albedo(mu[1:], 1e-6, model) - 1) < 1e-6)
    e_grazing = directional_albedo(0.0, [1e-6, 1e-4], model)
    assert abs(e_grazing[0] - e_grazing[1]) < 1e-6  # E(0, alpha) settles as alpha -> 0 ...
    if model == "ggx_separable":
        assert e_grazing[0] < 0.95  # ... below 1: separable E is discontinuous at (mu, alpha) = (0, 0)


@pytest.mark.parametrize("model", [m for m in MODEL_NAMES if m != "oren_nayar_057"])
def test_albedo_decreases_with_roughness_on_average(model):
    alpha = np.linspace(0, 1, 11)
    e_avg = average_albedo(alpha, model)
    assert np.all(np.diff(e_avg) < 0)


@pytest.mark.parametrize("model", OREN_NAYAR_MODELS)
def test_oren_nayar_gains_energy_at_grazing(model):
    # A + kappa B > 1 exactly when sigma^2 < (0.45 kappa a - 0.045) / (0.5 - 0.45 kappa): E(0) = A + B/2
    # (cos phi) or A + 4B/(3 pi) (gamma) exceeds 1 for small roughness
    m = get_model(model)
    kappa = 0.5 if m.azimuth == "cos_phi" else 4 / (3 * np.pi)
    threshold = 2 / np.pi * np.sqrt((0.45 * kappa * m.a_constant - 0.045) / (0.5 - 0.45 * kappa))
    e = directional_albedo(0.0, threshold * np.array([0.5, 1 - 1e-9, 1 + 1e-9, 1.5]), model, method="direction")
    assert e[0] > 1 and e[1] > 1 and e[2] < 1 and e[3] < 1
    # E_avg = A + k B exceeds 1 only for the footnote's 0.57 with cos(phi), below alpha_1 where it is 1
    e_avg = average_albedo(np.linspace(0.01, 1, 100), model, method="direction")
    if model != "oren_nayar_057":
        assert np.all(e_avg < 1)
        return
    k = 2 / 3 - 64 / (45 * np.pi)
    alpha_1 = 2 / np.pi * np.sqrt((0.45 * k * 0.57 - 0.045) / (0.5 - 0.45 * k))
    assert abs(average_albedo(alpha_1, model, method="direction") - 1) < 1e-12
    assert average_albedo(alpha_1 / 2, model) > 1 and average_albedo(2 * alpha_1, model) < 1
    # there the compensation lobe has no finite value: it grows without bound as alpha -> alpha_1
    lobe = multiple_scattering_brdf(0.5, 0.0, alpha_1 * (1 + np.array([1e-3, 1e-5])), model)
    assert abs(lobe[1]) > 50 * abs(lobe[0])


def test_oren_nayar_lambert_limit_and_grazing_values():
    mu = np.array([0.0, 0.3, 1.0])
    for model in OREN_NAYAR_MODELS:
        # sigma = 0 is Lambert: f = 1/pi, E = 1 (with the blog's displayed f_r, which already holds
        # cos(theta_i), the same integral would give 2/3)
        for method in ("closed_form", "direction"):
            np.testing.assert_allclose(directional_albedo(mu, 0.0, model, method=method), 1.0, rtol=0, atol=1e-14)
        m = get_model(model)
        a, b = oren_nayar_coefficients(np.array([0.2, 1.0]), m.a_constant)
        e = directional_albedo([[0.0], [1.0]], [0.2, 1.0], model, method="direction")
        grazing = a + b / 2 if m.azimuth == "cos_phi" else a + 4 * b / (3 * np.pi)
        np.testing.assert_allclose(e[0], grazing, rtol=0, atol=1e-12)
        np.testing.assert_allclose(e[1], a, rtol=0, atol=1e-12)  # normal incidence: theta_min = 0


def test_oren_nayar_average_constants_by_sympy():
    sp = pytest.importorskip("sympy")
    t, ti = sp.symbols("t t_i", positive=True)
    for azimuth, model in (("cos_phi", "oren_nayar"), ("gamma", "oren_nayar_gamma")):
        # E = A + (2B/pi) [int_0^t ... + int_t^(pi/2) ...] from the BRDF, then E_avg = A + B k
        c = 1 if azimuth == "cos_phi" else sp.sin(t) * sp.sin(ti)
        inner = sp.integrate(sp.expand(sp.sin(t) * sp.sin(ti) ** 2 * c), (ti, 0, t)) + sp.tan(t) * sp.integrate(
            sp.expand(sp.sin(ti) ** 2 * sp.cos(ti) * c), (ti, t, sp.pi / 2)
        )
        k = sp.nsimplify(4 / sp.pi * sp.integrate(sp.simplify(inner * sp.cos(t) * sp.sin(t)), (t, 0, sp.pi / 2)))
        a, b = oren_nayar_coefficients(0.8, 0.33)
        assert abs(average_albedo(0.8, model) - (a + b * float(k))) < 1e-14


def test_oren_nayar_shortcut_against_the_exact_azimuth():
    # the HLSL's unnormalised gamma = s_o s_i cos(phi) weights the B lobe by s_o s_i <= 1
    mu, alpha = np.meshgrid(np.linspace(0, 1, 11), np.linspace(0, 1, 11))
    exact = directional_albedo(mu, alpha, "oren_nayar")
    shortcut = directional_albedo(mu, alpha, "oren_nayar_gamma")
    assert np.all(shortcut <= exact + 1e-15)
    np.testing.assert_allclose(shortcut[:, -1], exact[:, -1], rtol=0, atol=1e-15)  # normal incidence: both A
    np.testing.assert_allclose(shortcut[0], exact[0], rtol=0, atol=1e-15)  # sigma = 0: Lambert
    assert np.max(exact - shortcut) > 0.01  # visibly darker elsewhere


# -- the BRDFs ----------------------------------------------------------------------------------------
def random_configurations(n=400, seed=17):
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, n), rng.uniform(0, 1, n), rng.uniform(0, 2 * np.pi, n), rng.uniform(0.01, 1, n)


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_reciprocity(model):
    mu_o, mu_i, phi, alpha = random_configurations()
    np.testing.assert_allclose(brdf(mu_o, mu_i, phi, alpha, model), brdf(mu_i, mu_o, phi, alpha, model), rtol=1e-13)


def test_ggx_against_the_blog_formula_with_vectors():
    mu_o, mu_i, phi, alpha = random_configurations()
    s_o, s_i = np.sqrt(1 - mu_o**2), np.sqrt(1 - mu_i**2)
    w_o = np.stack([s_o, 0 * s_o, mu_o], axis=-1)
    w_i = np.stack([s_i * np.cos(phi), s_i * np.sin(phi), mu_i], axis=-1)
    h = w_o + w_i
    mu_h = h[:, 2] / np.linalg.norm(h, axis=-1)
    a2 = alpha**2
    d = a2 / (np.pi * (mu_h**2 * (a2 - 1) + 1) ** 2)
    root_o, root_i = np.sqrt(a2 + (1 - a2) * mu_o**2), np.sqrt(a2 + (1 - a2) * mu_i**2)
    np.testing.assert_allclose(ggx_brdf(mu_o, mu_i, phi, alpha), d / ((mu_i + root_i) * (mu_o + root_o)), rtol=1e-10)
    g2 = 1 / (1 + smith_lambda(mu_o, alpha) + smith_lambda(mu_i, alpha))
    np.testing.assert_allclose(ggx_brdf(mu_o, mu_i, phi, alpha, "correlated"), d * g2 / (4 * mu_o * mu_i), rtol=1e-10)
    # the blog's printed mu_h (no square root on (1 - mu_o^2)(1 - mu_i^2)) is another function
    printed = (mu_o + mu_i) / np.sqrt(2 * (1 + mu_o * mu_i + (1 - mu_o**2) * (1 - mu_i**2) * np.cos(phi)))
    assert np.max(np.abs(printed - mu_h)) > 0.05


def test_smith_functions_and_ndf():
    mu, alpha = np.array([0.0, 0.2, 0.7, 1.0]), 0.4
    tan2 = np.divide(1 - mu**2, mu**2, out=np.full(mu.shape, np.inf), where=mu > 0)
    np.testing.assert_allclose(smith_lambda(mu, alpha), (-1 + np.sqrt(1 + alpha**2 * tan2)) / 2, rtol=1e-14)
    np.testing.assert_allclose(smith_g1(mu, alpha), 1 / (1 + smith_lambda(mu, alpha)), rtol=1e-14)
    np.testing.assert_allclose(smith_g2(mu[:, None], mu, alpha), smith_g1(mu[:, None], alpha) * smith_g1(mu, alpha))
    assert smith_g1(0.0, 0.0) == 1 and smith_lambda(0.0, 0.0) == 0 and smith_g2(0.0, 0.0, 0.0, "correlated") == 1
    assert smith_g2(0.0, 0.5, alpha, "correlated") == 0
    np.testing.assert_allclose(ggx_ndf([1.0, 0.0], alpha), [1 / (np.pi * alpha**2), alpha**2 / np.pi], rtol=1e-15)
    # int D(m) mu_m dw_m = 1: with u = tan^2(theta_m) / alpha^2 it is int_0^inf du / (1 + u)^2 in closed form;
    # numerically on theta_m in [0, pi/2], graded towards 0 where the peak is
    for a in (0.05, 0.5, 1.0):
        total = 0.0
        for lo, hi in ((0, a / 4), (a / 4, a), (a, 4 * a), (4 * a, np.pi / 2)):
            if lo < np.pi / 2:
                th, w = gauss_legendre(60, lo, min(hi, np.pi / 2))
                total += 2 * np.pi * np.sum(w * ggx_ndf(np.cos(th), a) * np.cos(th) * np.sin(th))
        assert abs(total - 1) < 1e-10


@pytest.mark.parametrize("model", ["ggx_separable", "ggx_correlated", "oren_nayar", "oren_nayar_gamma"])
def test_float32_evaluation(model):
    mu_o, mu_i, phi, alpha = random_configurations()
    if model.startswith("ggx"):
        # and as many near the mirror configuration of a sharp peak (alpha = 0.01)
        mu_o, mu_i = np.concatenate((mu_o, mu_o)), np.concatenate((mu_i, np.minimum(mu_o + 1e-4, 1)))
        phi = np.concatenate((phi, np.full(phi.size, np.pi - 1e-3)))
        alpha = np.concatenate((alpha, np.full(alpha.size, 1e-2)))
    mu_o, mu_i, phi, alpha = (x.astype(np.float32) for x in (mu_o, mu_i, phi, alpha))
    single = brdf(mu_o, mu_i, phi, alpha, model)
    double = brdf(*(x.astype(np.float64) for x in (mu_o, mu_i, phi, alpha)), model)
    assert single.dtype == np.float32
    finite = np.isfinite(double)
    np.testing.assert_allclose(single[finite], double[finite], rtol=2e-5)


def test_oren_nayar_brdf_conventions():
    # the blog's displayed f_r = (1/pi) cos(theta_i) [A + B max(0, cos phi) sin(theta_max) tan(theta_min)]
    mu_o, mu_i, phi, alpha = random_configurations()
    theta_o, theta_i = np.arccos(mu_o), np.arccos(mu_i)
    a, b = oren_nayar_coefficients(alpha)
    blog_displayed = (
        mu_i
        / np.pi
        * (
            a
            + b
            * np.maximum(0, np.cos(phi))
            * np.sin(np.maximum(theta_o, theta_i))
            * np.tan(np.minimum(theta_o, theta_i))
        )
    )
    np.testing.assert_allclose(oren_nayar_brdf(mu_o, mu_i, phi, alpha) * mu_i, blog_displayed, rtol=1e-12)
    np.testing.assert_array_equal(oren_nayar_coefficients(0.0), (1.0, 0.0))  # sigma = 0: Lambert
    sigma2 = (np.pi / 2) ** 2  # alpha = 1: sigma = pi/2
    np.testing.assert_allclose(
        oren_nayar_coefficients(1.0), (1 - sigma2 / (2 * (sigma2 + 0.33)), 0.45 * sigma2 / (sigma2 + 0.09)), rtol=1e-15
    )
    # the footnote variant changes A only
    a57, b57 = oren_nayar_coefficients(alpha, 0.57)
    np.testing.assert_array_equal(b57, b)
    assert np.all(a57 >= a)
    # both directions grazing: tan(theta_min) = inf
    assert oren_nayar_brdf(0.0, 0.0, 0.0, 0.5) == np.inf
    assert oren_nayar_brdf(0.0, 0.0, np.pi, 0.5) == oren_nayar_coefficients(0.5)[0] / np.pi  # phi = pi: no B lobe


# -- energy compensation and the blog's claims ------------------------------------------------------------
@pytest.mark.parametrize("model", MODEL_NAMES)
def test_white_furnace_of_the_compensated_brdf(model):
    mu = np.array([0.0, 0.01, 0.3, 0.7, 1.0])
    for alpha in (0.0, 0.05, 0.5, 1.0):
        np.testing.assert_allclose(compensated_albedo(mu, alpha, model), 1.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("model", MODEL_NAMES)
def test_double_integral_is_pi_in_the_blog_normalisation(model):
    # the blog: "their sum always yield pi"
    alpha = np.array([0.0, 0.2, 0.6, 1.0])
    energy = energy_integrals(alpha, model)
    np.testing.assert_allclose(energy["total"], np.pi, rtol=0, atol=1e-9)
    np.testing.assert_allclose(energy["single"], average_albedo(alpha, model, convention="blog"), rtol=0, atol=1e-9)


def test_multiple_scattering_lobe():
    mu_o, mu_i = np.array([[0.0], [0.4], [1.0]]), np.array([0.0, 0.2, 0.9])
    for model in ("ggx_separable", "oren_nayar"):
        f_ms = multiple_scattering_brdf(mu_o, mu_i, 0.6, model)
        np.testing.assert_allclose(multiple_scattering_brdf(mu_i[:, None], mu_o[:, 0], 0.6, model), f_ms.T, rtol=1e-14)
        e_o, e_i = directional_albedo(mu_o, 0.6, model), directional_albedo(mu_i, 0.6, model)
        e_avg_blog = average_albedo(0.6, model, convention="blog")
        # the blog's eq. 6 with its E_avg (pi times Kulla-Conti's) is the same function
        np.testing.assert_allclose(f_ms, (1 - e_o) * (1 - e_i) / (np.pi - e_avg_blog), rtol=1e-13)
        assert np.all(multiple_scattering_brdf(mu_o, mu_i, 0.0, model) == 0)  # nothing lost by a mirror


def test_where_multiple_scattering_overtakes():
    # the blog: "the multiple scattering BRDF term becomes preponderant ... when alpha > 0.8"
    for model in GGX_MODELS:
        alpha = crossover_alpha(model)
        assert abs(average_albedo(alpha, model) - 0.5) < 1e-9
        assert abs(alpha - 0.8) < 0.05
        at_normal = crossover_alpha(model, mu=1.0)
        assert abs(directional_albedo(1.0, at_normal, model) - 0.5) < 1e-9 and at_normal < alpha
        assert crossover_alpha(model, mu=0.0) is None  # at grazing E stays above 1/2
    # both Smith forms cross together at normal incidence, and the separable (the blog's) GGX first on average
    assert abs(crossover_alpha("ggx_separable", mu=1.0) - crossover_alpha("ggx_correlated", mu=1.0)) < 1e-9
    assert crossover_alpha("ggx_separable") < crossover_alpha("ggx_correlated")
    for model in OREN_NAYAR_MODELS:
        assert crossover_alpha(model) is None


# -- arguments --------------------------------------------------------------------------------------------
def test_vectorised_shapes():
    mu, alpha = np.array([[0.1], [0.5], [0.9]]), np.array([0.2, 0.4, 0.6, 0.8])
    grid = directional_albedo(mu, alpha)
    assert grid.shape == (3, 4)
    np.testing.assert_allclose(grid[1, 2], directional_albedo(0.5, 0.6), rtol=1e-14)
    assert directional_albedo(0.5, 0.6).shape == ()
    assert average_albedo([[0.5]]).shape == (1, 1)


@pytest.mark.parametrize(
    "call, error",
    [
        (lambda: directional_albedo(1.5, 0.5), ValueError),
        (lambda: directional_albedo(-0.1, 0.5), ValueError),
        (lambda: directional_albedo(0.5, 1.01), ValueError),
        (lambda: directional_albedo(0.5, np.nan), ValueError),
        (lambda: directional_albedo("0.5", 0.5), TypeError),
        (lambda: directional_albedo(0.5, 0.5, "ggx"), ValueError),
        (lambda: directional_albedo(0.5, 0.5, "oren_nayar", method="half_vector"), ValueError),
        (lambda: directional_albedo(0.5, 0.5, "oren_nayar", fresnel=lambda c: c), ValueError),
        (lambda: directional_albedo(0.5, 0.5, fresnel=0.04), TypeError),
        (lambda: average_albedo(0.5, convention="pi"), ValueError),
        (lambda: ggx_brdf(0.5, 0.5, np.pi, 0.0), ValueError),  # alpha = 0 is a delta, not a function
        (lambda: ggx_brdf(0.5, 0.5, 7.0, 0.5), ValueError),
        (lambda: ggx_brdf(0.5, 0.5, np.pi, 0.5, smith="uncorrelated"), ValueError),
        (lambda: oren_nayar_brdf(0.5, 0.5, 1.0, 0.5, a_constant=0.4), ValueError),
        (lambda: oren_nayar_brdf(0.5, 0.5, 1.0, 0.5, azimuth="sin_phi"), ValueError),
        (lambda: crossover_alpha(mu=2.0), ValueError),
    ],
)
def test_arguments_outside_the_domain_are_refused(call, error):
    with pytest.raises(error):
        call()


def test_brdf_domain_edges():
    assert np.isfinite(ggx_brdf([0.0, 1.0], [1.0, 0.0], 0.0, 1e-3)).all()
    assert np.isfinite(ggx_brdf(1.0, 1.0, 0.0, 1.0))
    # both grazing: h horizontal, D = alpha^2/pi, V = 1/alpha^2 (separable); at w_i = -w_o the same limit
    np.testing.assert_allclose(ggx_brdf(0.0, 0.0, [0.0, 1.0, np.pi], 0.5), 0.25 / np.pi / 0.25, rtol=1e-14)
    assert ggx_brdf(0.0, 0.0, 0.0, 0.5, "correlated") == np.inf  # V = 1/(2 (mu_o S_i + mu_i S_o))
    assert np.isfinite(ggx_brdf(0.0, 0.0, 0.0, 0.5, "separable"))


# -- tables ---------------------------------------------------------------------------------------------
def test_table_writer_round_trip(tmp_path):
    specs = (
        tabulate.AlbedoTable("ggx", GGX_MODELS, "nodes", 4),
        tabulate.AlbedoTable("oren_nayar", OREN_NAYAR_MODELS, "centres", 3),
    )
    from fitlab.store import write_tables

    write_tables(tmp_path, tabulate.build_tables(False, specs=specs))
    assert tabulate.check_tables(tmp_path, False, every=1, specs=specs) == []
    mu, alpha, values = tabulate.read_albedo_table(tmp_path / specs[0].file, specs[0])
    np.testing.assert_array_equal(mu, [0, 0.25, 0.5, 0.75, 1])
    np.testing.assert_allclose(
        values["ggx_correlated"], directional_albedo(mu, alpha[:, None], "ggx_correlated"), atol=1e-12
    )
    header = (tmp_path / specs[1].file).read_text().splitlines()[:4]
    assert header[1].startswith("# method:") and "texel centres" in header[3]
    # a wrong value is caught
    path = tmp_path / specs[0].file
    lines = path.read_text().splitlines()
    fields = lines[-1].split(",")
    fields[2] = repr(float(fields[2]) + 1e-7)
    path.write_text("\n".join(lines[:-1] + [",".join(fields)]) + "\n")
    failures = tabulate.check_tables(tmp_path, False, every=1, specs=specs)
    assert len(failures) == 1 and specs[0].file in failures[0]


def test_table_grids_and_a_wrong_grid(tmp_path):
    np.testing.assert_array_equal(tabulate.grid("centres", 4), [0.125, 0.375, 0.625, 0.875])
    np.testing.assert_array_equal(tabulate.grid("nodes", 2), [0.0, 0.5, 1.0])
    with pytest.raises(ValueError):
        tabulate.grid("edges", 4)
    nodes, centres = (tabulate.AlbedoTable("ggx", GGX_MODELS, kind, 2) for kind in ("nodes", "centres"))
    from fitlab.store import TableError, write_tables

    write_tables(tmp_path, tabulate.build_tables(False, specs=[centres]))
    (tmp_path / centres.file).rename(tmp_path / nodes.file)
    with pytest.raises(TableError):  # 4 rows where 9 are expected
        tabulate.read_albedo_table(tmp_path / nodes.file, nodes)


@pytest.mark.skipif(not DATA.is_dir(), reason="the committed tables are not in this checkout")
def test_committed_tables_rows_by_the_other_route():
    assert sorted(p.name for p in DATA.glob("*.csv")) == sorted(tabulate.TABLE_FILES)
    assert sum(p.stat().st_size for p in DATA.glob("*.csv")) < 3_000_000
    for spec in tabulate.TABLES:
        mu, alpha, values = tabulate.read_albedo_table(DATA / spec.file, spec)
        pick = np.array([0, mu.size // 3, mu.size - 1])
        for model, table in values.items():
            want = directional_albedo(mu[pick], alpha[pick][:, None], model, method="direction")
            np.testing.assert_allclose(table[np.ix_(pick, pick)], want, rtol=0, atol=1e-9)
    alpha, averages = tabulate.read_average_table(DATA / tabulate.AVERAGE_FILE)
    for model in ("ggx_separable", "oren_nayar_gamma"):
        np.testing.assert_allclose(
            averages[model][[0, 100, 256]], average_albedo(alpha[[0, 100, 256]], model, method="direction"), atol=1e-9
        )
    header, _ = read_table(DATA / tabulate.AVERAGE_FILE, tabulate.AVERAGE_COLUMNS)
    assert tuple(header) == tabulate.AVERAGE_COLUMNS
