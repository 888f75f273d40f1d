"""The order-2 runtime model: its parts' exact limits, its identities, and its accuracy.

Every figure here is computed: the exact limits are checked against the exact engine (a second method),
the accuracy of the order-2 model against fitlab.families.lambert_sphere.exact.brdf on the sets of
fitlab.families.lambert_sphere.program.runtime.accuracy_points, next to the paper-structure model measured in the
same run.  The goals asserted are the model's accuracy goals.
"""

from __future__ import annotations

from pathlib import Path

import jax
import numpy as np
import pytest
import sympy as sp

from fitlab.codegen import DEFAULT_FORMS
from fitlab.core import float64, get_form
from fitlab.families.lambert_sphere.exact import albedo, brdf, constants, h_function, multiple_scattering_modes
from fitlab.families.lambert_sphere.forms import runtime_terms
from fitlab.families.lambert_sphere.forms.constants import FIRST_ORDER
from fitlab.families.lambert_sphere.forms.h_functions import characteristic, first_order
from fitlab.families.lambert_sphere.program.runtime import (
    ORDER2_FORMS,
    accuracy,
    directional_albedo,
    runtime_model,
)
from fitlab.forms.symbolic import symbols
from fitlab.store import fit_path, load

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
mu, c, v = symbols(("mu", "c", "v"))
EDGES = np.array([0.0, 1e-12, 1e-6, 1e-3, 0.5, 1.0 - 1e-9, 1.0])


@pytest.fixture(scope="module")
def order2():
    """The order-2 model whose parts are fitted to their own three-term targets (the program's model three-term;
    the default, fitted to the true BRDF: tests/test_default_model.py, tests/test_true_refit.py)."""
    return runtime_model(fits_dir=FITS, forms=ORDER2_FORMS, model="three-term")


@pytest.fixture(scope="module")
def figures(order2):
    """accuracy() of the order-2 model and of the paper-structure refit (orders 0 and 1, default forms), same run."""
    return {
        "order2": accuracy(order2),
        "order1": accuracy(runtime_model(fits_dir=FITS, order2=False, model=DEFAULT_FORMS)),
    }


# -- the exact first order in c --------------------------------------------------------------------
@pytest.mark.parametrize("order", [0, 1, 2])
def test_first_order_polynomial_is_the_integral_it_states(order):
    """first_order = int_0^1 (P(v) - P(mu))/(v + mu) dv, P = Psi/c at c = 0: the sum against sympy's integral."""
    p = sp.expand(characteristic(order, v) / c).subs(c, 0)
    integral = sp.integrate(sp.cancel((p - p.subs(v, mu)) / (v + mu)), (v, 0, 1))
    assert sp.expand(integral - first_order(order)) == 0


@pytest.mark.parametrize("order", [0, 1, 2])
def test_first_order_matches_the_exact_h_function_as_c_goes_to_0(order):
    """(log H/mu - Psi log(1 + 1/mu))/c -> first_order(mu) as c -> 0; the remainder is O(c)."""
    # mu >= 0.01: the solver's ~1e-14 relative error in H costs 1e-14/(mu c) in this quotient
    x = np.array([0.01, 0.1, 0.3, 0.7, 1.0])
    poly = sp.lambdify(mu, first_order(order))(x)
    psi = sp.lambdify((mu, c), characteristic(order))
    gaps = []
    for cv in (1e-3, 1e-4):
        g = (np.log(h_function(order, x, cv)) / x - psi(x, cv) * np.log1p(1 / x)) / cv
        gaps.append(np.max(np.abs(g - poly)))
    assert gaps[1] < 0.2 * gaps[0]  # shrinks like c: the O(c) term is exact


@pytest.mark.parametrize("name", "BCDF")
def test_first_order_constants_match_the_exact_ones(name):
    """X(c)/c -> FIRST_ORDER[X] as c -> 0 (Q = 2 pi (mu_i + mu_o) f0_ss + O(c^2)); the remainder is O(c)."""
    cs = np.array([1e-4, 1e-5])
    k = constants(cs)
    gap = np.abs(np.asarray(k[name], dtype=float) / cs - float(FIRST_ORDER[name]))
    assert gap[1] < 0.2 * gap[0] + 1e-9


def test_first_order_constants_agree_with_single_scattering():
    """A + B t + C p + D p t + E p^2 + F q at O(c) is 2 pi times the numerator of eq. 38 (t = mu_i + mu_o)."""
    mi, mo = symbols(("mu_i", "mu_o"))
    p, t, q = mi * mo, mi + mo, mi**2 + mo**2
    A1, E1 = sp.Rational(69, 128), sp.Rational(45, 128)
    qq = A1 + FIRST_ORDER["B"] * t + FIRST_ORDER["C"] * p + FIRST_ORDER["D"] * p * t + E1 * p**2 + FIRST_ORDER["F"] * q
    assert sp.expand(qq - (207 + 256 * p - 45 * q + 135 * p**2) / sp.Integer(384)) == 0


# -- the forms: limits, float32/float64, gradients ---------------------------------------------------
def _random_params(form, seed=0):
    rng = np.random.default_rng(seed)
    return {p: float(rng.normal(0.0, 0.3)) for p in form.params}


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_log_exp_is_exact_at_mu_0_and_c_0_and_finite_at_the_edges(order, dtype):
    form = get_form(f"H{order}", "log_exp")
    f = sp.lambdify((mu, c), form.substituted(_random_params(form)), "numpy")
    m, cc = (a.astype(dtype) for a in np.meshgrid(EDGES, EDGES, indexing="ij"))
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):  # mu^4 underflows in float32
        out = np.asarray(f(m, cc))
    assert np.all(np.isfinite(out))
    assert np.all(out[0, :] == 1.0) and np.all(out[:, 0] == 1.0)  # mu = 0, c = 0


@pytest.mark.parametrize("order", [0, 1, 2])
def test_log_exp_has_the_exact_grazing_slope(order):
    """H - 1 = Psi(0) mu log(1/mu) + d mu + o(mu): D(mu) = (H - 1)/mu - Psi(0) log(1/mu) has a finite limit,
    so D(1e-6) and D(1e-8) agree (a wrong log weight would separate them by its error times log(100))."""
    form = get_form(f"H{order}", "log_exp")
    f = sp.lambdify((mu, c), form.substituted(_random_params(form, 1)), "numpy")
    for cv in (0.3, 1.0):
        x = np.array([1e-6, 1e-8])  # small enough for the limit, large enough that H - 1 keeps its digits
        psi0 = float(characteristic(order).subs({mu: 0, c: cv}))
        d = (f(x, cv) - 1) / x - psi0 * np.log(1 / x)
        assert abs(d[0] - d[1]) < 1e-3 * abs(psi0)


@pytest.mark.parametrize("target,form", [("H0", "log_exp"), ("H2", "log_exp"), ("C", "c2_rational_4_3")])
def test_jacobians_are_finite_at_the_edges(target, form):
    fm = get_form(target, form)
    theta = np.array([_random_params(fm, 2)[p] for p in fm.params])
    jf = jax.jacfwd(fm.jax_function, argnums=0)
    grid = np.meshgrid(EDGES, EDGES, indexing="ij") if len(fm.inputs) == 2 else (EDGES,)
    jac = float64(lambda t, *xs: np.asarray(jf(t, *xs)))(theta, *(g.ravel() for g in grid))
    assert np.all(np.isfinite(jac))


def test_c2_constants_are_exact_to_first_order():
    for name in "BCDF":
        f = load(fit_path(FITS, name, "c2_rational_4_3"))
        cs = np.array([1e-8, 1e-6])
        assert np.allclose(f(c=cs) / cs, float(FIRST_ORDER[name]), rtol=0, atol=1e-5)
        assert f(c=np.array([0.0]))[0] == 0.0


# -- the runtime model: identities ---------------------------------------------------------------------
def test_fm2_term_with_the_exact_h2_is_the_exact_fm2():
    """runtime_terms' m2 with the exact H2 against the exact engine's third multiple-scattering mode."""
    mi, mo = symbols(("mu_i", "mu_o"))
    parts = {p: sp.Function(f"x_{p}")(c) for p in ("l", "m", "B", "C", "D", "F")}
    parts.update({p: sp.Function(f"x_{p}")(mu, c) for p in ("H0", "H1", "H2")})
    m2 = sp.lambdify((mi, mo, c), runtime_terms(parts)["m2"],
                     modules=[{"x_H2": lambda x, cv: h_function(2, x, cv)}, "numpy"])  # fmt: skip
    rng = np.random.default_rng(3)
    a, b = rng.uniform(1e-3, 1, 50), rng.uniform(1e-3, 1, 50)
    for cv in (0.1, 0.9, 1.0):
        want = multiple_scattering_modes(a, b, cv, phase="three_term")[2]
        assert np.allclose(m2(a, b, cv), want, rtol=1e-9, atol=1e-14)


def test_order2_model_is_reciprocal_nonnegative_and_zero_at_c0(order2):
    rng = np.random.default_rng(4)
    a, b, p = rng.uniform(0, 1, 5000), rng.uniform(0, 1, 5000), rng.uniform(0, np.pi, 5000)
    cc = np.concatenate((rng.uniform(0, 1, 4990), [0, 1e-9, 1e-6, 1e-3, 1, 1, 1, 1, 1, 1]))
    f, g = order2(a, b, p, cc), order2(b, a, p, cc)
    assert np.all(np.isfinite(f)) and np.all(f >= 0)
    assert np.allclose(f, g, rtol=1e-13, atol=0)
    assert np.all(order2(a, b, p, np.zeros_like(a)) == 0.0)


def test_directional_albedo_quadrature_agrees_with_the_exact_albedo():
    """directional_albedo of the exact BRDF against exact.albedo (adaptive quadrature about w_i): two methods."""
    x = np.array([1e-3, 0.4, 1.0])
    for cv in (0.5, 1.0):
        got = directional_albedo(brdf, x, cv)
        assert np.max(np.abs(got - albedo(x, cv))) < 1e-5


# -- accuracy -------------------------------------------------------------------------------------------
def test_order2_model_improves_on_the_paper_structure(figures):
    new, old = figures["order2"], figures["order1"]
    assert new["max"] < 0.5 * old["max"] and new["rms"] < 0.5 * old["rms"]
    assert new["max_grazing"] < 0.5 * old["max_grazing"]
    assert new["max_c0"] == 0.0


def test_order2_model_meets_the_issue_goals(figures):
    r = figures["order2"]
    assert r["max"] <= 5e-3, r["worst"]
    assert r["rms"] <= 5e-4
    assert r["max_grazing"] <= 0.05, r["worst_grazing"]
    assert r["albedo_err"] <= 1e-3
    assert r["albedo_c1_min"] >= 0.999


def test_order2_model_against_both_references(order2, figures):
    """accuracy() measures against the true BRDF by default.  Against the mixed reference, which its parts were
    fitted to, the model is within 8.9e-4 (measured; bound 1e-3), the grazing set included; against the true BRDF
    the structure's own gap adds to that: 2.1e-3 (bound 2.5e-3), worst at grazing forward scattering, where the
    three-term multiple scattering the parts carry is furthest from the truth."""
    mixed = accuracy(order2, phase="mixed")
    assert mixed["max"] <= 1e-3 and mixed["max_grazing"] <= 1e-3
    true = figures["order2"]
    assert mixed["max"] < true["max"] <= 2.5e-3
    assert true["worst"]["phi"] == pytest.approx(np.pi) and true["worst"]["mu_i"] == true["worst"]["mu_o"] == 0.01


def test_energy_at_c1_never_exceeds_one(order2):
    """At c = 1 the model's directional albedo is at most 1 at every incidence and at least 0.999.
    The reference its parts were fitted to exceeds 1 there (phase "mixed": true phase function in single
    scattering, three-term after it; docs/model.md, "Energy"); the energy scale (runtime.energy_scale, set on a
    grid of 103 incidences) holds the model below 1, checked here on 400 other incidences, the grazing edge
    included."""
    x = np.concatenate(([1e-9, 1e-7, 1e-5], np.sort(np.random.default_rng(40).uniform(0, 1, 400))))
    a = directional_albedo(order2, x, 1.0)
    assert a.max() <= 1.0, x[np.argmax(a)]
    assert a.min() >= 0.999
    assert albedo(np.array([0.6]), 1.0, phase="mixed")[0] > 1.0  # why the scale exists


def test_published_presets_need_no_energy_scale():
    """The published presets lose energy at c = 1 (1 to 2 %), so their energy scale is 1: they stay as printed."""
    from fitlab.core import get_form
    from fitlab.families.lambert_sphere.program.runtime import PRESET_VARIANTS, energy_scale

    for variant, (choice, normalisation) in PRESET_VARIANTS.items():
        parts = {p: get_form(p, form).substituted(preset) for p, (form, preset) in choice.items()}
        assert energy_scale(parts, normalisation=normalisation) == 1, variant


def test_energy_scale_is_a_few_parts_in_1e5_and_reproducible():
    """The order-2 fits' scale: below 1 (the unscaled model overshoots, as the reference does) by less than
    1e-4, and the same rational number when recomputed (what makes regenerated code byte-identical), whether
    read from fitlab's cache or computed afresh."""
    from fitlab.families.lambert_sphere.program.runtime import energy_scale

    parts = {p: load(fit_path(FITS, p, ORDER2_FORMS[p])).expression for p in ORDER2_FORMS}
    s = energy_scale(parts)
    assert 1 - 1e-4 < s < 1 and (s * 10**6).is_integer
    assert energy_scale(parts, use_cache=False) == s


# -- generated C of the order-2 model --------------------------------------------------------------------
@pytest.fixture(scope="module")
def order2_c(tmp_path_factory):
    from fitlab.codegen import load_program
    from fitlab.codegen.languages import emit
    from fitlab.codegen.native import build, compiler
    from fitlab.core import get_target

    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    forms = {p: f for p, f in ORDER2_FORMS.items() if f != get_target(p).default_form}
    prog = load_program(FITS, forms=forms, model="three-term")
    return build(emit(prog, "c"), prog, tmp_path_factory.mktemp("order2"))


def test_order2_c_agrees_with_the_model_and_float_with_double(order2, order2_c):
    """C double against the numpy model (same sympy expression, other printer), C float against C double
    (within 1e-4) on mu >= 0.01, every c, cos phi in [-1, 1]; the parts on their own too."""
    rng = np.random.default_rng(5)
    n = 20000
    mi, mo, cc = rng.uniform(0.01, 1, n), rng.uniform(0.01, 1, n), rng.uniform(0, 1, n)
    cp = rng.uniform(-1, 1, n)
    mi, mo, cp, cc = (np.float32(a).astype(float) for a in (mi, mo, cp, cc))
    d = order2_c("brdf", mi, mo, cp, cc)
    want = order2(mi, mo, np.arccos(cp), cc)
    assert np.max(np.abs(d - want) / want) < 1e-12
    f = order2_c("brdf", mi, mo, cp, cc, dtype=np.float32)
    assert np.max(np.abs(f - d) / d) < 1e-4
    for order in range(3):
        fit = load(fit_path(FITS, f"H{order}", "log_exp"))
        assert np.max(np.abs(order2_c(f"h{order}", mi, cc) / fit(mu=mi, c=cc) - 1)) < 1e-13


def test_runtime_structure_with_exact_parts_is_the_reference():
    """The identity the error budget (studies.lambert_sphere.error_budget) rests on: with every
    part exact, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi is the "mixed" reference, true single scattering plus the three-term
    multiple scattering (the three-term phase function has Legendre orders 0-2, so that multiple scattering has
    these three Fourier orders and no other).  The true BRDF's multiple scattering has every order: what the
    structure leaves of it is the error budget's first row."""
    from fitlab.families.lambert_sphere.program.runtime import assembled
    from studies.lambert_sphere.error_budget import exact_parts

    rng = np.random.default_rng(7)
    n = 300
    mi, mo, ph = rng.uniform(0.01, 1, n), rng.uniform(0.01, 1, n), rng.uniform(0, np.pi, n)
    cc = np.repeat([1e-4, 0.3, 0.9, 1.0], n // 4)
    got = assembled(exact_parts())(mi, mo, ph, cc)
    want = brdf(mi, mo, ph, cc, phase="mixed")
    assert np.max(np.abs(got / want - 1)) < 1e-9


def test_runtime_structure_with_exact_parts_at_grazing():
    """The same identity (against the "mixed" reference) on the grazing set's corner (mu_i, mu_o in
    {1e-6, 1e-4, 1e-2}, phi in {0, pi}): within 2.4e-6 (measured; bound 1e-5), the structure's own cancellation of the O(c) terms of
    H_i H_o Q/(2 pi) - n0_ss at mu_i = mu_o = 1e-6, c = 1e-6.  With sqrt(1 - u^2) evaluated directly, single
    scattering in forward scattering at grazing made it 1.2e-4."""
    from fitlab.families.lambert_sphere.program.runtime import assembled
    from studies.lambert_sphere.error_budget import exact_parts

    g = np.array(np.meshgrid([1e-6, 1e-4, 1e-2], [1e-6, 1e-4, 1e-2], [0.0, np.pi], [1e-6, 0.5], indexing="ij"))
    mi, mo, ph, cc = g.reshape(4, -1)
    got = assembled(exact_parts())(mi, mo, ph, cc)
    assert np.max(np.abs(got / brdf(mi, mo, ph, cc, phase="mixed") - 1)) < 1e-5
