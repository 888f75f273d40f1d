"""Fresnel factors with kinks in the exact engine (fitlab.families.microfacet_energy.exact): total internal
reflection, a dielectric seen from its denser side (eta < 1), F = 1 below the critical cosine c_k = sqrt(1 - eta^2)
and a square-root edge above it.

The two routes of directional_albedo, told where the kink is (a FresnelFactor), against each other and against an
independent computation: QUADPACK's adaptive rule (scipy.integrate.quad) over the half vector in coordinates about
w_o, (theta_d, phi_d) with cos(theta_d) = w_o . h, where the kink is the coordinate line theta_d = theta_k, given to
quad as a breakpoint (and D and G2 written here again from their formulas).  The same for visible_fresnel.  The
edges: mu -> 0, alpha -> 0 (the mirror), eta -> 1 from below (the kink goes to grazing).  Nothing here is a pasted
result.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from fitlab.families.microfacet_energy.exact import (
    FresnelFactor,
    average_fresnel,
    average_fresnel_conductor,
    average_fresnel_dielectric,
    conductor_factor,
    dielectric_factor,
    directional_albedo,
    fresnel_conductor,
    fresnel_dielectric,
    visible_fresnel,
)

ETAS = (1 / 1.5, 1 / 1.33, 0.9)
ALPHAS = (0.05, 0.3, 1.0)


def _quad(f, lo, hi, points=()):
    pts = sorted({p for p in points if lo < p < hi})
    return integrate.quad(f, lo, hi, points=pts or None, epsabs=1e-14, epsrel=1e-13, limit=400)[0]


def _about_w_o(mu_o, alpha, eta, weight, visible: bool):
    """int over the half vector h = cos(theta_d) w_o + sin(theta_d) (cos(phi_d) e_1 + sin(phi_d) e_2), e_1 in the
    plane of w_o and n, of sin(theta_d) cos(theta_d) F(cos theta_d) D(h) weight(mu_i): dw_h = sin dtheta dphi, the
    kink of F is theta_d = theta_k.  The azimuthal range is where mu_i = 2 cos(theta_d) h_z - mu_o > 0
    (reflection) or h_z > 0 (visible normals), in closed form; the breakpoints are theta_k, where the range
    reaches 0 or pi, and D's peak at theta_d = theta_o."""
    a2 = alpha * alpha
    s_o, t_o = math.sqrt(1 - mu_o * mu_o), math.acos(mu_o)
    t_k = math.acos(math.sqrt(1 - eta * eta))

    def inner(t):
        ct, st_ = math.cos(t), math.sin(t)
        # reflection: mu_i = mu_o cos(2t) + s_o sin(2t) cos(phi); visible: h_z = mu_o ct + s_o st cos(phi)
        base, amp = (mu_o * (2 * ct * ct - 1), s_o * 2 * st_ * ct) if not visible else (mu_o * ct, s_o * st_)
        if amp <= abs(base):
            if base <= 0:
                return 0.0
            end = math.pi
        else:
            end = math.acos(-base / amp)

        def g(p):
            cp = math.cos(p)
            mz = mu_o * ct + s_o * st_ * cp
            mu_i = max(base + amp * cp, 0.0)
            return a2 / (math.pi * ((a2 - 1) * mz * mz + 1) ** 2) * weight(mu_i)

        return 2 * _quad(g, 0, end) * st_ * ct * float(fresnel_dielectric(ct, eta))

    ends = [abs(math.pi / 2 - t_o)] if visible else [(t_o + math.pi / 2) / 2, abs(math.pi / 2 - t_o) / 2]
    peak = [t_o + s * alpha * k for s in (-1, 1) for k in (0.5, 2, 8)]
    return _quad(inner, 0, math.pi / 2, [t_k, t_o, *ends, *peak])


def quadpack_albedo(mu_o, alpha, eta, smith):
    """E = int D(h) G2 F (w_o . h) / mu_o dw_h over mu_i > 0 (dw_i = 4 (w_o . h) dw_h), G2 / mu_o from Smith's
    Lambda: S(mu) = sqrt(alpha^2 + (1 - alpha^2) mu^2), G1 = 2 mu / (mu + S)."""
    a2 = alpha * alpha
    s_of = lambda mu: math.sqrt(a2 + (1 - a2) * mu * mu)  # noqa: E731
    so = s_of(mu_o)
    if smith == "correlated":  # 1 / (1 + Lambda_o + Lambda_i) / mu_o
        weight = lambda mu_i: 2 * mu_i / (mu_o * s_of(mu_i) + mu_i * so)  # noqa: E731
    else:
        weight = lambda mu_i: 2 * mu_i / (mu_i + s_of(mu_i)) * 2 / (mu_o + so)  # noqa: E731
    return _about_w_o(mu_o, alpha, eta, weight, visible=False)


def quadpack_visible(mu_o, alpha, eta):
    """R = G1(mu_o) / mu_o int (w_o . m) D(m) F(w_o . m) dw_m over m_z > 0."""
    a2 = alpha * alpha
    g1_over_mu = 2 / (mu_o + math.sqrt(a2 + (1 - a2) * mu_o * mu_o))
    return g1_over_mu * _about_w_o(mu_o, alpha, eta, lambda mu_i: 1.0, visible=True)


@pytest.mark.parametrize("eta", ETAS)
def test_both_routes_match_quadpack_across_the_critical_angle(eta):
    """eta in {1/1.5, 1/1.33, 0.9} x alpha in {0.05, 0.3, 1} x mu near 0 and 1 (both Smith forms in turn): half
    vector within 1e-10 and direction within 5e-10 of QUADPACK (measured 3e-11 and 1.5e-10 over 0 <= mu <= 1,
    alpha down to 0.01, eta up to 0.99), and the routes within 4e-10 of each other, as for a smooth F.  The same
    Fresnel as a plain function (no kink named) misses by more than 1e-6 somewhere: the points exercise the kink."""
    f = dielectric_factor(eta)
    plain = lambda c: fresnel_dielectric(c, eta)  # noqa: E731
    blind = 0.0
    for i, (alpha, mu) in enumerate((a, m) for a in ALPHAS for m in (0.02, 0.98)):
        smith = ("correlated", "separable")[i % 2]
        model = f"ggx_{smith}"
        ref = quadpack_albedo(mu, alpha, eta, smith)
        half = float(directional_albedo(mu, alpha, model, fresnel=f))
        direction = float(directional_albedo(mu, alpha, model, method="direction", fresnel=f))
        assert abs(half - ref) < 1e-10, (alpha, mu, half - ref)
        assert abs(direction - ref) < 5e-10, (alpha, mu, direction - ref)
        assert abs(half - direction) < 4e-10
        blind = max(blind, abs(float(directional_albedo(mu, alpha, model, fresnel=plain)) - ref))
    assert blind > 1e-6


def test_the_reported_case():
    """alpha 0.6, mu 0.5, eta 1/1.5, height-correlated (the walk's order 1): the plain function's routes gave
    0.35938 and 0.35654; with the kink both give QUADPACK's value."""
    f = dielectric_factor(1 / 1.5)
    ref = quadpack_albedo(0.5, 0.6, 1 / 1.5, "correlated")
    for method in ("half_vector", "direction"):
        assert abs(float(directional_albedo(0.5, 0.6, "ggx_correlated", method, fresnel=f)) - ref) < 5e-10
    plain = lambda c: fresnel_dielectric(c, 1 / 1.5)  # noqa: E731
    assert abs(float(directional_albedo(0.5, 0.6, "ggx_correlated", fresnel=plain)) - ref) > 1e-3


def test_grazing_and_normal_incidence():
    """mu = 0 and mu = 1 exactly (s_o = 0: the kink is a circle about n, a tau edge alone), and mu -> 0
    continuously."""
    eta = 1 / 1.33
    f = dielectric_factor(eta)
    for mu, alpha, smith in ((0.0, 0.3, "correlated"), (0.0, 0.05, "separable"), (1.0, 0.3, "correlated")):
        ref = quadpack_albedo(mu, alpha, eta, smith)
        for method in ("half_vector", "direction"):
            assert abs(float(directional_albedo(mu, alpha, f"ggx_{smith}", method, fresnel=f)) - ref) < 5e-10
    e = directional_albedo(np.array([0.0, 1e-12, 1e-9, 1e-6]), 0.3, "ggx_correlated", fresnel=f)
    assert np.all(np.abs(e[1:] - e[0]) < 1e-5)


def test_small_alpha_tends_to_the_mirror():
    """alpha -> 0: E_F -> F(mu) E (the mirror, alpha = 0, gives F(mu)): off by O(alpha) away from the kink and by
    O(sqrt(alpha)) at mu = c_k, where F's square root is sampled over an O(alpha) spread of w_o . h."""
    f = dielectric_factor(1 / 1.5)
    c_k = f.kinks[0]
    mu = np.array([0.0, 0.3, c_k - 0.05, c_k + 0.05, 1.0])
    at_kink = []
    for alpha in (1e-4, 1e-6):
        e_f = directional_albedo(mu, alpha, "ggx_correlated", fresnel=f)
        e = directional_albedo(mu, alpha, "ggx_correlated")
        assert np.all(np.abs(e_f - f(mu) * e) <= alpha), alpha
        at_kink.append(abs(float(directional_albedo(c_k, alpha, "ggx_correlated", fresnel=f)) - 1.0))
        np.testing.assert_allclose(
            directional_albedo(mu, alpha, "ggx_correlated", "direction", fresnel=f), e_f, rtol=0, atol=1e-9
        )
    assert at_kink[0] < 5 * math.sqrt(1e-4) and at_kink[1] < 5 * math.sqrt(1e-6) and at_kink[1] < at_kink[0] / 5
    np.testing.assert_array_equal(directional_albedo(mu, 0.0, "ggx_correlated", fresnel=f), f(mu))


def test_eta_tending_to_one_from_below():
    """eta -> 1-: the kink goes to grazing (c_k ~ sqrt(2 (1 - eta))) and F -> 0 elsewhere, so E -> 0 as the
    measure of the facets with w_o . h < c_k, ~ c_k^2: E / (1 - eta) settles; the routes agree all the way."""
    ratios = []
    for eta in (1 - 1e-4, 1 - 1e-6, 1 - 1e-9):
        f = dielectric_factor(eta)
        e = directional_albedo([0.0, 0.5], 0.3, "ggx_correlated", fresnel=f)
        d = directional_albedo([0.0, 0.5], 0.3, "ggx_correlated", "direction", fresnel=f)
        np.testing.assert_allclose(e, d, rtol=1e-8, atol=1e-15)
        ratios.append(e[0] / (1 - eta))
    assert abs(ratios[2] / ratios[1] - 1) < 1e-3 < abs(ratios[0] / ratios[1] - 1)
    ref = quadpack_albedo(0.0, 0.3, 1 - 1e-6, "correlated")
    assert abs(float(directional_albedo(0.0, 0.3, "ggx_correlated", fresnel=dielectric_factor(1 - 1e-6))) - ref) < 1e-12


@settings(max_examples=12, deadline=None)
@given(
    eta=st.floats(0.3, 0.999),
    alpha=st.floats(0.01, 1.0),
    mu=st.floats(0.0, 1.0),
    smith=st.sampled_from(("separable", "correlated")),
)
def test_routes_agree_with_any_kink(eta, alpha, mu, smith):
    f = dielectric_factor(eta)
    a = float(directional_albedo(mu, alpha, f"ggx_{smith}", fresnel=f))
    b = float(directional_albedo(mu, alpha, f"ggx_{smith}", "direction", fresnel=f))
    assert abs(a - b) < 1e-9 and 0.0 <= a <= 1.0


def test_visible_fresnel_follows_the_kink():
    """R(mu_o) = int D_o F dw_m against QUADPACK about w_o (a plain function missed it by up to 6e-3)."""
    for eta, alpha, mu in ((1 / 1.5, 0.6, 0.5), (0.9, 0.05, 0.02), (1 / 1.33, 1.0, 1.0), (0.99, 0.3, 0.0)):
        ref = quadpack_visible(mu, alpha, eta)
        assert abs(float(visible_fresnel(mu, alpha, dielectric_factor(eta))) - ref) < 1e-10, (eta, alpha, mu)


def test_fresnel_factors_carry_their_kinks():
    """dielectric_factor and conductor_factor evaluate the exact Fresnel functions and name the cosine where
    t0 = eta^2 - k^2 - (1 - c^2) = 0 (the critical angle for k = 0, eta < 1), none when it is outside (0, 1);
    average_fresnel takes the kinks as panel edges (the same as the functions that pass them explicitly)."""
    c = np.linspace(0, 1, 11)
    f = dielectric_factor(0.6)
    np.testing.assert_array_equal(f(c), fresnel_dielectric(c, 0.6))
    assert f.kinks == (pytest.approx(0.8, abs=1e-15),)
    assert dielectric_factor(1.5).kinks == () and dielectric_factor(1.0).kinks == ()
    g = conductor_factor(0.5, 0.1)
    np.testing.assert_array_equal(g(c), fresnel_conductor(c, 0.5, 0.1))
    assert g.kinks == (pytest.approx(math.sqrt(1 - 0.25 + 0.01), abs=1e-15),)
    assert conductor_factor(0.21, 3.272).kinks == ()
    assert average_fresnel(f) == float(average_fresnel_dielectric(0.6))
    assert average_fresnel(g) == float(average_fresnel_conductor(0.5, 0.1))
    assert FresnelFactor(np.cos, (0.0, 0.5, 1.0, 0.5)).kinks == (0.5,)  # the ends are every rule's edges already


@pytest.mark.parametrize(
    "make, error",
    [
        (lambda: FresnelFactor("F"), TypeError),
        (lambda: FresnelFactor(np.cos, 0.5), TypeError),
        (lambda: FresnelFactor(np.cos, (1.5,)), ValueError),
        (lambda: FresnelFactor(np.cos, (math.nan,)), ValueError),
        (lambda: FresnelFactor(np.cos, ("0.5",)), ValueError),
        (lambda: dielectric_factor([0.5, 0.6]), ValueError),
        (lambda: dielectric_factor(0.0), ValueError),
        (lambda: conductor_factor(0.5, -1.0), ValueError),
    ],
)
def test_bad_fresnel_factors_are_refused_in_one_line(make, error):
    with pytest.raises(error) as info:
        make()
    assert "\n" not in str(info.value)
