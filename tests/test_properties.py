"""Property tests for the exact engine and every runtime model.

Models under test, all as f(mu_i, mu_o, phi, c) in 1/sr:

* ``exact``: :func:`fitlab.families.lambert_sphere.exact.brdf` (its default, the whole phase function
  in every collision; the three-term H-function engine, phase "mixed", where a property is checked
  over many albedos);
* ``paper_printed``, ``paper``, ``renderer``: the preset runtime models,
  :func:`fitlab.families.lambert_sphere.program.runtime.runtime_model` (variant);
* ``refit``: the runtime model of the committed fits, ``runtime_model(fits_dir=fits)``;
* ``generated``: ``brdf(mu_i, mu_o, cos(phi), c)`` of fits/generated/lambert_sphere.py,
  loaded with importlib from the file (not from the installed package).

Properties: reciprocity, non-negativity, directional albedo at most 1 at c = 1
(energy never created), monotonicity in c, clear errors for bad arguments of the
exact engine, and the cost and accuracy of ``constants`` near c = 1.

Where a property does not hold today the case is an ``xfail(strict=True)`` whose
reason gives the measured figure, so that the fix (the energy-conserving runtime model for the runtime
models) turns it into an XPASS, which fails the suite until the mark is removed.

Hypothesis runs derandomized (the same examples on every run) with no example
database (nothing is written into the tree); ``max_examples`` is small so the file
runs in about a minute on two shared cores.  The three-term engine costs ~50 us a
point and ~0.1 s for every new albedo c (three H-function solves), so its c values
are drawn partly from a fixed grid whose solutions stay cached; the whole-phase engine
costs ~4 s for every new albedo (about 31 Fourier orders solved; it keeps the solutions
of about two albedos) and ~0.1 s for every new pair of cosines, so it is checked at the
albedos of C_TRUE.
"""

from __future__ import annotations

import importlib
import importlib.util
import time
import traceback
from functools import cache
from pathlib import Path

import exact_cache
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from fitlab.codegen import DEFAULT_FORMS
from fitlab.families.lambert_sphere.exact import (
    albedo,
    brdf,
    brdf_modes,
    clear_h_cache,
    constants,
    graded_gauss,
    h_fock,
    h_function,
    lambert_sphere_characteristic,
    mode_polynomials,
    multiple_scattering_modes,
    single_scattering_albedo,
    single_scattering_modes,
    solve_h,
    spherical_albedo,
    three_term_single_albedo,
)
from fitlab.families.lambert_sphere.program.runtime import PRESET_VARIANTS, runtime_model

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
GENERATED = FITS / "generated" / "lambert_sphere.py"

PROPERTY = settings(
    max_examples=40, deadline=None, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow]
)
FEW = settings(PROPERTY, max_examples=30)

RUNTIME = (*PRESET_VARIANTS, "refit", "generated")
MODELS = ("exact", *RUNTIME)

# c values whose exact solutions stay cached between examples (ends and the fold included)
C_GRID = (0.0, 1e-6, 1e-3, 0.05, 0.1, 0.2, 0.35, 0.5, 0.65, 0.8, 0.9, 0.95, 0.99, 0.999, 1 - 1e-6, 1.0)

unit = st.floats(0.0, 1.0)  # 0, 1, subnormals and everything between
angle = st.floats(-10.0, 10.0)  # phi: any finite angle, several turns
albedo_c = st.floats(0.0, 1.0)
exact_c = st.one_of(st.sampled_from(C_GRID), st.floats(0.0, 1.0))
# c values of the whole-phase engine: the edges (c = 0 solves nothing) and one inside, whose solutions fit in
# its cache together
C_TRUE = (0.0, 0.5, 1.0)


def true_c(c):
    """The albedo of C_TRUE nearest ``c``."""
    return min(C_TRUE, key=lambda g: abs(g - c))


@cache
def generated_module():
    spec = importlib.util.spec_from_file_location("fitlab_generated_lambert_sphere", GENERATED)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@cache
def model(name):
    """f(mu_i, mu_o, phi, c) for a model name of MODELS (built once per session)."""
    if name == "exact":
        return brdf
    if name in PRESET_VARIANTS:
        return runtime_model(name)
    if name == "refit":
        return runtime_model(fits_dir=FITS, model=DEFAULT_FORMS)
    if name == "generated":
        gen = generated_module()
        return lambda mu_i, mu_o, phi, c: gen.brdf(mu_i, mu_o, np.cos(phi), c)
    raise KeyError(name)


def evaluate(name, mu_i, mu_o, phi, c):
    with np.errstate(all="ignore"):
        return np.asarray(model(name)(mu_i, mu_o, phi, c), dtype=float)


# --------------------------------------------------------------------------- reciprocity

# Every model is symmetric in (mu_i, mu_o) by construction (H(mu_i) H(mu_o), symmetric
# polynomials, S and mu_i + mu_o); swapping the arguments changes only the order of
# the floating-point operations.  The parts that are summed (single scattering, fm0,
# fm1 cos phi, fm2 cos 2phi) are each rounded to ~1e-16 relative, and the exact
# engine forms H_i H_o - 1 as (H_i - 1) H_o + (H_o - 1), which is not symmetric in
# rounding.  Measured on 20000 random points: at most 5.5e-14 relative and 3.6e-15
# absolute (runtime models), 3.3e-15 / 2.2e-16 (exact).  Tolerance: 1e-12 relative
# plus 1e-14 absolute (for values near 0 where the terms cancel), ~20x the worst
# measured; a real asymmetry (a wrong exponent on one H, a mu_i where mu_o belongs)
# is of order 1e-3 or more.
RECIPROCITY_RTOL = 1e-12
RECIPROCITY_ATOL = 1e-14


def assert_reciprocal(a, b):
    a, b = float(a), float(b)
    if np.isnan(a) or np.isnan(b) or np.isinf(a) or np.isinf(b):
        assert a == b or (np.isnan(a) and np.isnan(b)), (a, b)
        return
    assert abs(a - b) <= RECIPROCITY_RTOL * max(abs(a), abs(b)) + RECIPROCITY_ATOL, (a, b, abs(a - b))


@pytest.mark.parametrize("name", RUNTIME)
@PROPERTY
@given(mu_i=unit, mu_o=unit, phi=angle, c=albedo_c)
@example(mu_i=0.0, mu_o=1.0, phi=0.0, c=1.0)
@example(mu_i=1e-300, mu_o=0.999, phi=np.pi, c=0.5)
def test_runtime_models_are_reciprocal(name, mu_i, mu_o, phi, c):
    assert_reciprocal(evaluate(name, mu_i, mu_o, phi, c), evaluate(name, mu_o, mu_i, phi, c))


@FEW
@given(mu_i=unit, mu_o=unit, phi=angle, c=exact_c)
@example(mu_i=0.0, mu_o=1.0, phi=0.0, c=1.0)
@example(mu_i=1e-12, mu_o=0.3, phi=np.pi, c=0.999)
def test_exact_brdf_is_reciprocal(mu_i, mu_o, phi, c):
    assert_reciprocal(brdf(mu_i, mu_o, phi, c, phase="mixed"), brdf(mu_o, mu_i, phi, c, phase="mixed"))
    ct = true_c(c)
    assert_reciprocal(brdf(mu_i, mu_o, phi, ct), brdf(mu_o, mu_i, phi, ct))
    # each Fourier order by itself, too
    for f, g in zip(brdf_modes(mu_i, mu_o, c), brdf_modes(mu_o, mu_i, c)):
        assert_reciprocal(f, g)


# ----------------------------------------------------------------------- non-negativity


def assert_non_negative(v):
    v = float(v)
    assert not np.isnan(v), "NaN"
    assert v >= 0.0, v  # +inf (the pole at mu_i = mu_o = 0) counts as non-negative


@pytest.mark.parametrize("name", MODELS)
@PROPERTY
@given(mu_i=unit, mu_o=unit, phi=angle, c=albedo_c)
@example(mu_i=1.0, mu_o=1.0, phi=0.0, c=1.0)
@example(mu_i=0.0, mu_o=1e-300, phi=np.pi, c=1.0)
@example(mu_i=1.0, mu_o=0.0, phi=np.pi, c=0.0)
def test_non_negative(name, mu_i, mu_o, phi, c):
    if name == "exact":
        c = true_c(c)  # keep the exact engine on cached solutions
    with np.errstate(divide="ignore", over="ignore"):
        overflows = np.isinf(np.float64(1.0) / np.float64(mu_i + mu_o))
    if overflows and name in (*PRESET_VARIANTS, "refit"):
        # the pole and its subnormal neighbours, where 1/(mu_i + mu_o) overflows: the lambdified models' NaN there
        # is test_runtime_model_pole's (a strict xfail)
        return
    assert_non_negative(evaluate(name, mu_i, mu_o, phi, c))


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(
            n,
            marks=pytest.mark.xfail(
                strict=True,
                reason="RuntimeModel (sympy lambdify) returns NaN at mu_i = mu_o = 0 (0/0 in the pole "
                "1/(mu_i + mu_o)); the exact engine returns +inf (0 at c = 0), the generated module a finite value",
            ),
        )
        for n in (*PRESET_VARIANTS, "refit")
    ]
    + ["exact", "generated"],
)
@pytest.mark.parametrize("c", [0.0, 0.5, 1.0])
def test_runtime_model_pole(name, c):
    """At mu_i = mu_o = 0 a model returns a number >= 0 (inf allowed), never NaN."""
    assert_non_negative(evaluate(name, 0.0, 0.0, 0.3, c))


# ------------------------------------------------------------------- monotonicity in c

# The exact BRDF increases with c at every fixed (mu_i, mu_o, phi): more scattering,
# never less light (checked on a sample before asserting it: 400 random angles x the
# 16 values of C_GRID, smallest step 7.9e-9 > 0; the single-scattering part is linear
# in c with a non-negative phase function, the multiple-scattering part is a series
# in c with non-negative terms).  The runtime models: 20000 random points, c2 - c1 up
# to 0.3: no decrease in any of them, so the property is asserted for every model.
# Tolerance: 1e-12 relative + 1e-15 absolute, for c1 and c2 a few ulp apart.


@PROPERTY
@given(mu_i=unit, mu_o=unit, phi=angle)
@example(mu_i=0.0, mu_o=0.0, phi=0.0)
@example(mu_i=1.0, mu_o=1.0, phi=np.pi)
def test_exact_brdf_increases_with_c(mu_i, mu_o, phi):
    c = np.array(C_GRID)
    f = brdf(mu_i, mu_o, phi, c, phase="mixed")
    if mu_i == 0.0 and mu_o == 0.0:  # the pole: 0 at c = 0, +inf for c > 0
        assert f[0] == 0.0 and np.all(f[1:] == np.inf)
        return
    assert np.all(np.diff(f) >= -1e-12 * np.abs(f[:-1]) - 1e-15), f


def test_exact_true_brdf_increases_with_c():
    """The whole-phase BRDF, one albedo at a time over a fixed set of points (random, seeded, and the edges
    mu in {0, 1e-6, 1}, phi in {0, pi}): the engine solves each albedo once."""
    rng = np.random.default_rng(7)
    edge = np.array(np.meshgrid([0.0, 1e-6, 1.0], [1e-6, 1.0], [0.0, np.pi], indexing="ij")).reshape(3, -1)
    mi, mo, ph = np.concatenate((rng.uniform(0, 1, (3, 40)) * [[1], [1], [np.pi]], edge), axis=1)
    f = np.array([exact_cache.brdf(mi, mo, ph, cv) for cv in (0.0, 0.05, 0.5, 0.95, 1.0)])  # tests/exact_cache.py
    assert np.all(np.diff(f, axis=0) >= -1e-12 * np.abs(f[:-1]) - 1e-15)
    assert np.all(f[0] == 0.0) and np.all(np.diff(f, axis=0) > 0)


@pytest.mark.parametrize("name", RUNTIME)
@PROPERTY
@given(mu_i=unit, mu_o=unit, phi=angle, c1=albedo_c, c2=albedo_c)
@example(mu_i=0.5, mu_o=0.5, phi=0.0, c1=0.0, c2=1.0)
def test_runtime_models_increase_with_c(name, mu_i, mu_o, phi, c1, c2):
    lo, hi = sorted((c1, c2))
    with np.errstate(divide="ignore", over="ignore"):
        if np.isinf(np.float64(1.0) / np.float64(mu_i + mu_o)):
            # the pole and its subnormal neighbours, where 1/(mu_i + mu_o) overflows: the runtime models'
            # NaN there is test_runtime_model_pole's (a strict xfail)
            return
    f_lo, f_hi = evaluate(name, mu_i, mu_o, phi, lo), evaluate(name, mu_i, mu_o, phi, hi)
    assert f_hi >= f_lo - 1e-12 * abs(f_lo) - 1e-15, (float(f_lo), float(f_hi))


# ---------------------------------------------------------------- energy: albedo <= 1

# Directional albedo a(mu_i) = 2 int_0^pi int_0^1 f(mu_i, mu_o, phi) mu_o dmu_o dphi
# (every model depends on phi through cos phi only): mu_o on the graded Gauss rule of
# the engine (8 nodes on each panel [4^-(k+1), 4^-k], down to 1e-14: it resolves the
# mu log mu and mu^d behaviour of the H-functions and forms at mu_o -> 0), phi by the
# midpoint rule with 32 nodes on [0, pi] (spectrally accurate for a smooth periodic
# function).  Checked below against the engine's own albedo(mu_i, c) (error <= 2e-7,
# measured 5e-9 at mu_i = 0.5 and 1.9e-7 at mu_i = 1) and, for each runtime model,
# against the rule with twice the nodes in both directions.
ALBEDO_TOL = 1e-6  # what "at most 1" means here: quadrature error 2e-7, with room; sees 1e-4 easily
MU_O_NODES, MU_O_WEIGHTS = graded_gauss(8, 0.25, 1e-14)
N_PHI = 32


def directional_albedo(f, mu_i, c, nodes=(MU_O_NODES, MU_O_WEIGHTS), n_phi=N_PHI):
    v, w = nodes
    phi = (np.arange(n_phi) + 0.5) * np.pi / n_phi
    with np.errstate(all="ignore"):
        val = np.asarray(f(mu_i, v[:, None], phi[None, :], c), dtype=float)
    return float(2.0 * (np.pi / n_phi) * np.sum(val.sum(axis=1) * w * v))


@pytest.mark.parametrize(("mu_i", "c"), [(0.5, 1.0), (1.0, 1.0), (0.2, 0.5)])
def test_albedo_quadrature_reproduces_the_exact_albedo(mu_i, c):
    got = directional_albedo(brdf, mu_i, c)
    assert got == pytest.approx(float(albedo(mu_i, c)), abs=2e-7)


@pytest.mark.parametrize("name", RUNTIME)
def test_albedo_quadrature_has_converged_for_runtime_models(name):
    fine = graded_gauss(16, 0.25, 1e-14)
    for mu_i in (0.0, 0.3, 0.5, 1.0):
        coarse = directional_albedo(model(name), mu_i, 1.0)
        assert coarse == pytest.approx(directional_albedo(model(name), mu_i, 1.0, fine, 2 * N_PHI), abs=2e-7)


# At c = 1 (directional albedo on a grid of mu_i):
#   paper_printed, paper, renderer: max 0.993699 at mu_i = 0, down to 0.978887 at
#     mu_i = 1: they hold (they lose 0.6 to 2.1 %; the three presets differ only in
#     H1, l and m, i.e. in fm1 cos phi, which integrates to 0 over phi);
#   refit and generated (the committed fits, the order-2 model): held below 1 by the
#     energy scale (runtime.energy_scale; without it they reach 1 + 4e-5, as the reference does);
#   exact (the whole phase function in every collision): 1 to 1e-12 (test_exact_albedo_is_one_at_c_1), as the
#     three-term half space alone (test_exact_three_term_albedo_is_one_at_c_1); the "mixed" reference (true
#     single scattering + three-term multiple scattering) reaches 1.0000711 at mu_i = 0.61 (docs/model.md:
#     kd_mixed(1) = 1.0000103).
@pytest.mark.parametrize("name", RUNTIME)
@FEW
@given(mu_i=unit)
@example(mu_i=0.5)
@example(mu_i=0.3)
@example(mu_i=0.0)
@example(mu_i=1.0)
def test_runtime_albedo_at_most_one_at_c_1(name, mu_i):
    a = directional_albedo(model(name), mu_i, 1.0)
    assert a <= 1.0 + ALBEDO_TOL, f"{name}: directional albedo {a:.6f} at mu_i = {mu_i}, c = 1"


def test_exact_albedo_is_one_at_c_1():
    # the reference (the whole phase function in every collision) conserves energy: 1 to 1e-12 at every mu_i
    a = albedo(np.linspace(0.0, 1.0, 41), 1.0)
    np.testing.assert_allclose(a, 1.0, rtol=0, atol=1e-12)


def test_mixed_albedo_excess_is_the_documented_one():
    # the "mixed" reference (true single scattering + three-term multiple scattering) is not conservative
    # by construction: its albedo at c = 1 runs from 0.999884 to 1.0000711 (docs/model.md), pinned here so that
    # it cannot grow unseen
    a = albedo(np.linspace(0.0, 1.0, 41), 1.0, phase="mixed")
    assert 1.0 < a.max() <= 1.0 + 1e-4
    assert a.min() >= 1.0 - 1.2e-4


@PROPERTY
@given(mu_i=unit)
@example(mu_i=0.0)
@example(mu_i=1.0)
def test_exact_three_term_albedo_is_one_at_c_1(mu_i):
    assert float(albedo(mu_i, 1.0, phase="three_term")) == pytest.approx(1.0, abs=1e-12)


@FEW
@given(mu_i=unit, c=exact_c)
def test_exact_three_term_albedo_at_most_one(mu_i, c):
    assert float(albedo(mu_i, c, phase="three_term")) <= 1.0 + 1e-12


# ------------------------------------------------------------- argument errors (exact)

# Found on the engine before the checks of exact/_checks.py:
#   "0.5" (a numeric string) was accepted as 0.5 everywhere; a complex numpy array
#   lost its imaginary part with only a ComplexWarning; True was taken as 1;
#   None gave "c contains NaN"; "abc", ["a"], object() and {} gave numpy's
#   "could not convert string to float" / "float() argument must be ..." naming no
#   argument; a ragged list gave numpy's "inhomogeneous shape" message; order "abc",
#   nan or inf gave int()'s messages or an OverflowError; mode_polynomials(0, 2.0)
#   ran (sqrt of a negative number) and single_scattering_albedo(0.5, "foo") silently
#   used the three-term phase function.
WRONG_TYPES = [
    pytest.param("abc", id="str"),
    pytest.param("0.5", id="numeric-str"),
    pytest.param(None, id="None"),
    pytest.param(0.5 + 0j, id="complex"),
    pytest.param(0.5 + 1j, id="complex-imag"),
    pytest.param(np.array([0.5 + 1j]), id="complex-array"),
    pytest.param(["a", "b"], id="list-of-str"),
    pytest.param([0.5, None], id="list-with-None"),
    pytest.param(True, id="bool"),
    pytest.param(np.array([True]), id="bool-array"),
    pytest.param(object(), id="object"),
    pytest.param({}, id="dict"),
    pytest.param(b"0.5", id="bytes"),
]

# (name, call with the bad value in one argument, domain words the message must contain)
CALLS = [
    ("h_function.mu", lambda x: h_function(0, x, 0.5), "mu"),
    ("h_function.c", lambda x: h_function(0, 0.5, x), "c"),
    ("h_fock.u", lambda x: h_fock(lambert_sphere_characteristic(0, 0.5), x), "u"),
    ("brdf.mu_i", lambda x: brdf(x, 0.5, 0.3, 0.5), "mu_i"),
    ("brdf.mu_o", lambda x: brdf(0.5, x, 0.3, 0.5), "mu_o"),
    ("brdf.phi", lambda x: brdf(0.5, 0.5, x, 0.5), "phi"),
    ("brdf.c", lambda x: brdf(0.5, 0.5, 0.3, x), "c"),
    ("brdf_modes.mu_i", lambda x: brdf_modes(x, 0.5, 0.5), "mu_i"),
    ("brdf_modes.c", lambda x: brdf_modes(0.5, 0.5, x), "c"),
    ("single_scattering_modes.mu_o", lambda x: single_scattering_modes(0.5, x, 0.5), "mu_o"),
    ("multiple_scattering_modes.c", lambda x: multiple_scattering_modes(0.5, 0.5, x), "c"),
    ("albedo.mu_i", lambda x: albedo(x, 0.5), "mu_i"),
    ("albedo.c", lambda x: albedo(0.5, x), "c"),
    ("spherical_albedo.c", lambda x: spherical_albedo(x), "c"),
    ("single_scattering_albedo.mu_i", lambda x: single_scattering_albedo(x), "mu_i"),
    ("three_term_single_albedo.mu_i", lambda x: three_term_single_albedo(x), "mu_i"),
    ("constants.c", lambda x: constants(x), "c"),
    ("mode_polynomials.c", lambda x: mode_polynomials(0, x), "c"),
]

OUT_OF_DOMAIN = {
    "mu": [np.nan, -0.1, -np.inf],
    "u": [np.nan, -1e-300],
    "mu_i": [np.nan, -0.1, 1.0000001, np.inf],
    "mu_o": [np.nan, -0.1, 1.5],
    "phi": [np.nan, np.inf, -np.inf],
    "c": [np.nan, -1e-9, 1.0 + 1e-15, np.inf, 10**400],
}


def check_refusal(call, value, arg, kind):
    with pytest.raises(kind) as exc:
        call(value)
    message = str(exc.value)
    assert "\n" not in message, message
    assert message.startswith(arg + " "), message  # names the argument first
    last = traceback.extract_tb(exc.value.__traceback__)[-1]
    assert "numpy" not in last.filename and "functools" not in last.filename, (last.filename, message)


@pytest.mark.parametrize("value", WRONG_TYPES)
@pytest.mark.parametrize(("label", "call", "arg"), CALLS, ids=[c[0] for c in CALLS])
def test_wrong_argument_types_raise_one_clear_type_error(label, call, arg, value):
    if label == "mode_polynomials.c":
        try:
            hash(value)
        except TypeError:  # lru_cache refuses it before the function runs: clear enough
            with pytest.raises(TypeError, match="unhashable"):
                call(value)
            return
    check_refusal(call, value, arg, TypeError)


@pytest.mark.parametrize(("label", "call", "arg"), CALLS, ids=[c[0] for c in CALLS])
def test_out_of_domain_values_raise_one_clear_value_error(label, call, arg):
    for value in OUT_OF_DOMAIN[arg]:
        check_refusal(call, value, arg, ValueError)


@FEW
@given(
    bad=st.one_of(
        st.text(),
        st.none(),
        st.complex_numbers(),
        st.lists(st.text(), min_size=1, max_size=3),
        st.booleans(),
        st.binary(),
        st.dictionaries(st.text(max_size=2), st.floats(), max_size=2),
    ),
    which=st.sampled_from(["mu_i", "mu_o", "phi", "c"]),
)
def test_brdf_refuses_every_non_real_argument(bad, which):
    args = {"mu_i": 0.5, "mu_o": 0.5, "phi": 0.3, "c": 0.5}
    args[which] = bad
    with pytest.raises(TypeError, match=f"^{which} must be a real number"):
        brdf(**args)


@FEW
@given(c=st.one_of(st.floats(allow_nan=True), st.integers()).filter(lambda x: not (0 <= x <= 1)))
def test_albedo_refuses_every_c_outside_0_1(c):
    with pytest.raises(ValueError, match="^c "):
        albedo(0.5, c)


OTHER_REFUSALS = [
    (lambda: h_function("abc", 0.5, 0.5), TypeError, "order"),
    (lambda: h_function(None, 0.5, 0.5), TypeError, "order"),
    (lambda: h_function(np.nan, 0.5, 0.5), ValueError, "order"),
    (lambda: h_function(np.inf, 0.5, 0.5), ValueError, "order"),
    (lambda: h_function(True, 0.5, 0.5), TypeError, "order"),
    (lambda: h_function(1.5, 0.5, 0.5), ValueError, "order"),
    (lambda: h_function(0, 0.5, 0.5, method=None), TypeError, "method"),
    (lambda: h_function(0, 0.5, 0.5, method="magic"), ValueError, "method"),
    (lambda: mode_polynomials("0", 0.5), TypeError, "order"),
    (lambda: mode_polynomials(0, 2.0), ValueError, "c"),
    (lambda: albedo(0.5, 0.5, phase=3), TypeError, "phase"),
    (lambda: albedo(0.5, 0.5, phase="lambert"), ValueError, "phase"),
    (lambda: spherical_albedo(0.5, phase=3), TypeError, "phase"),
    (lambda: single_scattering_albedo(0.5, "foo"), ValueError, "phase"),
    (lambda: single_scattering_albedo([0.5, 0.6]), TypeError, "mu_i"),
    (lambda: three_term_single_albedo(0.5), ValueError, "mu_i"),
    (lambda: solve_h("Psi"), TypeError, "char"),
    (lambda: solve_h(lambert_sphere_characteristic(0, 0.5), nodes_per_panel=0), ValueError, "nodes_per_panel"),
    (lambda: solve_h(lambert_sphere_characteristic(0, 0.5), ratio=1.0), ValueError, "ratio"),
    (lambda: h_fock(lambert_sphere_characteristic(0, 0.5), 0.5, h=0.0), ValueError, "h"),
    (lambda: h_fock(None, 0.5), TypeError, "char"),
    (lambda: brdf([[0.1], [0.2, 0.3]], 0.5, 0.3, 0.5), ValueError, "mu_i"),
]


@pytest.mark.parametrize(
    ("call", "kind", "start"),
    OTHER_REFUSALS,
    ids=[f"{i}-{a}-{k.__name__}" for i, (_, k, a) in enumerate(OTHER_REFUSALS)],
)
def test_other_arguments_are_refused_clearly(call, kind, start):
    check_refusal(lambda _: call(), None, start, kind)


def test_valid_argument_kinds_still_work():
    from fractions import Fraction

    ref = float(brdf(0.5, 0.25, 0.0, 0.5))
    assert float(brdf(Fraction(1, 2), np.float32(0.25), 0, 1 / 2)) == pytest.approx(ref, rel=1e-7)
    assert float(brdf([0.5], [0.25], [0.0], [0.5])[0]) == ref
    assert float(h_function(np.int64(0), 1, 1)) > 2.0  # integers anywhere: H0(1) at c = 1 is 2.9
    assert h_function(0, np.inf, 0.5) == pytest.approx(float(constants(0.5)["H0_inf"]), rel=1e-12)
    assert brdf(np.zeros((0,)), 0.5, 0.3, 0.5).shape == (0,)


# ------------------------------------------------- the slow corner: constants(1 - 1e-16)

# Profile (before the fix, one BLAS thread): 10 s cold, 92 H-function solves.  The
# moment relations near c = 1 were continued along a fixed ladder in s = sqrt(1 - c):
# 25 steps from s = 0.5 to 0.02, then halving down to the target s = 1.05e-8 (20 more),
# for order 0 and order 1 alike, each step an H-function solve (480 x 480 Newton)
# plus a finite-difference Newton on the moment relations that near the fold runs to
# its 50-iteration cap.  With BLAS on two threads on a busy two-core machine a single
# 480 x 480 solve took 0.4 s instead of 9 ms, and constants(1 - 1e-16) 150 s.
# The fix (constants._solve_unknowns): order 1 has no fold and starts from the c -> 0
# limit (same root as the ladder to 4e-16 on s in [1e-8, 0.5]); order 0 walks the
# ladder only down to s = 6.25e-4 and starts below it from the straight line in s
# between the regular conservative solution (s = 0) and that ladder point.  It is
# also more accurate: B(1 - 1e-16) was 1.4e-9 off its expansion in s, now 2e-12.


def _clear_constant_caches():
    mod = importlib.import_module("fitlab.families.lambert_sphere.exact.constants")
    mod.mode_polynomials.cache_clear()
    mod._ladder_solution.cache_clear()
    mod._conservative_unknowns.cache_clear()
    clear_h_cache()
    return mod


def test_constants_near_c_1_are_fast_from_a_cold_start():
    hmod = importlib.import_module("fitlab.families.lambert_sphere.exact.hfunction")
    _clear_constant_caches()
    t = time.perf_counter()
    k = constants(1 - 1e-16)
    seconds = time.perf_counter() - t
    solves = hmod._solve_cached.cache_info().misses
    # 92 H-function solves before the fix; 25 + 5 ladder points of order 0, c = 1, the target
    assert solves <= 40, solves
    assert seconds < 30.0, seconds  # ~3 s with one BLAS thread (conftest); 10 s before the fix
    assert np.isfinite(k["B"]) and k["H0_inf"] > 8e7


def test_constants_near_c_1_are_accurate():
    c = 1 - 1e-16  # the double just below 1: 1 - 2^-53, s = 1.054e-8
    s = np.sqrt(1.0 - c)
    k, k1, k0 = constants(c), constants(1 - 1e-12), constants(1.0)
    s1 = np.sqrt(1.0 - (1 - 1e-12))
    # H0(inf) = K0(0)^(-1/2) in closed form (eq. 32)
    assert float(k["H0_inf"]) == pytest.approx(12.0 / np.sqrt((16 - c) * (4 * c + 9)) / s, rel=1e-12)
    # every other constant is analytic in s near s = 0: the straight line through
    # c = 1 and c = 1 - 1e-12 predicts it to O(s s1) = 1e-14 (the curvature terms are
    # below 1 in size; measured 6e-15 at most).  B is the exception: it depends on the
    # fold direction of the order-0 moment relations, whose root at s = 1e-8 is fixed
    # only to ~eps/s by the equations themselves; measured 2.0e-12 off the line
    # (4e-12 at c = 1 - 4e-16).  Before the fix B was 1.4e-9 off.
    for name in ("l", "m", "A", "B", "C", "D", "E", "F"):
        predicted = float(k0[name]) + (float(k1[name]) - float(k0[name])) * s / s1
        assert float(k[name]) == pytest.approx(predicted, abs=2e-11 if name == "B" else 1e-13), name
    # the moment relations and their closed-form consequences (eq. 33 and the Psi identities)
    assert float(k["A"]) == pytest.approx(69 * c / 128, abs=1e-15)
    assert float(k["E"]) == pytest.approx(15 / 128 * (1 - c) * c * (4 * c / 3 + 3), abs=1e-15)
    assert float(k["l"] ** 2 + 45 * k["m"] / 64) == pytest.approx((45 + 20 * c) / 64, abs=1e-14)
    assert float(2 * k["F"] - k["C"]) == pytest.approx(c * (c * (20 * c + 281) - 346) / 384, abs=1e-14)
    for order in (0, 1, 2):
        assert mode_polynomials(order, c).residual <= 1e-13
