"""fitlab.physics: each formula is one function that numpy, JAX (jit, float64 and float32, gradients) and sympy (forms
and printed code) evaluate alike, at the domain's edges too; the identities between the formulas hold."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from fitlab.core import float64
from fitlab.forms.symbolic import lambdify_numpy
from fitlab.physics import NUMPY, jax_namespace, namespace, sources, sympy_namespace
from fitlab.physics import fresnel as F
from fitlab.physics import lambert_sphere as L
from fitlab.physics import microfacet as M
from fitlab.physics import oren_nayar as O

RNG = np.random.default_rng(61)
N = 2000
#: cosines with the edges 0 and 1
C = np.concatenate(([0.0, 1e-9, 0.5, 1.0 - 1e-9, 1.0], RNG.uniform(0, 1, N)))


#: name -> (function, arguments as float64 arrays of equal length): every formula of fitlab.physics on its domain
CASES = {
    "schlick": (F.fresnel_schlick, (C, RNG.uniform(0, 1, C.size))),
    "schlick_generalised": (
        F.schlick_generalised,
        (C, RNG.uniform(0, 1, C.size), RNG.uniform(0.5, 1, C.size), RNG.uniform(0.1, 1, C.size)),
    ),
    "lazanyi": (F.lazanyi, (C, RNG.uniform(0, 1, C.size), RNG.uniform(0, 1, C.size), RNG.uniform(1, 8, C.size))),
    "f82_tint": (F.f82_tint, (C, RNG.uniform(0, 1, C.size), RNG.uniform(0.5, 1, C.size))),
    "conductor": (F.fresnel_conductor, (C, RNG.uniform(0.05, 4, C.size), RNG.uniform(0, 6, C.size))),
    "conductor_k0": (F.fresnel_conductor, (C, RNG.uniform(0.3, 3, C.size), np.zeros(C.size))),
    "dielectric": (F.fresnel_dielectric, (C, RNG.uniform(0.3, 3, C.size))),
    "ggx_ndf": (M.ggx_ndf, (1 - C * C, C * C, RNG.uniform(1e-4, 1, C.size))),
    "beckmann_ndf": (M.beckmann_ndf, (1 - C * C, np.maximum(C * C, 0.01), RNG.uniform(0.01, 1, C.size))),
    "ggx_lambda": (M.ggx_lambda, (np.maximum(C, 1e-6), RNG.uniform(0, 1, C.size))),
    "beckmann_lambda": (M.beckmann_lambda, (np.maximum(C, 1e-6), RNG.uniform(0.01, 1, C.size))),
    "ggx_g1": (M.ggx_g1, (C, RNG.uniform(0, 1, C.size))),
    "oren_nayar_a": (
        lambda s, a: O.oren_nayar_coefficients(s, a)[0],
        (RNG.uniform(0, 1.6, C.size), np.full(C.size, 0.33)),
    ),
    "oren_nayar_b": (
        lambda s, a: O.oren_nayar_coefficients(s, a)[1],
        (RNG.uniform(0, 1.6, C.size), np.full(C.size, 0.57)),
    ),
    "phase": (L.phase_function, (2 * C - 1,)),
    "phase_of_angle": (L.phase_function_of_angle, (np.pi * C,)),
    "phase_forward": (L.phase_function_forward, (C,)),
    "three_term": (L.three_term_phase_function, (2 * C - 1,)),
}


def _same_to_rounding(got, want):
    """Equal to 16 ulps of each value, or of the function's largest value on the case: the back ends round the same
    operations alike but for libm's (or XLA's) last bit and XLA's fused multiply-adds, which a cancellation in the
    formula (the phase function and 1 - c^2 near 1, Lambda near the normal, Beckmann's Lambda at large a) turns into
    larger relative differences of small values."""
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    scale = np.max(np.abs(want[np.isfinite(want)]))
    np.testing.assert_allclose(got, want, rtol=16 * np.finfo(float).eps, atol=16 * np.finfo(float).eps * scale)


@pytest.mark.parametrize("name", sorted(CASES))
@float64
def test_jax_jit_evaluates_the_numpy_formula(name):
    import jax
    import jax.numpy as jnp

    f, args = CASES[name]
    want = f(*args)
    got = np.asarray(jax.jit(f)(*(jnp.asarray(a) for a in args)))
    _same_to_rounding(got, want)


@pytest.mark.parametrize("name", sorted(CASES))
@float64
def test_float32_follows_float64(name):
    """numpy and JAX in float32 stay float32 and within a few thousand float32 ulps of float64 (the worst: the
    cancellation the inputs' own float32 rounding carries into 1 - c near c = 1 and into (eta - 1) near eta = 1)."""
    import jax.numpy as jnp

    f, args = CASES[name]
    want = np.asarray(f(*args))
    for xp in (np, jnp):
        got = np.asarray(f(*(xp.asarray(a, dtype=np.float32) for a in args)))
        assert got.dtype == np.float32, (name, xp.__name__)
        scale = np.maximum(np.abs(want), 1.0 if name in ("ggx_ndf", "beckmann_ndf", "ggx_lambda") else 1e-3)
        err = np.abs(got.astype(float) - want) / scale
        finite = np.isfinite(want)
        assert np.all(np.isfinite(got[finite])), (name, xp.__name__)
        assert np.max(err[finite]) < 1e-3, (name, xp.__name__, float(np.max(err[finite])))


@pytest.mark.parametrize("name", sorted(CASES))
def test_sympy_expression_evaluates_the_formula(name):
    """The formula called on sympy symbols is an expression whose value (sympy's numpy printer) is the numpy one."""
    f, args = CASES[name]
    symbols = sp.symbols(f"x0:{len(args)}", real=True)
    expr = f(*symbols)
    assert isinstance(expr, sp.Expr)
    # erfc (Beckmann's Lambda) is no function of the fit files' language: sympy's own numpy printer with scipy
    fn = sp.lambdify(symbols, expr, ["scipy", "numpy"]) if expr.has(sp.erfc) else lambdify_numpy(symbols, expr)
    got = np.asarray(fn(*args), dtype=float)
    want = np.asarray(f(*args))
    interior = np.isfinite(want)
    if name in ("conductor", "conductor_k0", "dielectric"):  # the guarded ratios' limits are sympy's 0 / 0
        interior &= args[0] > 0
    # sympy rearranges the operations (and writes sqrt(1 - u^2) clamped): equal to rounding of the function's scale
    scale = np.max(np.abs(want[interior]))
    np.testing.assert_allclose(got[interior], want[interior], rtol=1e-12, atol=64 * np.finfo(float).eps * scale)


@float64
def test_gradients_of_the_fitted_formulas_are_finite():
    """A fit differentiates the Fresnel forms through the conductor (Gulbrandsen) and Schlick's family: JAX's
    gradients are finite on the whole domain, edges and the conductor's bend (t0 = 0) included, and agree with
    finite differences."""
    import jax
    import jax.numpy as jnp

    c = jnp.asarray(np.concatenate(([0.0, 1.0, 0.3], np.linspace(0.01, 0.99, 50))))

    def gulbrandsen(r, g):
        n, k = F.gulbrandsen_index(r, g)
        return jnp.sum(F.fresnel_conductor(c, n, k))

    for r, g in ((0.9, 0.5), (0.3, 0.0), (0.5, 1.0), (0.95, 0.999)):
        grad = jax.grad(gulbrandsen, argnums=(0, 1))(r, g)
        assert all(np.isfinite(float(v)) for v in grad)
        h = 1e-6
        fd = (float(gulbrandsen(r + h, g)) - float(gulbrandsen(r - h, g))) / (2 * h)
        assert float(grad[0]) == pytest.approx(fd, rel=1e-5, abs=1e-7)
    # the bend of a conductor: t0 = eta^2 - k^2 - (1 - c^2) = 0 at c = 0.6
    eta = float(np.sqrt(1 - 0.36))
    grad = jax.grad(lambda e, kk: F.fresnel_conductor(jnp.asarray(0.6), e, kk), argnums=(0, 1))(eta, 0.1)
    assert all(np.isfinite(float(v)) for v in grad)
    for f, args in (
        (F.lazanyi, (0.3, 0.5, 0.1, 6.0)),
        (F.f82_tint, (0.3, 0.5, 0.9)),
        (F.schlick_generalised, (0.3, 0.5, 1.0, 0.2)),
    ):
        grad = jax.grad(lambda *a, f=f: f(jnp.asarray(a[0]), *a[1:]), argnums=tuple(range(1, len(args))))(*args)
        assert all(np.isfinite(float(v)) for v in grad)


def test_the_namespace_follows_the_arguments():
    import jax.numpy as jnp

    assert namespace(0.5, np.ones(2)) is NUMPY
    assert namespace(np.float32(1.0)) is NUMPY
    assert namespace(jnp.ones(2), 0.5) is jax_namespace()
    assert namespace(sp.Symbol("x"), 0.5) is sympy_namespace()
    assert sympy_namespace().where(True, 1, 2) == 1
    assert isinstance(sympy_namespace().where(sp.Symbol("x") > 0, 1, 2), sp.Piecewise)
    with pytest.raises(ValueError, match="no physics module"):
        sources("optics")
    assert {p.name for p in sources("fresnel")} == {"_namespace.py", "fresnel.py"}


# -- identities between the formulas ------------------------------------------------------------------------
@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.05, 5.0), st.floats(0.0, 8.0))
def test_conductor_is_a_reflectance_with_its_limits(c, eta, k):
    f = float(F.fresnel_conductor(c, eta, k))
    assert 0.0 <= f <= 1.0 + 1e-15
    if c == 1.0:
        assert f == pytest.approx(float(F.normal_reflectance(eta, k)), rel=1e-13, abs=1e-16)
    if c == 0.0 and not (eta == 1.0 and k == 0.0):
        assert f == pytest.approx(1.0, abs=1e-15)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.2, 4.0))
def test_conductor_without_absorption_is_the_dielectric(c, eta):
    assert float(F.fresnel_conductor(c, eta, 0.0)) == pytest.approx(
        float(F.fresnel_dielectric(c, eta)), rel=1e-12, abs=1e-15
    )


def test_conductor_against_the_complex_amplitudes_in_high_precision():
    """The real form without cancellation against r_s, r_p of a complex index in 50-digit arithmetic, where the
    naive real forms lose digits: eta near 1 at small k, and the bend t0 = 0."""
    import mpmath as mp

    mp.mp.dps = 50

    def exact(c, eta, k):
        c, e = mp.mpf(c), mp.mpc(eta, k)
        w = mp.sqrt(e * e - (1 - c * c))
        rs, rp = (c - w) / (c + w), (e * e * c - w) / (e * e * c + w)
        return float((abs(rs) ** 2 + abs(rp) ** 2) / 2)

    rng = np.random.default_rng(5)
    cases = [(rng.uniform(0, 1), rng.uniform(0.1, 4), rng.uniform(0, 6)) for _ in range(150)]
    cases += [(rng.uniform(0, 1), 1 + rng.normal(0, 1e-3), abs(rng.normal(0, 1e-3))) for _ in range(50)]
    for _ in range(50):
        c, k = rng.uniform(0.05, 1), rng.uniform(0, 0.5)
        cases.append((c, float(np.sqrt(1 - c * c + k * k)), k))  # t0 = 0
    for c, eta, k in cases:
        want = exact(c, eta, k)
        got = float(F.fresnel_conductor(c, eta, k))
        # relative to F, but for the cancellation of c - a that the data itself carries (eta - 1 ~ 1e-3)
        assert abs(got - want) <= 1e-14 * want + 1e-18, (c, eta, k, got, want)


@settings(max_examples=100, deadline=None)
@given(st.one_of(st.just(0.0), st.floats(1e-100, 1.0)), st.floats(0.01, 1.0))
def test_smith_identities(mu, alpha):
    a2 = alpha * alpha
    lam = float(M.ggx_lambda(mu, a2))
    g1 = float(M.ggx_g1(mu, a2))
    assert g1 == pytest.approx(1.0 / (1.0 + lam), rel=1e-14, abs=1e-300)
    assert float(M.ggx_g2(mu, mu, a2, "correlated")) == pytest.approx(1.0 / (1.0 + 2 * lam), rel=1e-13, abs=1e-300)
    assert float(M.ggx_g2(mu, mu, a2, "separable")) == pytest.approx(g1 * g1, rel=1e-15, abs=1e-300)
    if mu > 0:
        t2 = a2 * (1 - mu * mu) / (mu * mu)
        assert lam == pytest.approx((np.sqrt(1 + t2) - 1) / 2, rel=1e-9, abs=1e-16)


def test_anisotropic_functions_reduce_to_the_isotropic_ones():
    x, y, z = RNG.normal(size=(3, 500))
    n = np.sqrt(x * x + y * y + z * z)
    x, y, z = x / n, y / n, np.abs(z) / n
    for alpha in (0.05, 0.4, 1.0):
        np.testing.assert_allclose(
            M.smith_lambda(x, y, z, alpha, alpha, "ggx"), M.ggx_lambda(z, alpha * alpha, x * x + y * y), rtol=1e-14
        )
        np.testing.assert_allclose(
            M.ndf(x, y, z, alpha, alpha, "ggx"), M.ggx_ndf(x * x + y * y, z * z, alpha * alpha), rtol=1e-13
        )
    # Beckmann's Lambda against its closed form in 40-digit arithmetic
    import mpmath as mp

    for mu, a2 in ((0.3, 0.25), (0.8, 0.01), (0.05, 1.0)):
        a = mu / np.sqrt(a2 * (1 - mu * mu))
        want = float((mp.exp(-a * a) / (a * mp.sqrt(mp.pi)) - mp.erfc(a)) / 2)
        assert float(M.beckmann_lambda(mu, a2)) == pytest.approx(want, rel=1e-10, abs=1e-300)


@pytest.mark.parametrize("distribution", ["ggx", "beckmann"])
def test_ndf_is_normalised(distribution):
    """int D(m) m_z dw = 1 over the hemisphere, anisotropic too (Gauss-Legendre in theta and phi)."""
    t, wt = np.polynomial.legendre.leggauss(400)
    theta = (t + 1) * np.pi / 4
    p, wp = np.polynomial.legendre.leggauss(64)
    phi = (p + 1) * np.pi
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    mx, my, mz = np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)
    for ax, ay in ((0.3, 0.3), (0.2, 0.6)):
        d = M.ndf(mx, my, mz, ax, ay, distribution)
        total = np.einsum("i,j,ij->", wt * np.pi / 4, wp * np.pi, d * mz * np.sin(th))
        assert total == pytest.approx(1.0, rel=1e-6)


def test_phase_function_forms_agree():
    """p of u, of the angle and of v = (1 - u) / 2 are one function: to 1e-16 absolute everywhere, and the v form
    keeps forward scattering's relative digits where the u form cannot."""
    u = np.concatenate(([-1.0, 1.0, 0.0], RNG.uniform(-1, 1, 5000)))
    p = L.phase_function(u)
    np.testing.assert_allclose(L.phase_function_of_angle(np.arccos(-u)), p, rtol=0, atol=2e-16)
    np.testing.assert_allclose(L.phase_function_forward((1 - u) / 2), p, rtol=0, atol=2e-16)
    # forward scattering, v small (p ~ 2 x^3 / (9 pi^2), x = 2 asin(sqrt(v))): relative digits, against 40-digit sums
    import mpmath as mp

    mp.mp.dps = 40
    v = np.geomspace(1e-12, 0.2, 60)
    want = []
    for vv in v:
        x = 2 * mp.asin(mp.sqrt(mp.mpf(vv)))
        want.append(float(2 * (mp.sin(x) - x * mp.cos(x)) / (3 * mp.pi**2)))
    np.testing.assert_allclose(L.phase_function_forward(v), want, rtol=1e-14)
    # the three-term model is its Legendre truncation
    np.testing.assert_allclose(
        L.three_term_phase_function(u),
        (L.LEGENDRE_A[0] + L.LEGENDRE_A[1] * u + L.LEGENDRE_A[2] * (3 * u * u - 1) / 2) / (4 * np.pi),
        rtol=1e-14,
        atol=1e-17,
    )


def test_oren_nayar_is_lambert_without_roughness():
    a, b = O.oren_nayar_coefficients(0.0, 0.33)
    assert (a, b) == (1.0, 0.0)
    mu_o, mu_i, cp = RNG.uniform(0, 1, (3, 100))
    np.testing.assert_array_equal(O.oren_nayar(mu_o, mu_i, cp, a, b, "cos_phi"), 1 / np.pi)


def test_printed_c_of_a_formula_is_the_formula():
    """The C printer (fitlab.codegen) prints the sympy of a formula: compiled, it gives the numpy values."""
    from fitlab.codegen.native import compiler
    from fitlab.codegen.printers import CPrinter

    if compiler() is None:
        pytest.skip("no C compiler")
    import ctypes

    from fitlab.codegen.native import c_function

    c, eta, k = sp.symbols("c eta k", real=True)
    body = CPrinter("double", lambda n: n).doprint(F.fresnel_conductor(c, eta, k))
    source = (
        "#include <math.h>\nstatic double safe_pow(double x, double p) { return x > 0.0 ? pow(x, p) : 0.0; }\n"
        "void fresnel(const double *cs, const double *etas, const double *ks, double *out, "
        "long n)\n{\n    for (long i = 0; i < n; ++i) {\n        const double c = cs[i], eta = etas[i], k = ks[i];\n"
        f"        out[i] = {body};\n    }}\n}}\n"
    )
    pointer = ctypes.POINTER(ctypes.c_double)
    fn = c_function(source, "fresnel", (pointer, pointer, pointer, pointer, ctypes.c_long))
    args = [np.ascontiguousarray(a[5:]) for a in CASES["conductor"][1]]
    out = np.empty(args[0].size)
    fn(*(a.ctypes.data_as(pointer) for a in (*args, out)), out.size)
    np.testing.assert_allclose(out, F.fresnel_conductor(*args), rtol=1e-13, atol=1e-16)
