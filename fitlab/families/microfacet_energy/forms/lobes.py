r"""Forms of the lobe-parameter targets (:mod:`..targets.lobes`), each one sympy expression, with the blog's published
expressions as presets.

Details: docs/blog_lobe_model.md, section ``fitlab.families.microfacet_energy.forms.lobes``."""

from __future__ import annotations

import sympy as sp

from fitlab.forms import Form
from fitlab.forms.symbolic import symbols

__all__ = [
    "alpha",
    "mu_i",
    "order",
    "lobe_forms",
    "BLOG_ETA",
    "BLOG_FLATTENING",
    "BLOG_SCALE",
    "SIGMA3_RATIO",
    "CODE_NORMALISATION",
    "blog_order_factor",
]

alpha, mu_i, order = symbols(("alpha", "mu_i", "order"))
#: the polynomials' variables in [-1, 1] on the domain: x in log(alpha) (the lobes' energy changes fastest at
#: small alpha: RMS 0.10 against 0.15 in 2 alpha - 1 for the blog's scale of diffuse facets), y, z linear
_x = 2 * sp.log(alpha / sp.Rational(1, 20)) / sp.log(20) - 1
_y, _z = 2 * mu_i - 1, (2 * order - 7) / sp.Integer(3)
_s_i = sp.sqrt(sp.Max(1 - mu_i**2, 0))

#: the blog's exponent eta(alpha) = e1 alpha + e2 alpha^2
BLOG_ETA = {
    "blog_text": {"e1": 2.5958, "e2": -1.32697},
    "blog_code": {"e1": 2.588380909161985, "e2": -1.3549594389004276},
}
#: the blog's normal flattening: a(alpha) + b(alpha) mu + c(alpha) mu^2 + d(alpha) mu^3, coefficients by power
BLOG_FLATTENING = {
    "blog_text": {
        "a": (0.9136430, -1.655480, 1.39617, -0.320331),
        "b": (0.0447239, 0.624740),
        "c": (-0.1188440, -0.973213, 0.36902),
        "d": (0.1325770, 0.169750, 0.0),
    },
    "blog_code": {
        "a": (0.8850557867448499, -1.2109761138443194, 0.22569832413951335, 0.4498256199595464),
        "b": (0.0856807009397115, 0.5659031384072539),
        "c": (-0.07707463071513312, -1.384614678037336, 0.8565888280926491),
        "d": (0.010423083821992304, 0.8525591060832015, -0.6844738691665317),
    },
}
#: the blog's scale sigma(mu, alpha) = a + b mu + c mu^2 + d mu^3, each cubic in alpha, as printed
BLOG_SCALE = {
    "blog_text": {
        "a": (0.02881326115, -0.92153748116, 6.63272611438, -4.595702230),
        "b": (-0.09663259042, 7.21414360220, -19.7868451171, 11.04205888),
        "c": (0.10935692546, -10.7904051575, 28.5080366763, -15.66525827),
        "d": (-0.04376425480, 5.24919600918, -13.5827073397, 7.348408854),
    },
    "blog_code": {
        "a": (0.028813261153483097, -0.9215374811620882, 6.632726114385572, -4.5957022306534),
        "b": (-0.09663259042197028, 7.214143602200921, -19.786845117100626, 11.042058883797509),
        "c": (0.10935692546815767, -10.790405157520944, 28.50803667636733, -15.665258273262731),
        "d": (-0.04376425480146207, 5.2491960091879, -13.582707339717146, 7.348408854602616),
    },
}
#: sigma_3 / sigma_2 (text and code)
SIGMA3_RATIO = 0.363902052363025
#: the code's scale relative to the text's: its lobe is twice the text's and its caller divides by pi
CODE_NORMALISATION = {"blog_text": 1.0, "blog_code": 2.0 / 3.141592653589793}


def _cubic_in_mu(prefix_degrees: dict, prefix: str = "") -> tuple[tuple[str, ...], sp.Expr]:
    """sum_j P_j(alpha) mu_i^j, P_j of the degree given for each of "a", "b", "c", "d" (j = 0..3)."""
    params, expr = [], sp.S.Zero
    for j, (name, degree) in enumerate(prefix_degrees.items()):
        for p in range(degree + 1):
            sym = sp.Symbol(f"{prefix}{name}{p}", real=True)
            params.append(sym.name)
            expr += sym * alpha**p * mu_i**j
    return tuple(params), expr


def _preset(coefficients: dict, prefix: str = "", scale: float = 1.0) -> dict:
    return {f"{prefix}{name}{p}": scale * v for name, vals in coefficients.items() for p, v in enumerate(vals)}


def blog_order_factor(k3, k4, k5) -> sp.Expr:
    """k(order) with k(2) = 1, k(3) = k3, k(4) = k4, k(5) = k5: Lagrange interpolation on the orders 2..5."""
    nodes = (2, 3, 4, 5)
    values = (1, k3, k4, k5)
    out = sp.S.Zero
    for n, v in zip(nodes, values):
        basis = sp.Mul(*((order - m) / sp.Integer(n - m) for m in nodes if m != n))
        out += v * basis
    return out


def _monomials(degree: int, with_order: bool) -> dict:
    """label -> monomial in (x, y[, z]): total degree <= degree in (x, y) times z^0, and for targets of the order
    z (degree - 1 in (x, y)) and z^2 (degree - 2)."""
    out = {}
    for kz in range(3 if with_order else 1):
        for total in range(degree - kz + 1):
            for i in range(total + 1):
                out[f"{i}{total - i}{kz}"] = _x**i * _y ** (total - i) * _z**kz
    return out


def _poly(prefix: str, degree: int, with_order: bool) -> tuple[tuple[str, ...], sp.Expr]:
    terms = _monomials(degree, with_order)
    params = tuple(prefix + k for k in terms)
    return params, sp.Add(*(sp.Symbol(p, real=True) * t for p, t in zip(params, terms.values())))


def _rich(target: str, kind_of_value: str, with_order: bool, start: float) -> Form:
    """The richer form of a target: ``poly`` (a polynomial), ``exp_poly`` (its exponential: positive) or
    ``sine_poly`` (s_i times a polynomial; ``sine2_poly``: s_i^2 times it), docs/blog_lobe_model.md."""
    params, p = _poly("c", 3, with_order)
    if kind_of_value == "positive":
        name, expr, what = "exp_poly", sp.exp(p), "exp(P)"
    elif kind_of_value == "odd":
        name, expr, what = "sine_poly", _s_i * p, "s_i P, s_i = sqrt(1 - mu_i^2) (0 at normal incidence)"
    elif kind_of_value == "even":
        name, expr, what = "sine2_poly", _s_i**2 * p, "s_i^2 P, s_i = sqrt(1 - mu_i^2) (0 at normal incidence)"
    else:
        name, expr, what = "poly", p, "P"
    order_text = (
        ", z = (2 order - 7)/3: degree <= 3 in (x, y), <= 2 with z, <= 1 with z^2"
        if with_order
        else ": total degree <= 3"
    )
    first = params[0]
    return Form(
        target=target,
        name=name,
        inputs=("alpha", "mu_i", "order") if with_order else ("alpha", "mu_i"),
        params=params,
        expr=expr,
        start={q: (start if q == first else 0.0) for q in params},
        description=f"{what}, P a polynomial in x = 2 log(20 alpha)/log(20) - 1, y = 2 mu_i - 1{order_text}",
    )


def lobe_forms(kind: str) -> tuple[Form, ...]:
    """Every form of the lobe-parameter targets of ``kind`` ("diffuse": with the blog's presets)."""
    presets = kind == "diffuse"
    out = []
    # the blog's final lobe: exponent, normal flattening (functions of alpha and mu_i), scale (and the order)
    t = f"ms_blog_eta_{kind}"
    e1, e2 = symbols(("e1", "e2"))
    out.append(
        Form(
            t,
            "blog_quadratic",
            ("alpha", "mu_i"),
            ("e1", "e2"),
            e1 * alpha + e2 * alpha**2,
            presets=BLOG_ETA if presets else {},
            start=None if presets else dict(BLOG_ETA["blog_text"]),
            description="the blog's eta(alpha) = e1 alpha + e2 alpha^2 (section 'Parameters Fitting'; text "
            "and code differ)",
        )
    )
    (p_sym,) = symbols(("p",))
    out.append(
        Form(
            t,
            "blog_exp2",
            ("alpha", "mu_i"),
            ("p",),
            2 ** (p_sym * (1 - alpha)) - 1,
            presets={"blog_text": {"p": 10.0}} if presets else {},
            start=None if presets else {"p": 10.0},
            description="the text's eta(alpha) = 2^(10 (1 - alpha)) - 1 read as a function of the surface's "
            "alpha (fitlab reads it as the lobe model's own exponent: docs/microsurface_lobes.md)",
            refit_by_default=False,
        )
    )
    out.append(_rich(t, "any", False, 0.5))
    t = f"ms_blog_flattening_{kind}"
    params, expr = _cubic_in_mu({"a": 3, "b": 1, "c": 2, "d": 2})
    fl = {k: _preset(v) for k, v in BLOG_FLATTENING.items()}
    out.append(
        Form(
            t,
            "blog_cubic",
            ("alpha", "mu_i"),
            params,
            expr,
            presets=fl if presets else {},
            start=None if presets else fl["blog_text"],
            description="the blog's sigma_n(mu, alpha) = a + b mu + c mu^2 + d mu^3, a cubic, b linear, c and "
            "d quadratic in alpha (the text's d is linear), mu = mu_i",
        )
    )
    out.append(_rich(t, "positive", False, 0.0))
    t = f"ms_blog_scale_{kind}"
    params, expr = _cubic_in_mu({"a": 3, "b": 3, "c": 3, "d": 3})
    k3, k4, k5 = symbols(("k3", "k4", "k5"))
    sc = {name: {**_preset(BLOG_SCALE[name], scale=CODE_NORMALISATION[name]), "k3": SIGMA3_RATIO, "k4": 0.0,
                 "k5": 0.0} for name in BLOG_SCALE}  # fmt: skip
    out.append(
        Form(
            t,
            "blog_cubic",
            ("alpha", "mu_i", "order"),
            (*params, "k3", "k4", "k5"),
            expr * blog_order_factor(k3, k4, k5),
            presets=sc if presets else {},
            start=None if presets else sc["blog_text"],
            description="the blog's sigma(mu, alpha) = a + b mu + c mu^2 + d mu^3, each cubic in alpha, mu = "
            "mu_i, times k(order): k(2) = 1, k(3) = k3, k(4) = k4, k(5) = k5 (Lagrange in the order); "
            "the blog has k3 = 0.363902052363025 and neglects higher orders (k4 = k5 = 0); the "
            "code's preset carries its normalisation 2/pi",
        )
    )
    out.append(_rich(t, "positive", True, -2.0))
    # the tilted lobe, every parameter a function of alpha, mu_i and the order
    for param, value_kind, start in (
        ("sigma", "positive", -2.0),
        ("eta", "any", 0.0),
        ("flattening", "positive", 0.0),
        ("b", "odd", 0.0),
        ("k", "even", 0.0),
    ):
        out.append(_rich(f"ms_tilt_{param}_{kind}", value_kind, True, start))
    return tuple(out)
