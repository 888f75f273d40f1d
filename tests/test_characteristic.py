import numpy as np
import pytest

from fitlab.families.lambert_sphere.exact import k_function, psi
from fitlab.families.lambert_sphere.exact.characteristic import lambert_sphere_characteristic


def k_printed(order, t, c):
    """Paper eqs. 18-20 as printed (accurate only for t not small)."""
    at = np.arctan(t)
    if order == 0:
        num = (256 * c - 301) * t**3 + (
            (346 - c * (20 * c + 281)) * t**2 - 15 * (c - 1) * (4 * c + 9) + 207 * t**4
        ) * at
        num += 15 * (c - 1) * (4 * c + 9) * t
        return 1 - c * num / (192 * t**5)
    if order == 1:
        num = (40 * c + 282) * t**3 - 3 * (t**2 + 1) * (20 * c + 64 * t**2 + 45) * at + 15 * (4 * c + 9) * t
        return 1 - c * num / (288 * t**5)
    return 1 - 5 * c * (3 * (t**2 + 1) ** 2 * at - t * (5 * t**2 + 3)) / (128 * t**5)


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("c", [0.0, 0.3, 0.9, 1.0])
def test_k_matches_printed_closed_form_where_it_is_accurate(order, c):
    t = np.array([0.7, 1.0, 1.9, 2.1, 5.0, 50.0, 1e3])
    np.testing.assert_allclose(k_function(order, t, c), k_printed(order, t, c), rtol=0, atol=5e-15)


def psi_printed(order, u, c):
    """Psi_m(u) as printed (the forms test_psi_printed_forms checks)."""
    if order == 0:
        return c * (-15 * (c - 1) * (4 * c + 9) * u**4 + (c * (20 * c + 281) - 346) * u**2 + 207) / 384
    if order == 1:
        return -c * (u**2 - 1) * (5 * (4 * c + 9) * u**2 - 64) / 192
    return 15 * c * (u**2 - 1) ** 2 / 256


def k_quadrature(order, t, c, n=40):
    """K_m(t) = 1 - 2 int_0^1 Psi_m(v) / (1 + t^2 v^2) dv by n-point Gauss-Legendre: independent of both
    the closed forms and fitlab's evaluation; accurate to rounding for t <= 1 (the integrand's poles
    v = +-i/t stay at distance >= 1 from [0, 1])."""
    x, w = np.polynomial.legendre.leggauss(n)
    v, w = 0.5 * (x + 1), 0.5 * w
    return 1 - 2 * np.sum(w * psi_printed(order, v, c) / (1 + (t * v) ** 2))


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("c", [0.1, 0.5, 0.9, 1.0])
def test_k_matches_quadrature_at_small_t(order, c):
    for t in (0.0, 1e-12, 1e-8, 1e-4, 1e-3, 0.01, 0.1, 0.5, 1.0):
        assert float(k_function(order, t, c)) == pytest.approx(k_quadrature(order, t, c), rel=1e-13, abs=1e-15), t


def test_small_t_cancellation_is_avoided():
    # docs/model.md, "H-functions": the printed K0(1e-4) at c = 0.5 loses every digit to cancellation; the value, by quadrature
    # of the defining integral, is 0.59201...
    true = k_quadrature(0, 1e-4, 0.5)
    assert true == pytest.approx(0.59201, abs=1e-5)
    assert abs(k_printed(0, 1e-4, 0.5) - true) > 0.3  # the printed form is useless there
    k = k_function(0, 1e-4, 0.5)
    assert k == pytest.approx(true, rel=1e-14)
    # Taylor: K(t) = K(0) + t^2 J(0) + O(t^4); compare with a second-order finite check
    k0 = k_function(0, 0.0, 0.5)
    assert (k - k0) / 1e-8 == pytest.approx((k_function(0, 1e-3, 0.5) - k0) / 1e-6, rel=1e-5)


@pytest.mark.parametrize("order", [0, 1, 2])
def test_k0_equals_one_minus_twice_the_integral_of_psi(order):
    x, w = np.polynomial.legendre.leggauss(20)
    x, w = 0.5 * (x + 1), 0.5 * w
    for c in [0.0, 0.25, 0.75, 1.0]:
        assert k_function(order, 0.0, c) == pytest.approx(1 - 2 * np.dot(w, psi(order, x, c)), abs=1e-15)


def test_k0_is_exactly_zero_at_c_1_and_relatively_accurate_near_it():
    assert k_function(0, 0.0, 1.0) == 0.0
    eps = 1e-12
    # eq. 32: K0(0) = (c - 16)(c - 1)(4c + 9)/144
    c = 1.0 - eps
    exact = (16 - c) * (1 - c) * (4 * c + 9) / 144
    assert k_function(0, 0.0, c) == pytest.approx(exact, rel=1e-14)


def test_k_limits_and_monotone_for_order0():
    t = np.concatenate(([0.0], np.logspace(-12, 12, 200), [np.inf]))
    for c in [0.0, 0.5, 1.0]:
        k = k_function(0, t, c)
        assert np.all(np.isfinite(k))
        assert k[-1] == 1.0
        assert np.all(np.diff(k) >= -1e-15)


def test_psi_printed_forms():
    u = np.linspace(0, 1, 11)
    for c in (0.0, 0.7, 1.0):
        for order in (0, 1, 2):
            np.testing.assert_allclose(psi(order, u, c), psi_printed(order, u, c), atol=1e-15)


@pytest.mark.parametrize(
    "call",
    [
        lambda: psi(3, 0.5, 0.5),
        lambda: psi(0, 0.5, 1.5),
        lambda: psi(0, 0.5, -0.1),
        lambda: psi(0, 0.5, np.nan),
        lambda: k_function(0, -1.0, 0.5),
        lambda: k_function(0, np.nan, 0.5),
        lambda: lambert_sphere_characteristic(1.5, 0.5),
    ],
)
def test_bad_inputs_raise(call):
    with pytest.raises(ValueError):
        call()
