"""The true-phase exact engine: exact/true_phase.py and the phase= API.

Fast checks run by default; the full-degree agreement of the two methods over the whole c list
is a benchmark (pytest -m benchmark): it solves ~50 Fourier orders per c by doubling.
"""

import numpy as np
import pytest
from scipy import integrate
from scipy.special import eval_legendre

from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.exact import true_phase as tp
from fitlab.families.lambert_sphere.exact.albedo import single_scattering_albedo

GRID = np.array([0.0, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.8, 1.0])
MI, MO = (a.ravel() for a in np.meshgrid(GRID, GRID, indexing="ij"))
OFF_POLE = (MI + MO) > 0


def test_legendre_moments_closed_form_and_quadrature():
    a = tp.legendre_moments(40)
    np.testing.assert_allclose(a[:7], exact.LEGENDRE_A, rtol=0, atol=1e-15)
    assert a[8] == pytest.approx(17.0 / 16384.0, rel=1e-14)
    assert np.all(a[3::2] == 0.0)
    for k in range(0, 41, 1):
        num, _ = integrate.quad(
            lambda u, k=k: exact.phase_function(u) * eval_legendre(k, u), -1, 1, limit=400, epsabs=1e-15, epsrel=1e-13
        )
        assert 2 * np.pi * (2 * k + 1) * num == pytest.approx(a[k], rel=1e-9, abs=1e-13), k
    # A_k ~ (16/pi) k^-4 for even k
    k = np.arange(20, 41, 2)
    np.testing.assert_allclose(a[k] * k**4, 16 / np.pi, rtol=0.25)
    # the series sums back to p(u)
    u = np.linspace(-1, 1, 7)
    b = tp.legendre_moments(2000)
    series = np.polynomial.legendre.legval(u, b) / (4 * np.pi)
    np.testing.assert_allclose(series, exact.phase_function(u), atol=2e-10)


@pytest.mark.parametrize("method, c", [("newton", 0.5), ("newton", 1.0), ("doubling", 1.0)])
def test_three_term_kernel_reproduces_h_function_engine(method, c):
    ref = exact.multiple_scattering_modes(MI[OFF_POLE], MO[OFF_POLE], c, phase="three_term")
    got = tp.multiple_scattering_orders(MI[OFF_POLE], MO[OFF_POLE], c, method=method, phase="three_term")
    assert len(got) == 3
    for g, r in zip(got, ref):
        np.testing.assert_array_less(np.abs(g - r), 1e-12 * np.abs(r) + 1e-300)
    # the whole three-term BRDF through the API
    phi = 2.0
    f3 = exact.brdf(MI[OFF_POLE], MO[OFF_POLE], phi, c, phase="three_term")
    ss = c * exact.three_term_phase_function(-(MI * MO + np.sqrt((1 - MI**2) * (1 - MO**2)) * np.cos(phi)))[OFF_POLE]
    mine = ss / (MI + MO)[OFF_POLE] + sum(g * np.cos(m * phi) for m, g in enumerate(got))
    np.testing.assert_allclose(mine, f3, rtol=1e-12)


@pytest.mark.parametrize("c", [1e-6, 0.1, 0.5, 0.9, 0.99, 1.0])
def test_two_methods_agree_reduced_degree(c):
    """Newton and doubling, on different rules, at degree 4 (orders 0, 1), rules down to 1e-8: the check
    of the methods themselves; the full degree and default rules are the benchmark below."""
    kw = dict(degree=4, orders=2, smallest=1e-8)
    a = tp.multiple_scattering_orders(MI[OFF_POLE], MO[OFF_POLE], c, method="newton", **kw)
    b = tp.multiple_scattering_orders(MI[OFF_POLE], MO[OFF_POLE], c, method="doubling", **kw)
    f = exact.brdf(MI[OFF_POLE], MO[OFF_POLE], np.pi, c, phase="mixed")
    for x, y in zip(a, b):
        np.testing.assert_array_less(np.abs(x - y), 1e-10 * f)


@pytest.mark.benchmark
@pytest.mark.parametrize("c", [1e-6, 0.1, 0.5, 0.9, 0.99, 1.0])
def test_two_methods_agree_full_degree(c):
    m = tp.needed_orders(c)
    a = tp.multiple_scattering_orders(MI[OFF_POLE], MO[OFF_POLE], c, method="newton", orders=m)
    b = tp.multiple_scattering_orders(MI[OFF_POLE], MO[OFF_POLE], c, method="doubling", orders=m)
    f = exact.brdf(MI[OFF_POLE], MO[OFF_POLE], np.pi, c, phase="mixed")
    for x, y in zip(a, b):
        np.testing.assert_array_less(np.abs(x - y), 1e-10 * f)


def test_nystrom_reproduces_nodes():
    """At node pairs the Nystrom step returns the nodes' solution (away from grazing node pairs, where
    R - single at the nodes cancels ~1/(mu_i + mu_j) and the Nystrom value is the better one)."""
    sol = tp.solve_order(1, 0.9, degree=8)
    idx = np.arange(sol.nodes.size)[sol.nodes > 1e-3][::7]
    v = sol.nodes[idx]
    got = tp.multiple_scattering_orders(v[:, None], v[None, :], 0.9, degree=8, orders=2)[1]
    want = -2 / (4 * np.pi) * (sol.r - sol.single)[np.ix_(idx, idx)]
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("mu_i", [0.0, 1e-6, 0.01, 0.5, 1.0])
def test_albedo_conserved_at_c_one(mu_i):
    a = exact.albedo(mu_i, 1.0, phase="true")
    assert float(a) == pytest.approx(1.0, abs=1e-12)


def test_albedo_below_one_and_consistent():
    a = exact.albedo(np.array([0.0, 0.3, 1.0]), 0.9, phase="true")
    assert np.all(a < 1.0)
    # the multiple-scattering albedo is the azimuthal mean: compare the mixed model's to the three-term one's
    a_mixed = exact.albedo(np.array([0.3]), 0.9, phase="mixed")
    assert abs(a[1] - a_mixed[0]) < 1e-3


def test_reciprocity_and_phi_symmetry():
    """The construction is symmetric at every degree: checked at degree 16 (the full degree below)."""
    c = 1.0
    mi, mo = np.array([0.0, 1e-6, 0.05, 0.3, 0.9]), np.array([0.7, 0.2, 0.6, 0.01, 1.0])
    phi = np.array([0.0, 1.0, -1.0, np.pi])[:, None]
    a, b = np.concatenate((mi, mo)), np.concatenate((mo, mi))
    u = -(a * b + np.sqrt((1 - a * a) * (1 - b * b)) * np.cos(phi))
    f = c * exact.phase_function(u) / (a + b) + tp.multiple_scattering_sum(a, b, phi, c, degree=16, orders=8)
    np.testing.assert_allclose(f[:, :5], f[:, 5:], rtol=1e-13)
    np.testing.assert_allclose(f[1], f[2], rtol=1e-14)


@pytest.mark.parametrize("c", [0.03, 1.0])
def test_rows_interpolated_at_many_cosines_agree_with_rows_at_each(c):
    """Many distinct cosines take the Nystrom rows interpolated (exact/true_phase.py, interpolation_panels): at
    random pairs (cosines down to 1e-12, near 1, the panels' edges, 0 and 1) every order is within 1e-12 of the
    BRDF of the rows computed at each cosine (pairs in chunks with fewer distinct cosines), and reciprocal."""
    n, chunk = 1000, 250
    rng = np.random.default_rng(7)
    edges = np.array([p[0] for p in tp.interpolation_panels(tp.DEGREE, 1e-10)] + [1.0])
    pool = np.concatenate(
        (rng.uniform(0, 1, n), 10 ** rng.uniform(-12, 0, n // 4), 1 - 10 ** rng.uniform(-9, -1, n // 4), edges)
    )
    mi, mo = rng.permutation(pool)[:n], rng.permutation(pool)[:n]
    size = sum(p[2].size for p in tp.interpolation_panels(tp.DEGREE, 1e-10))
    assert np.unique(np.concatenate((mi, mo))).size > size > 2 * chunk
    both = tp.multiple_scattering_orders(np.concatenate((mi, mo)), np.concatenate((mo, mi)), c)
    parts = [
        tp.multiple_scattering_orders(mi[k : k + chunk], mo[k : k + chunk], c, orders=len(both))
        for k in range(0, n, chunk)
    ]
    direct = [np.concatenate(p) for p in zip(*parts)]
    phi = np.linspace(0, np.pi, n)
    u = -(mi * mo + np.sqrt((1 - mi**2) * (1 - mo**2)) * np.cos(phi))
    f = c * exact.phase_function(u) / (mi + mo) + sum(d * np.cos(m * phi) for m, d in enumerate(direct))
    for a, b in zip(both, direct):
        assert np.max(np.abs(a[:n] - b) / f) < 1e-12
        assert np.max(np.abs(a[:n] - a[n:]) / f) < 1e-12


def test_orders_left_out_are_below_the_tolerance_of_the_brdf():
    """needed_orders stops at ORDER_TOLERANCE = 1e-12 of order 0: the next ten orders sum to < 1e-11 of the
    BRDF at every phi (mu down to 1e-6; at c = 1, where multiple scattering is largest)."""
    c = 1.0
    mi, mo = np.array([1e-6, 1e-3, 0.01, 0.2, 0.5, 1.0, 0.05]), np.array([1e-6, 0.7, 0.01, 0.9, 0.5, 1.0, 0.3])
    k = tp.needed_orders(c)
    tail = tp.multiple_scattering_orders(mi, mo, c, orders=k + 10)[k:]
    phi = np.linspace(0, np.pi, 7)[:, None]
    f = exact.brdf(mi, mo, phi, c, phase="true")
    assert np.max(np.abs(sum(t * np.cos((k + j) * phi) for j, t in enumerate(tail))) / f) < 1e-11


def test_small_c_limit_is_single_scattering():
    mi, mo, phi = np.array([0.01, 0.3, 1.0]), np.array([0.5, 0.02, 1.0]), np.array([0.3, 2.0, 3.0])
    for c in (1e-3, 1e-6):
        ms = tp.multiple_scattering_sum(mi, mo, phi, c, degree=16, orders=6)
        u = -(mi * mo + np.sqrt((1 - mi**2) * (1 - mo**2)) * np.cos(phi))
        ss = c * exact.phase_function(u) / (mi + mo)
        # multiple scattering is O(c^2): f/c -> single scattering / c
        assert np.all(np.abs(ms) / ss < 2 * c)
        assert np.all(ms > 0)
    assert np.all(tp.multiple_scattering_sum(mi, mo, phi, 0.0, degree=16, orders=6) == 0.0)


@pytest.fixture
def degree_32(monkeypatch):
    """The API at degree 32 (a few 1e-7 of the BRDF at grazing: docs/derivation.md, "The true phase
    function"): the default degree's 51 orders take too long for the quick tests."""
    monkeypatch.setattr(tp, "DEGREE", 32)


def test_grazing_values_and_gap(degree_32):
    c = 1.0
    f = exact.brdf(np.array([0.0, 0.0, 0.0, 1e-9]), np.array([0.0, 1e-8, 0.5, 0.5]), 1.0, c, phase="true")
    assert f[0] == np.inf
    assert np.all(np.isfinite(f[1:]))
    # mu_i = 0 is the limit of small mu_i
    assert f[3] == pytest.approx(f[2], rel=1e-7)
    # The gap, same solve. An independent solver: at c = 1, mu_i = mu_o = 0.01, phi = pi the true
    # BRDF is 0.44041, fitlab's mixed 0.43963 (2.0e-3 relative; five digits printed).
    t = float(exact.brdf(0.01, 0.01, np.pi, 1.0, phase="true"))
    m = float(exact.brdf(0.01, 0.01, np.pi, 1.0, phase="mixed"))
    assert t == pytest.approx(0.44041, abs=6e-6)
    assert m == pytest.approx(0.43963, abs=6e-6)
    assert (t - m) / t == pytest.approx(1.8e-3, abs=3e-4)


def test_phase_api():
    assert exact.DEFAULT_PHASE == "true"
    args = (np.array([0.3, 0.6]), np.array([0.5, 0.2]), 1.0, 0.7)
    np.testing.assert_array_equal(exact.brdf(*args), exact.brdf(*args, phase="true"))
    for bad in ("truth", "3term", ""):
        with pytest.raises(ValueError, match="phase must be one of"):
            exact.brdf(*args, phase=bad)
        with pytest.raises(ValueError, match="phase must be one of"):
            exact.albedo(0.5, 0.5, phase=bad)
        with pytest.raises(ValueError, match="phase must be one of"):
            exact.multiple_scattering_modes(0.5, 0.5, 0.5, phase=bad)
    with pytest.raises(ValueError, match="infinitely many"):
        exact.brdf_modes(0.5, 0.5, 0.5, phase="true")
    # the old model= (whose "true" meant today's "mixed") is gone: one name for one physics
    with pytest.raises(TypeError, match="model"):
        exact.albedo(0.4, 0.8, model="true")
    # mixed and three_term share the multiple scattering
    for x, y in zip(
        exact.multiple_scattering_modes(0.3, 0.4, 0.6, phase="mixed"),
        exact.multiple_scattering_modes(0.3, 0.4, 0.6, phase="three_term"),
    ):
        assert x == y


def test_spherical_albedo_true_at_c_one():
    assert float(exact.spherical_albedo(1.0, phase="true")) == pytest.approx(1.0, abs=1e-12)
    assert float(exact.spherical_albedo(0.0, phase="true")) == 0.0


def test_single_scattering_albedo_of_truncation():
    """Energy at c = 1 rests on the degree-L single scattering having the true albedo: check it."""
    v, w = tp.node_rule(tp.DEGREE)
    a = tp.legendre_moments(tp.DEGREE)
    for mu_i in (0.01, 0.5, 1.0):
        q = tp.assoc_normalised(0, tp.DEGREE, v)
        qi = tp.assoc_normalised(0, tp.DEGREE, np.array([-mu_i]))[:, 0]
        a_l = 0.5 * np.sum(a * qi * (q @ (w * v / (mu_i + v))))
        assert a_l == pytest.approx(single_scattering_albedo(mu_i), abs=1e-13)


def test_true_brdf_validation_set():
    """The audit's true-BRDF set: the engine's values at one of its albedos, energy at c = 0 and 1, and the
    same points as the mixed set, which it stays within the measured gap of (2.0e-3 away from the pole)."""
    from fitlab.families.lambert_sphere.targets import datasets as d

    ds = d.brdf_validation("true")
    mixed = d.brdf_validation("mixed")
    c = ds.inputs["c"]
    for k in ("mu_i", "mu_o", "phi", "c"):
        np.testing.assert_array_equal(ds.inputs[k], mixed.inputs[k])
    assert np.all(ds.inputs["kd"][c == 1.0] == pytest.approx(1.0, abs=1e-12))
    assert np.all(ds.inputs["kd"][c == 0.0] == 0.0) and np.all(ds.y[c == 0.0] == 0.0)
    cv = float(np.unique(c)[len(np.unique(c)) // 2])
    sel = c == cv
    want = exact.brdf(ds.inputs["mu_i"][sel], ds.inputs["mu_o"][sel], ds.inputs["phi"][sel], cv, phase="true")
    np.testing.assert_allclose(ds.y[sel], want, rtol=1e-13)
    away = (ds.inputs["mu_i"] >= 1e-3) & (ds.inputs["mu_o"] >= 1e-3) & (c > 0.0)
    gap = np.abs(mixed.y[away] / ds.y[away] - 1.0)
    assert 1e-4 < gap.max() < 2.1e-3


@pytest.mark.parametrize("c", [1e-300, 1e-200, 1e-155])
def test_below_double_the_multiple_scattering_is_zero_and_the_brdf_is_single_scattering(c):
    """Where c^2 is below double's smallest normal number (c < 1.5e-154) the multiple scattering, O(c^2), is 0 or
    subnormal: one order, no solve (at c = 1e-300 the solve ran on subnormal numbers and the order count
    kept all 96 orders: 80 s); the BRDF is c p(u)/(mu_i + mu_o) to the last bit, grazing included."""
    assert tp.needed_orders(c) == 1
    mu_i, mu_o = (a.ravel() for a in np.meshgrid([0.0, 1e-9, 1e-3, 0.5, 1.0], [1e-6, 0.2, 1.0], indexing="ij"))
    phi = np.linspace(0.0, np.pi, mu_i.size)
    u = -(mu_i * mu_o + np.sqrt((1.0 - mu_i**2) * (1.0 - mu_o**2)) * np.cos(phi))
    single = c * exact.phase_function(u) / (mu_i + mu_o)
    assert np.all(np.abs(tp.multiple_scattering_sum(mu_i, mu_o, phi, c)) < np.finfo(float).tiny)
    np.testing.assert_allclose(exact.brdf(mu_i, mu_o, phi, c), single, rtol=4 * np.finfo(float).eps, atol=0.0)
