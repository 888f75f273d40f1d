"""Forms: one symbolic definition, numpy and JAX agree, presets transcribe the published coefficients (docs/model.md),
values and parameter gradients stay finite at the domain edges."""

import itertools
import json
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import sympy as sp

from fitlab.core import float64, get_form
from fitlab.families.lambert_sphere.forms import FORMS, runtime_brdf
from fitlab.forms.symbolic import parse_expression, safe_pow

ALL = list(FORMS)
EDGE = {"mu": (0.0, 1e-12, 0.5, 1.0), "mu_i": (0.0, 1e-9, 0.5, 1.0), "mu_o": (0.0, 0.3, 1.0),
        "c": (0.0, 1e-12, 0.5, 1 - 1e-12, 1.0), "kd": (0.0, 0.5, 1.0), "phi": (-np.pi, 0.0, 2.0, np.pi)}  # fmt: skip


def _edge_points(form):
    grid = np.array(list(itertools.product(*(EDGE[n] for n in form.inputs))))
    if (
        "mu_i" in form.inputs and "mu_o" in form.inputs
    ):  # the pole mu_i = mu_o = 0 of every BRDF term is outside the forms' domain
        i, o = form.inputs.index("mu_i"), form.inputs.index("mu_o")
        grid = grid[(grid[:, i] + grid[:, o]) > 0]
    return [grid[:, k] for k in range(grid.shape[1])]


def _parameter_vectors(form):
    rng = np.random.default_rng(0)
    base = form.vector(form.start_values)
    out = [base] + [form.vector(p) for p in form.presets]
    for _ in range(4):  # points an optimizer may visit: +-30 % around the start
        v = base * (1 + 0.3 * rng.uniform(-1, 1, base.size))
        v[[form.params.index(p) for p in form.fixed]] = [form.fixed[p] for p in form.fixed]
        out.append(v)
    return out


@pytest.mark.parametrize("form", ALL, ids=lambda f: f.key)
@float64  # fitlab's JAX work is float64; import fitlab leaves JAX's default as it was
def test_finite_values_and_gradients_at_edges(form):
    xs = _edge_points(form)
    jac = jax.jit(jax.jacfwd(lambda th, *x: form.jax_function(th, *x)))
    for theta in _parameter_vectors(form):
        v = form.numpy_function(theta, *xs)
        assert np.all(np.isfinite(v)), form.key
        j = np.asarray(jac(jnp.asarray(theta), *(jnp.asarray(x) for x in xs)))
        assert np.all(np.isfinite(j)), form.key


@pytest.mark.parametrize("form", ALL, ids=lambda f: f.key)
@float64
def test_numpy_and_jax_agree_and_float32_stays_finite(form):
    rng = np.random.default_rng(1)
    xs = [rng.uniform(0.01, 1.0, 200) for _ in form.inputs]
    theta = form.vector(form.start_values)
    a = form.numpy_fit_function(theta, *xs)
    b = np.asarray(form.jax_function(jnp.asarray(theta), *(jnp.asarray(x) for x in xs)))
    np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-300)
    edge32 = [np.asarray(x, dtype=np.float32) for x in _edge_points(form)]
    assert np.all(np.isfinite(form.numpy_function(theta.astype(np.float32), *edge32)))


def test_expression_text_round_trips():
    for form in ALL:
        back = parse_expression(form.expression, (*form.inputs, *form.params))
        assert sp.simplify(back - form.expr) == 0, form.key


def test_parse_expression_rejects_unknown_names():
    with pytest.raises(ValueError, match="unknown name 'typo'"):
        parse_expression("mu + typo", ("mu",))


def test_memoised_translations_are_what_a_fresh_translation_gives():
    """parse_expression, expression_text and the lambdify back ends keep their results (fitlab.forms.symbolic):
    a second call gives the same object; a refusal is raised again, never kept as a result; two expressions that
    ``==`` tells apart only by a Float's precision keep texts of their own; the names are part of the key."""
    from fitlab.forms.symbolic import expression_text, lambdify_numpy, symbols

    text = "a*mu**2 + 0.25*safe_pow(mu, b)"
    first = parse_expression(text, ("mu", "a", "b"))
    assert parse_expression(text, ["mu", "a", "b"]) is first
    mu, a, b = symbols(("mu", "a", "b"))
    assert first == a * mu**2 + sp.Float("0.25") * safe_pow(mu, b)
    for _ in range(2):
        with pytest.raises(ValueError, match="unknown name 'b'"):
            parse_expression(text, ("mu", "a"))
    x = sp.Symbol("x", real=True)
    short, long = sp.Float("0.1", 15) * x, sp.Float("0.1", 30) * x
    assert expression_text(short) == "0.100000000000000*x"
    assert expression_text(long) == "0.100000000000000000000000000000*x"
    f = lambdify_numpy((mu, a, b), first)
    assert lambdify_numpy([mu, a, b], first) is f
    assert f(0.5, 2.0, 1.0) == 2.0 * 0.25 + 0.25 * 0.5
    terms = lambdify_numpy((mu,), [mu**2, mu])  # a list: translated each time, returns a list
    assert terms(3.0) == [9.0, 3.0]


def test_parse_expression_matches_sympys_parser_on_every_committed_fit():
    # the restricted parser must read what sympy's (code-evaluating) parser read before, node for node
    for path in sorted((Path(__file__).resolve().parents[1] / "fitlab" / "fits").glob("*.json")):
        rec = json.loads(path.read_text())
        names = (*rec["inputs"], *rec["params"])
        local = {n: sp.Symbol(n, real=True) for n in names} | {"safe_pow": safe_pow}
        assert sp.srepr(parse_expression(rec["expression"], names)) == sp.srepr(
            sp.sympify(rec["expression"], locals=local)
        ), path.name


@pytest.mark.parametrize(
    "text, message",
    [
        ("__import__('os').system('touch /tmp/x') or mu", "BoolOp"),
        ("mu.__class__", "Attribute"),
        ("(lambda: 1)()", "calls"),
        ("__import__('os')", "calls '__import__'"),
        ("mu**99999999", "power"),
        ("(" * 400 + "mu" + ")" * 400, "nest|parse"),
        ("'a'", "str literal"),
        ("mu[0]", "Subscript"),
        ("sqrt(mu, x=1)", "keyword"),
        ("1e999", "non-finite"),
        ("sqrt()", "0 arguments"),
        ("mu" + " + mu" * 60000, "characters long"),
    ],
)
def test_parse_expression_refuses_code_without_running_it(text, message):
    with pytest.raises(ValueError, match=message):
        parse_expression(text, ("mu", "c"))


# Independent transcriptions of the paper's coefficients (docs/model.md, "Published approximations"), typed from the text, checked against the forms' presets.
def test_presets_transcribe_spec6():
    mu = np.linspace(0, 1, 11)[:, None]
    c = np.linspace(0, 1, 7)[None, :]
    s = np.sqrt(1 - c)
    a = (1.50112 * s**6.05435 + 8.21644) / (4.17593 - 1.21222 * s)
    d = (7.7731 - 0.565811 * s**0.961546) / (8.65912 - 0.159974 * s**7)
    with np.errstate(divide="ignore"):
        h0inf = 12 / np.sqrt((c - 16) * (c - 1) * (4 * c + 9))
    want = (1 + a * mu**d) / (1 + a * mu**d / h0inf)
    np.testing.assert_allclose(get_form("H0", "hapke")("paper", mu, c), want, rtol=1e-13)
    e = -1.1283119660147671 * mu**3 + 1.8572804924335546 * mu**2 - 1.0787917226917565 * mu + 0.45944184025347456
    want = np.exp((-0.14483935877260054 * c + 0.024285125615255733 * c**2) * mu**e)
    np.testing.assert_allclose(get_form("H1", "separable")("renderer", mu, c), want, rtol=1e-13)
    e = -1.12831 * mu**3 + 1.85728 * mu**2 - 1.07879 * mu + 0.459442
    want = np.exp(0.0242851 * c**2 - 0.144839 * c) * np.exp(-0.0894878 * mu**e)
    np.testing.assert_allclose(get_form("H1", "separable_printed")("paper", mu, c), want, rtol=1e-13)
    s = s.ravel()
    b = (0.346689 * s**3 - 0.777574 * s**2 + 0.515357 * s - 0.084463) / (0.182602 * s**2 - 0.665502 * s + 0.964893)
    np.testing.assert_allclose(get_form("B", "printed")("paper", c.ravel()), b, rtol=1e-13, atol=1e-15)
    kd = np.linspace(0, 1, 9)
    want = (1 - 1.00425 * (1 - kd) ** 2.67103) / (1 - 0.219924 * (1 - kd) ** 2.44559)
    np.testing.assert_allclose(get_form("c_of_kd", "rational_power")("paper", kd), want, rtol=1e-13)
    cc = c.ravel()
    want = (1 - 0.453029 * (1 - cc) - 0.544162 * np.sqrt(1 - cc)) / (1 + 1.42931 * np.sqrt(1 - cc))
    np.testing.assert_allclose(get_form("kd_of_c", "printed")("paper", cc), want, rtol=1e-13)


def test_fast_brdf_preset_is_eq41():
    rng = np.random.default_rng(2)
    mi, mo, c, kd = (rng.uniform(0.05, 0.95, 500) for _ in range(4))
    phi = rng.uniform(-np.pi, np.pi, 500)
    S = np.sqrt((1 - mi**2) * (1 - mo**2))
    u = -(mi * mo + S * np.cos(phi))
    f1 = c * 2 * (np.sqrt(1 - u**2) - u * np.arccos(u)) / (3 * np.pi**2) / (mi + mo)
    want = np.maximum(
        0,
        f1
        + 0.0151829 * (c - 0.249978) * (np.abs(phi) + np.sqrt(mi * mo)) / (np.arccos(S) / S + 0.113706)
        + 0.234459 * kd**1.85432,
    )
    np.testing.assert_allclose(get_form("fast_brdf", "paper")("paper", mi, mo, phi, c, kd), want, rtol=1e-12)


def test_printed_normalisation_halves_fm1():
    # eqs. 22 and 28 as printed (6 pi, 384 pi) give exactly half the corrected fm1;
    # fm1 = (g(phi=0) - g(pi) - (f_1(0) - f_1(pi)))/2 of the unclamped sum g
    from fitlab.families.lambert_sphere.forms.brdf import SINGLE, c, mu_i, mu_o, phi
    from fitlab.families.lambert_sphere.program.runtime import PRESET_VARIANTS

    choice, _ = PRESET_VARIANTS["paper"]
    parts = {p: get_form(p, f).substituted(pr) for p, (f, pr) in choice.items()}

    def fm1(normalisation):
        g = next(a for a in runtime_brdf(parts, normalisation).args if a != 0) - SINGLE
        at = {mu_i: 0.3, mu_o: 0.6, c: 0.8}
        return float((g.subs({**at, phi: 0}) - g.subs({**at, phi: sp.pi})).evalf(30)) / 2

    assert fm1("printed") == pytest.approx(fm1("corrected") / 2, rel=1e-12)


def test_clamped_forms_fit_the_unclamped_expression():
    f = get_form("fast_brdf", "paper")
    assert isinstance(f.expr, sp.Max) and not isinstance(f.fit_expr, sp.Max)
    assert get_form("H0", "hapke").fit_expr == get_form("H0", "hapke").expr


def test_the_lambert_clamps_built_unevaluated_are_sympys_evaluated_ones():
    """forms/brdf.py builds its clamps (Max, Min) with evaluate=False, which spares every import of the family
    sympy's ordering of their arguments; each clamp, evaluated again, is the same expression."""
    from fitlab.families.lambert_sphere.forms.brdf import PHASE, PHASE_FORWARD, SINGLE

    exprs = [PHASE, PHASE_FORWARD, SINGLE, *(f.expr for f in FORMS)]
    clamps = {node for e in exprs for node in sp.preorder_traversal(e) if isinstance(node, (sp.Max, sp.Min))}
    assert len(clamps) >= 5  # the phase function's three, the angle's, the fast BRDF's
    for node in clamps:
        assert node.func(*node.args) == node, node
