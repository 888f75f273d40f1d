import numpy as np
import pytest

from fitlab.families.lambert_sphere.exact import h_function, isotropic_characteristic, solve_h
from fitlab.families.lambert_sphere.exact.characteristic import lambert_sphere_characteristic
from fitlab.families.lambert_sphere.exact.hfunction import h_fock

HARD_C = [0.0, 1e-12, 0.3, 0.9, 0.999, 1 - 1e-8, 1 - 1e-12, 1.0]
HARD_MU = np.array([0.0, 1e-12, 1e-6, 1e-3, 0.05, 0.3, 0.5, 0.9, 1.0, 2.0, 10.0, 1e6, np.inf])


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("c", HARD_C)
def test_two_independent_methods_agree(order, c):
    a = h_function(order, HARD_MU, c)
    b = h_function(order, HARD_MU, c, method="fock")
    finite = np.isfinite(a)
    assert np.all(np.isfinite(b) == finite)
    assert not np.any(np.isnan(a)) and not np.any(np.isnan(b))
    np.testing.assert_allclose(a[finite], b[finite], rtol=1e-12, atol=0)


@pytest.mark.parametrize("order", [0, 1, 2])
def test_random_points_agree_to_1e10(order):
    rng = np.random.default_rng(order)
    mu = rng.uniform(0, 1, 200)
    c = 1 - rng.uniform(0, 1, 200) ** 2
    np.testing.assert_allclose(h_function(order, mu, c), h_function(order, mu, c, method="fock"), rtol=1e-12)


def test_endpoints():
    for order in range(3):
        assert np.all(h_function(order, 0.0, [0.0, 0.5, 1.0]) == 1.0)
        np.testing.assert_array_equal(h_function(order, [0.0, 0.5, np.inf], 0.0), 1.0)
    # eq. 32
    c = np.array([0.0, 0.3, 0.9, 0.999])
    np.testing.assert_allclose(h_function(0, np.inf, c), 12 / np.sqrt((c - 16) * (c - 1) * (4 * c + 9)), rtol=1e-15)
    assert h_function(0, np.inf, 1.0) == np.inf
    # H(inf) is also the limit of the finite values
    assert h_function(1, 1e12, 0.8) == pytest.approx(float(h_function(1, np.inf, 0.8)), rel=1e-10)


def test_conservative_growth_is_linear():
    h = h_function(0, [1e6, 2e6], 1.0)
    assert h[1] / h[0] == pytest.approx(2.0, rel=1e-5)


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("c", [0.2, 0.95, 1.0])
def test_zeroth_moment_identity(order, c):
    # int_0^1 Psi H = 1 - sqrt(K(0)): follows from the H-equation, not used by either method
    char = lambert_sphere_characteristic(order, c)
    sol = solve_h(char)
    lhs = sol.weights @ (char(sol.nodes) * sol.h_nodes)
    assert lhs == pytest.approx(1 - np.sqrt(char.k0), abs=1e-14)


def test_h_minus_one_over_mu_matches_difference():
    sol = solve_h(lambert_sphere_characteristic(0, 0.7))
    mu = np.array([1e-3, 0.1, 0.5, 1.0])
    np.testing.assert_allclose(sol.h_minus_one_over_u(mu), (sol(mu) - 1) / mu, rtol=1e-12)


def test_chandrasekhar_isotropic_published_value():
    # Chandrasekhar, Radiative Transfer (1960): conservative isotropic scattering H(1) = 2.90781.
    char = isotropic_characteristic(1.0)
    assert float(solve_h(char)(1.0)) == pytest.approx(2.90781, abs=1e-5)
    assert float(h_fock(char, 1.0)) == pytest.approx(2.90781, abs=1e-5)


@pytest.mark.parametrize("c", [0.3, 0.9, 1.0])
def test_isotropic_moment_identities(c):
    # alpha_0 = 2 (1 - sqrt(1 - c))/c and, at c = 1, alpha_1 = 2/sqrt(3) (Chandrasekhar 1960, ch. V)
    sol = solve_h(isotropic_characteristic(c))
    assert sol.moment(0) == pytest.approx(2 * (1 - np.sqrt(1 - c)) / c, rel=1e-14)
    if c == 1.0:
        assert sol.moment(1) == pytest.approx(2 / np.sqrt(3), rel=1e-13)


def test_broadcasting_and_shapes():
    mu = np.linspace(0, 1, 5)[:, None]
    c = np.array([0.1, 0.5, 1.0])[None, :]
    h = h_function(0, mu, c)
    assert h.shape == (5, 3)
    np.testing.assert_array_equal(h[:, 1], h_function(0, mu[:, 0], 0.5))


def test_float32_input_is_promoted():
    h = h_function(0, np.float32(0.5), np.float32(0.9))
    assert h.dtype == np.float64 and np.isfinite(h)


@pytest.mark.parametrize(
    "args",
    [(0, -0.1, 0.5), (0, np.nan, 0.5), (0, 0.5, 1.01), (0, 0.5, -1e-9), (3, 0.5, 0.5), (0.5, 0.5, 0.5)],
)
def test_bad_inputs_raise(args):
    with pytest.raises(ValueError):
        h_function(*args)


def test_unknown_method_raises():
    with pytest.raises(ValueError, match="method"):
        h_function(0, 0.5, 0.5, method="magic")
