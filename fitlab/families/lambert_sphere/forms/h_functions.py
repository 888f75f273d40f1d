r"""Forms for H0, H1 (and H2, which only the log_exp form approximates) as functions of (mu, c), mu in [0, 1], c in [0, 1].

s = sqrt(1 - c) throughout (docs/model.md, "Published approximations").
"""

from __future__ import annotations

import sympy as sp

from fitlab.forms.form import Form
from fitlab.forms.symbolic import safe_pow, symbols

mu, c = symbols(("mu", "c"))
s = sp.sqrt(1 - c)

#: 1/H0(inf) from eq. 32, exact: s sqrt((16 - c)(4c + 9))/12; zero at c = 1,
#: where H0(inf) is infinite, so the form divides by nothing singular.
INV_H0_INF = s * sp.sqrt((16 - c) * (4 * c + 9)) / 12


def _hapke() -> Form:
    a1, a2, a3, a4, a5, d1, d2, d3, d4, d5, d6 = symbols(
        ("a1", "a2", "a3", "a4", "a5", "d1", "d2", "d3", "d4", "d5", "d6")
    )
    a = (a1 * safe_pow(s, a2) + a3) / (a4 - a5 * s)
    d = (d1 - d2 * safe_pow(s, d3)) / (d4 - d5 * safe_pow(s, d6))
    x = a * safe_pow(mu, d)
    paper = dict(
        a1=1.50112, a2=6.05435, a3=8.21644, a4=4.17593, a5=1.21222,
        d1=7.7731, d2=0.565811, d3=0.961546, d4=8.65912, d5=0.159974, d6=7.0,
    )  # fmt: skip
    return Form(
        target="H0",
        name="hapke",
        inputs=("mu", "c"),
        params=("a1", "a2", "a3", "a4", "a5", "d1", "d2", "d3", "d4", "d5", "d6"),
        expr=(1 + x) / (1 + x * INV_H0_INF),
        presets={"paper": paper},
        # a and d are each a ratio: one scale per ratio is redundant.
        fixed={"a4": paper["a4"], "d4": paper["d4"]},
        description=(
            "Hapke-style H0 (eq. 31): (1 + a mu^d)/(1 + a mu^d/H0(inf)), H0(inf) exact (eq. 32), "
            "a = (a1 s^a2 + a3)/(a4 - a5 s), d = (d1 - d2 s^d3)/(d4 - d5 s^d6). "
            "Exact at mu = 0 (H0 = 1) and as mu -> inf; a4, d4 fix the scales of the two ratios."
        ),
    )


def _hapke_rational() -> Form:
    # A richer member of the same family: a and d quadratic-over-linear in s,
    # plus a mu^2 d term in numerator and denominator.  Same limits as eq. 31.
    names = ("a0", "a1", "a2", "a3", "d0", "d1", "d2", "d3", "b0", "b1")
    a0, a1, a2, a3, d0, d1, d2, d3, b0, b1 = symbols(names)
    a = (a0 + a1 * s + a2 * s**2) / (1 + a3 * s)
    d = (d0 + d1 * s + d2 * s**2) / (1 + d3 * s)
    b = b0 + b1 * s
    x = a * safe_pow(mu, d)
    y = b * safe_pow(mu, 2 * d)
    # start near eq. 31: a(0) = 8.21644/4.17593, d(0) = 7.7731/8.65912, similar values at s = 1
    start = dict(a0=1.9676, a1=0.0, a2=0.5, a3=-0.2903, d0=0.8977, d1=-0.05, d2=0.0, d3=0.0, b0=0.0, b1=0.0)
    return Form(
        target="H0",
        name="hapke_rational",
        inputs=("mu", "c"),
        params=names,
        expr=(1 + x + y) / (1 + (x + y) * INV_H0_INF),
        start=start,
        description=(
            "H0 = (1 + a mu^d + b mu^(2d))/(1 + (a mu^d + b mu^(2d))/H0(inf)), a, d quadratic over linear "
            "in s, b linear in s: eq. 31 with two more degrees of freedom in a, d and a second power of mu."
        ),
    )


def _h1_exponent():
    e0, e1, e2, e3 = symbols(("e0", "e1", "e2", "e3"))
    return e0 + e1 * mu + e2 * mu**2 + e3 * mu**3


_H1_PAPER = dict(k1=-0.144839, k2=0.0242851, e0=0.459442, e1=-1.07879, e2=1.85728, e3=-1.12831)
_H1_RENDERER = dict(
    k1=-0.14483935877260054, k2=0.024285125615255733,
    e0=0.45944184025347456, e1=-1.0787917226917565, e2=1.8572804924335546, e3=-1.1283119660147671,
)  # fmt: skip


def _h1_separable() -> Form:
    k1, k2 = symbols(("k1", "k2"))
    return Form(
        target="H1",
        name="separable",
        inputs=("mu", "c"),
        params=("k1", "k2", "e0", "e1", "e2", "e3"),
        expr=sp.exp((k1 * c + k2 * c**2) * safe_pow(mu, _h1_exponent())),
        presets={"renderer": _H1_RENDERER, "paper": _H1_PAPER},
        description=(
            "Separable H1 as the author's renderer evaluates it: exp((k1 c + k2 c^2) mu^e(mu)), "
            "e a cubic in mu (eqs. 23-25, renderer reading). H1 = 1 at mu = 0 and at c = 0 exactly; "
            "the 'paper' preset is the same function with the printed (rounded) coefficients."
        ),
    )


def _h1_separable_printed() -> Form:
    k1, k2, h = symbols(("k1", "k2", "h"))
    params = ("k1", "k2", "h", "e0", "e1", "e2", "e3")
    paper = dict(_H1_PAPER, h=-0.0894878)
    return Form(
        target="H1",
        name="separable_printed",
        inputs=("mu", "c"),
        params=params,
        expr=sp.exp(k1 * c + k2 * c**2) * sp.exp(h * safe_pow(mu, _h1_exponent())),
        presets={"paper": paper, "paper_variant": dict(paper, k2=0.242851)},
        description=(
            "Separable H1 as printed (eqs. 23-25): H1(1) Hc1(mu), H1(1) = exp(k1 c + k2 c^2), "
            "Hc1 = exp(h mu^e(mu)); 'paper_variant' is the other version's 0.242851 c^2. The shape cannot give "
            "H1 = 1 at c = 0 (Hc1 does not depend on c), so its floor is several per cent."
        ),
        refit_by_default=False,
    )


#: floor of mu inside log(1 + 1/mu): mu log(1 + 1/mu) -> 0 at mu = 0 instead of 0 * inf (1e-30 is a normal
#: float, so the float back ends keep it)
LOG_FLOOR = sp.Float("1e-30")


def characteristic(order: int, x: sp.Expr = mu) -> sp.Expr:
    r"""Psi_order(x, c), the characteristic function of Fourier order 0, 1, 2 (eqs. 13-15; docs/model.md)."""
    if order == 0:
        return c * (-15 * (c - 1) * (4 * c + 9) * x**4 + (c * (20 * c + 281) - 346) * x**2 + 207) / 384
    if order == 1:
        return -c * (x**2 - 1) * (5 * (4 * c + 9) * x**2 - 64) / 192
    if order == 2:
        return 15 * c * (x**2 - 1) ** 2 / 256
    raise ValueError(f"order must be 0, 1 or 2, got {order!r}")


def first_order(order: int, x: sp.Expr = mu) -> sp.Expr:
    r"""The O(c) part of log(H_order(x))/x less its log term, exactly: a cubic in x.

    With Psi = c P(v) + O(c^2), the first iterate of H = 1 + x H int_0^1 Psi(v) H(v)/(x + v) dv gives
    H = 1 + c x int_0^1 P(v)/(x + v) dv + O(c^2), and for P even
    int_0^1 P(v)/(x + v) dv = P(x) log(1 + 1/x) + int_0^1 (P(v) - P(-x))/(v + x) dv;
    for P = sum_n p_2n v^2n the last integral is sum_n p_2n sum_{k<2n} (-x)^(2n-1-k)/(k+1)."""
    p = sp.Poly(sp.expand(characteristic(order, symbols(("v",))[0]) / c).subs(c, 0), symbols(("v",))[0])
    out = sp.S.Zero
    for (deg,), coeff in p.terms():
        out += coeff * sum((-x) ** (deg - 1 - k) / sp.Integer(k + 1) for k in range(deg))
    return sp.expand(out)


#: (degree in s, degree in mu) of the fitted part of each order's log_exp form, a polynomial times (1 - s),
#: chosen by a linear least-squares scan of log(H)/mu on the tables: H0 needs the most powers (its H0(inf)
#: is infinite at s = 0), H2 the fewest (Psi2 <= 15c/256)
LOG_EXP_DEGREES = {0: (5, 4), 1: (2, 3), 2: (1, 3)}


#: Psi_order(0)/c with the whole phase function p in every collision (the true BRDF's): 2 int_0^pi p(cos x) cos(order x)
#: dx over the horizon's circle, of which the three-term Psi_order(0)/c (:func:`characteristic`: 69/128, -1/3, 15/256)
#: keeps the Legendre terms l <= 2; order 1 has no other (p's odd part is linear in its cosine)
TRUE_GRAZING = {0: 16 / (3 * sp.pi**2), 1: -sp.Rational(1, 3), 2: 16 / (27 * sp.pi**2)}


def true_grazing_shift(order: int) -> sp.Expr:
    r"""kappa: what the ``log_exp_true`` forms add to Psi_order(mu)/c in their log term, so that the runtime structure
    has the true BRDF's grazing law, (Psi_order(0) + kappa c) Psi_order(0) = Psi_order,true(0)^2
    (docs/model.md, "Parts fitted to the true BRDF"): kappa = (Psi_true(0)^2/Psi(0) - Psi(0))/c."""
    three = characteristic(order, sp.S.Zero) / c
    return TRUE_GRAZING[order] ** 2 / three - three


def log_exp(order: int, remainder: sp.Expr, shift: sp.Expr = sp.S.Zero) -> sp.Expr:
    r"""H_order(mu, c) = exp(mu ((Psi_order(mu) + shift c) log(1 + 1/mu) + c (p(mu) + remainder))): the exact grazing
    term (Psi_order, eqs. 13-15) and the exact first-order cubic p (:func:`first_order`), with ``remainder`` the
    rest, O(c), a function of (mu, c): a fitted polynomial (the ``log_exp`` forms) or a table
    (:mod:`fitlab.families.lambert_sphere.program.table_export`).  ``shift``: 0 for the three-term H-function,
    :func:`true_grazing_shift` for the true BRDF's grazing law.  See :func:`log_exp_remainder` for its inverse
    (shift 0)."""
    grazing = (characteristic(order) + shift * c) * sp.log(1 + 1 / sp.Max(mu, LOG_FLOOR))
    return sp.exp(mu * (grazing + c * (first_order(order) + remainder)))


def log_exp_remainder(order: int, h: sp.Expr) -> sp.Expr:
    r"""The remainder of :func:`log_exp` that gives H_order = ``h``: (log(h)/mu - Psi_order(mu) log(1 + 1/mu))/c - p(mu),
    for mu > 0 and c > 0 (at c = 0 it is 0, at mu -> 0 a finite limit)."""
    return (sp.log(h) / mu - characteristic(order) * sp.log(1 + 1 / mu)) / c - first_order(order)


def _h_log_exp(order: int) -> Form:
    s_degree, mu_degree = LOG_EXP_DEGREES[order]
    names = tuple(f"a{j}{k}" for j in range(s_degree + 1) for k in range(mu_degree + 1))
    coef = dict(zip(names, symbols(names)))
    # (1 - s) once, not its powers: 1 - s = c/(1 + s) is one division in the generated code
    fitted = (1 - s) * sum(coef[f"a{j}{k}"] * s**j * mu**k for j in range(s_degree + 1) for k in range(mu_degree + 1))
    return Form(
        target=f"H{order}",
        name="log_exp",
        inputs=("mu", "c"),
        params=names,
        expr=log_exp(order, fitted),
        start={n: 0.0 for n in names},
        description=(
            f"H{order} = exp(mu (Psi{order}(mu) log(1 + 1/mu) + c (p(mu) + (1 - s) sum_jk a_jk s^j mu^k))), "
            f"j <= {s_degree}, k <= {mu_degree}, Psi{order} the exact characteristic function "
            "(eqs. 13-15) and p the exact cubic of the first iterate (first_order). Exact at mu = 0 (H = 1), "
            f"at c = 0 and to first order in c (1 - s = O(c)); H - 1 ~ Psi{order}(0) mu log(1/mu) "
            "as mu -> 0, the exact grazing behaviour, so (H_i H_o - 1)/(mu_i + mu_o) in the runtime BRDF keeps "
            "its log(1/mu) pole."
        ),
    )


#: (degree in s, degree in mu) of the fitted part of each order's log_exp_true form (the parts fitted to the true
#: BRDF through the runtime structure): log_exp's, with one more power of mu in H1 and H2
TRUE_LOG_EXP_DEGREES = {0: (5, 4), 1: (2, 4), 2: (1, 4)}


def _h_log_exp_true(order: int) -> Form:
    s_degree, mu_degree = TRUE_LOG_EXP_DEGREES[order]
    names = tuple(f"a{j}{k}" for j in range(s_degree + 1) for k in range(mu_degree + 1))
    coef = dict(zip(names, symbols(names)))
    fitted = (1 - s) * sum(coef[f"a{j}{k}"] * s**j * mu**k for j in range(s_degree + 1) for k in range(mu_degree + 1))
    kappa = true_grazing_shift(order)
    return Form(
        target=f"H{order}",
        name="log_exp_true",
        inputs=("mu", "c"),
        params=names,
        expr=log_exp(order, fitted, kappa),
        start={n: 0.0 for n in names},
        description=(
            f"H{order} = exp(mu ((Psi{order}(mu) + kappa c) log(1 + 1/mu) + c (p(mu) + (1 - s) sum_jk a_jk s^j mu^k))), "
            f"j <= {s_degree}, k <= {mu_degree}: log_exp with kappa = {float(kappa):.6g} (true_grazing_shift), so that "
            "the runtime structure has the true BRDF's grazing law, (H_i H_o - 1) Psi(0) ~ Psi_true(0)^2 "
            "(mu_i log(1/mu_i) + mu_o log(1/mu_o)), Psi_true the whole phase function's. H = 1 at mu = 0 and "
            "at c = 0. For the parts fitted to the true BRDF."
        ),
        refit_by_default=False,
    )


def _h2_unity() -> Form:
    return Form(
        target="H2",
        name="unity",
        inputs=("mu", "c"),
        params=(),
        expr=sp.S.One,
        presets={"paper": {}},
        description=(
            "H2 = 1: the paper's runtime model, which drops fm2 (eq. 21); with it fm2 = 15 c S^2 (H2 H2 - 1)/"
            "(256 pi (mu_i + mu_o)) is 0 identically. Exact at mu = 0 and c = 0 only."
        ),
        refit_by_default=False,
    )


FORMS = (_hapke(), _hapke_rational(), _h1_separable(), _h1_separable_printed(), *(_h_log_exp(n) for n in range(3)),
         *(_h_log_exp_true(n) for n in range(3)), _h2_unity())  # fmt: skip
