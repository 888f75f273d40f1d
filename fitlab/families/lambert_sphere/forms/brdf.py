r"""BRDF-level forms: single scattering, the fast fm1 (eq. 29), the fast
variant of the whole BRDF (eq. 41), and the runtime model (docs/model.md,
"The runtime BRDF") assembled
from the forms of H0, H1 and the constants.

Conventions (docs/model.md, "Conventions"): mu_i, mu_o in [0, 1], phi the
relative azimuth with
phi = 0 back-scattering, S = sqrt((1 - mu_i^2)(1 - mu_o^2)), f in 1/sr.  Every
term has the pole 1/(mu_i + mu_o); at mu_i = mu_o = 0 the exact BRDF is
infinite, and these expressions are not meant to be evaluated there.
"""

from __future__ import annotations

from collections.abc import Mapping

import sympy as sp
from sympy.codegen.cfunctions import expm1

from fitlab.families.lambert_sphere.forms.constants import E_EXACT, FIRST_ORDER
from fitlab.forms.form import Form
from fitlab.forms.symbolic import safe_pow, symbols
from fitlab.physics.lambert_sphere import phase_function, phase_function_forward

mu_i, mu_o, phi, c, kd, mu = symbols(("mu_i", "mu_o", "phi", "c", "kd", "mu"))
S = sp.sqrt((1 - mu_i**2) * (1 - mu_o**2))
PI = sp.pi

# scattering cosine, clamped so that rounding never takes it outside [-1, 1].  The clamps of this module are built
# unevaluated: sympy's evaluation of Max and Min tries to order their arguments (factor_terms on the whole
# expression), about a tenth of a second of every import of the family, and leaves these ones as they are
# (tests/test_forms.py)
_u = sp.Max(-1, sp.Min(1, -(mu_i * mu_o + S * sp.cos(phi)), evaluate=False), evaluate=False)
#: Lambert-sphere phase function p(u) (docs/model.md, "Phase function"; :func:`fitlab.physics.lambert_sphere.phase_function`)
PHASE = phase_function(_u)
#: exact single scattering with the true phase function (eq. 10)
SINGLE = c * PHASE / (mu_i + mu_o)

#: (1 - u)/2 = (1 + mu_i mu_o + S cos(phi))/2, from a sum of terms >= 0: 1 - u = (1 - S^2)/(1 + S) + mu_i mu_o +
#: S (1 + cos phi), 1 - S^2 = mu_i^2 + mu_o^2 (1 - mu_i^2); clamped to [0, 1] against rounding
_V = sp.Min(
    1,
    sp.Max(
        0, ((mu_i**2 + mu_o**2 * (1 - mu_i**2)) / (1 + S) + mu_i * mu_o + S * (1 + sp.cos(phi))) / 2, evaluate=False
    ),
    evaluate=False,
)
#: the phase function p(u) as a function of 1 - u (:data:`PHASE`, the same function,
#: :func:`fitlab.physics.lambert_sphere.phase_function_forward`): sqrt(1 - u^2) - u acos(u) = sin x - x cos x, x =
#: acos(u) from v = (1 - u)/2 with one asin, by its series in forward scattering, where the two terms agree to
#: 1 - O(x^2) and their difference, of order x^3/3, would keep eps/x^2 of its digits
PHASE_FORWARD = phase_function_forward(_V)
#: :data:`SINGLE` evaluated through :data:`PHASE_FORWARD`: what the runtime terms use (in forward scattering at
#: grazing 1 - u ~ (mu_i + mu_o)^2/2, which u itself, rounded to float, no longer resolves below mu ~ 1e-4)
SINGLE_FORWARD = c * PHASE_FORWARD / (mu_i + mu_o)

#: (mu_i + mu_o) times the three-term single scattering of orders 0 and 1
#: (eq. 38 and eq. 28 with 192 pi; docs/errata.md)
_P, _Q = mu_i * mu_o, mu_i**2 + mu_o**2
SINGLE_NUMERATOR_0 = c * (207 + 256 * _P - 45 * _Q + 135 * _P**2) / (768 * PI)
SINGLE_NUMERATOR_1 = c * S * (64 + 45 * _P) / (192 * PI)

#: normalisations of eqs. 22 and 28: as the exact solution has them, and as printed
NORMALISATIONS = {"corrected": (3, 1), "printed": (6, 2)}


def _fm1_fast() -> Form:
    (k,) = symbols(("k",))
    return Form(
        target="fm1",
        name="fast",
        inputs=("mu_i", "mu_o", "c"),
        params=("k",),
        expr=-k * c * sp.atan(c) * S * sp.sqrt(sp.tanh(mu_i + mu_i * mu_o + mu_o)) / (mu_i + mu_o),
        presets={"paper": dict(k=0.0117)},
        description="fm1 ~ -k c atan(c) S sqrt(tanh(mu_i + mu_i mu_o + mu_o))/(mu_i + mu_o) (eq. 29).",
    )


def _fm1_fast_general() -> Form:
    k1, k2, g, e = symbols(("k1", "k2", "g", "e"))
    return Form(
        target="fm1",
        name="fast_general",
        inputs=("mu_i", "mu_o", "c"),
        params=("k1", "k2", "g", "e"),
        expr=-(k1 + k2 * c)
        * c
        * sp.atan(c)
        * S
        * safe_pow(sp.tanh(g * (mu_i + mu_i * mu_o + mu_o)), e)
        / (mu_i + mu_o),
        start=dict(k1=0.0117, k2=0.0, g=1.0, e=0.5),
        description=(
            "fm1 ~ -(k1 + k2 c) c atan(c) S tanh(g (mu_i + mu_i mu_o + mu_o))^e/(mu_i + mu_o): eq. 29 with a "
            "linear factor in c, and the steepness and power of the tanh free."
        ),
    )


def _fast_brdf() -> Form:
    p1, p2, p3, p4, p5 = symbols(("p1", "p2", "p3", "p4", "p5"))
    # eq. 41's 1/(acos(S)/S + p3), multiplied through by S: finite at S = 0
    lobe = p1 * (c - p2) * (sp.Abs(phi) + sp.sqrt(mu_i * mu_o)) * S / (sp.acos(S) + p3 * S)
    return Form(
        target="fast_brdf",
        name="paper",
        inputs=("mu_i", "mu_o", "phi", "c", "kd"),
        params=("p1", "p2", "p3", "p4", "p5"),
        expr=sp.Max(0, SINGLE + lobe + p4 * safe_pow(kd, p5), evaluate=False),
        presets={"paper": dict(p1=0.0151829, p2=0.249978, p3=0.113706, p4=0.234459, p5=1.85432)},
        description=(
            "Fast variant (eq. 41): max(0, f_1 + p1 (c - p2)(|phi| + sqrt(mu_i mu_o))/(acos(S)/S + p3) "
            "+ p4 kd^p5), f_1 exact single scattering (true phase function), kd the material's spherical "
            "albedo for c; phi in [-pi, pi]."
        ),
    )


FORMS = (_fm1_fast(), _fm1_fast_general(), _fast_brdf())

#: the parts of the runtime model of orders 0 and 1 (the paper's, eqs. 11, 12, 21)
RUNTIME_PARTS = ("H0", "H1", "l", "m", "B", "C", "D", "F")
#: the part the second Fourier order adds: with it the runtime model is f_1 + fm0 + fm1 cos phi + fm2 cos 2phi
ORDER2_PART = "H2"


#: the terms of the runtime model, in the order they are summed (m2 only where the parts hold H2)
RUNTIME_TERMS = ("single", "m0", "m1", "m2")
#: the azimuthal factor of each term: f_r = max(0, sum_t term_t * AZIMUTH[t])
AZIMUTH = {"single": sp.S.One, "m0": sp.S.One, "m1": sp.cos(phi), "m2": sp.cos(2 * phi)}


def product_less_one(h_i: sp.Expr, h_o: sp.Expr) -> sp.Expr:
    r"""H(mu_i) H(mu_o) - 1 without cancellation where the form allows it: expm1(x_i + x_o) when both are
    exponentials exp(x) (the ``log_exp`` forms, the exported tables), else the product less 1.

    Why: H - 1 = O(c) and O(mu log(1/mu)) as mu -> 0; the product of two numbers near 1 less 1 keeps only
    eps/(H_i H_o - 1) of its value (float: all of it at c = 1e-4 or mu = 1e-6)."""
    if isinstance(h_i, sp.exp) and isinstance(h_o, sp.exp):
        return expm1(h_i.args[0] + h_o.args[0])
    return h_i * h_o - 1


def less_exactly(x: sp.Expr, y: sp.Expr) -> sp.Expr | None:
    r"""x - y with y cancelled in the algebra, or None where x does not hold y: y a term of x (X1 c + c^2 R(c)
    less X1 c is c^2 R(c), 1 + m1 c + ... less 1), or of the sum a product multiplies (c (X1 + r) less X1 c is
    c r, as the exported tables store the constants), or y = 0."""
    x, y = sp.S(x), sp.S(y)
    if y == 0:
        return x
    terms = sp.Add.make_args(sp.expand_mul(x, deep=False) if x.is_Mul else x)
    if y.is_Add or y not in terms:
        return None
    return sp.Add(*(t for t in terms if t != y))


#: the O(c) part of each quantity the multiple-scattering terms subtract, exactly: the single-scattering
#: numerators' coefficients (Q_ss = c (207 + 256 P - 45 (mu_i^2 + mu_o^2) + 135 P^2)/384: A - 207 c/384 = 0
#: and E - 135 c/384 are exact polynomials) and m = 1 + O(c)
_SUBTRACTED = {**{x: FIRST_ORDER[x] * c for x in "BCDF"}, "m": sp.S.One}


def parts_in_algebra(parts: Mapping[str, sp.Expr]) -> tuple[str, ...]:
    r"""The parts whose expressions, not just their values, :func:`runtime_terms` needs to keep every digit:
    an H of exponential form (H_i H_o - 1 = expm1 of the sum of exponents: :func:`product_less_one`), a
    constant whose O(c) part the terms subtract and that holds it exactly (C - 2c/3, F + 15c/128, m - 1:
    :func:`less_exactly`).  Generated code inlines these in the terms and calls the others' routines."""
    out = []
    for p, e in parts.items():
        if p in ("H0", "H1", ORDER2_PART):
            keep = isinstance(e, sp.exp)
        else:
            keep = p in _SUBTRACTED and _SUBTRACTED[p] != 0 and less_exactly(e, _SUBTRACTED[p]) is not None
        if keep:
            out.append(p)
    return tuple(out)


def _less(x: sp.Expr, y: sp.Expr) -> sp.Expr:
    """x - y, cancelled in the algebra where x holds y (:func:`less_exactly`), else in floating point."""
    exact = less_exactly(x, y)
    return x - y if exact is None else exact


def runtime_terms(parts: Mapping[str, sp.Expr], normalisation: str = "corrected") -> dict[str, sp.Expr]:
    r"""The terms of the runtime model, each an expression in (mu_i, mu_o, c) (single: and phi)
    (docs/model.md, "The runtime BRDF").

    Returns {"single": f_1 (:data:`SINGLE_FORWARD`), "m0": fm0, "m1": fm1} and, where ``parts`` holds H2, "m2": fm2, with
    f_r = max(0, f_1 + fm0 + fm1 cos(phi) [+ fm2 cos(2 phi)]):
      f_1 = c p(u) / (mu_i + mu_o)  (true phase function, eq. 10),
      fm0 = (H0(mu_i) H0(mu_o) Q / (2 pi) - n0_ss) / (mu_i + mu_o),
        Q = A + B (mu_i+mu_o) + C mu_i mu_o + D mu_i mu_o (mu_i+mu_o) + E mu_i^2 mu_o^2 + F (mu_i^2+mu_o^2),
      fm1 = (c H1(mu_i) H1(mu_o) S G/(k pi) - n1_ss/j) / (mu_i + mu_o),  G = 1 + l (mu_i+mu_o) + (l^2 + 45 m/64) mu_i mu_o,
      fm2 = 15 c S^2 (H2(mu_i) H2(mu_o) - 1) / (256 pi (mu_i + mu_o))  (docs/model.md, "Order 2"),
    A, E exact (eq. 33); ``parts`` maps H0, H1 (and H2) (expressions in mu, c) and l, m, B, C, D, F
    (in c) to expressions with numbers for parameters, or to calls of undefined
    functions (codegen prints those as calls of the parts' own routines).
    normalisation "corrected" uses k = 3, j = 1 (the exact solution); "printed"
    uses eqs. 22 and 28 as printed, k = 6 and 384 pi (j = 2), which halves fm1.
    fm2 vanishes at c = 0 and where H2 = 1, is reciprocal when H2 is one function of (mu, c), and
    is exact with the exact H2.

    Written without the cancellation of fm0 and fm1 as printed (whose two O(c) parts agree at mu -> 0 and to
    first order in c, so that float keeps none of their difference at grazing or small c):
      fm0 = ((H0_i H0_o - 1) Q + (Q - Q_ss)) / (2 pi (mu_i + mu_o)),  Q_ss = 2 pi n0_ss,
      fm1 = c S ((H1_i H1_o - 1) G + (G - G_ss)) / (k pi (mu_i + mu_o)),  G_ss = 1 + 45 mu_i mu_o/64
    (n1_ss/j = c S G_ss/(k pi) for both normalisations), H_i H_o - 1 by :func:`product_less_one` and
    Q - Q_ss = B (mu_i+mu_o) + (C - 2c/3) mu_i mu_o + D mu_i mu_o (mu_i+mu_o) + (E - 135c/384) mu_i^2 mu_o^2
    + (F + 15c/128)(mu_i^2+mu_o^2), G - G_ss = l (mu_i+mu_o) + (l^2 + 45 (m - 1)/64) mu_i mu_o, each difference
    cancelled in the algebra (:func:`less_exactly`) where the part holds its O(c) term exactly (the
    ``c2_rational_4_3`` and ``log_exp`` forms, the exported tables; :func:`parts_in_algebra`).  The same
    function as the printed one: the exact engine subtracts the same way
    (:class:`fitlab.families.lambert_sphere.exact.constants.ModePolynomials`).
    """
    missing = [p for p in RUNTIME_PARTS if p not in parts]
    if missing:
        raise KeyError(f"runtime model needs forms for {missing}")
    if normalisation not in NORMALISATIONS:
        raise ValueError(f"normalisation must be one of {sorted(NORMALISATIONS)}")
    k, _ = NORMALISATIONS[normalisation]
    sigma = mu_i + mu_o

    def pair(part):
        return product_less_one(*(parts[part].subs(mu, x) for x in (mu_i, mu_o)))

    ell, m = parts["l"], parts["m"]
    B, C, D, F = (_less(parts[n], _SUBTRACTED[n]) for n in "BCDF")
    # Q - Q_ss; A - 207 c/384 is 0
    dq = B * sigma + C * _P + D * _P * sigma + sp.expand(E_EXACT - sp.Rational(135, 384) * c) * _P**2 + F * _Q
    q_ss = 2 * PI * SINGLE_NUMERATOR_0
    fm0 = (pair("H0") * (q_ss + dq) + dq) / (2 * PI * sigma)
    g_ss = 1 + sp.Rational(45, 64) * _P
    dg = ell * sigma + (ell**2 + sp.Rational(45, 64) * _less(m, _SUBTRACTED["m"])) * _P
    fm1 = c * S * (pair("H1") * (g_ss + dg) + dg) / (k * PI * sigma)
    out = {"single": SINGLE_FORWARD, "m0": fm0, "m1": fm1}
    if ORDER2_PART in parts:
        s2 = (1 - mu_i**2) * (1 - mu_o**2)
        out["m2"] = 15 * c * s2 * pair(ORDER2_PART) / (256 * PI * sigma)
    return out


def runtime_sum(parts: Mapping[str, sp.Expr], normalisation: str = "corrected", terms=RUNTIME_TERMS) -> sp.Expr:
    r"""The runtime structure before its clamp and energy scale, an expression in (mu_i, mu_o, phi, c):
    f_1 + fm0 + fm1 cos(phi) [+ fm2 cos(2 phi)], the ``terms`` kept (those :func:`runtime_terms` gives)."""
    t = runtime_terms(parts, normalisation)
    return sum(t[n] * AZIMUTH[n] for n in terms if n in t)


def runtime_brdf(parts: Mapping[str, sp.Expr], normalisation: str = "corrected", scale=1) -> sp.Expr:
    r"""The runtime model (docs/model.md, "The runtime BRDF") as one expression in (mu_i, mu_o, phi, c):
    f_r = max(0, s (f_1 + fm0 + fm1 cos(phi) [+ fm2 cos(2 phi) where ``parts`` holds H2])), the terms of
    :func:`runtime_terms`; s = ``scale`` is the energy scale of fitted models (1 for the published ones;
    :func:`fitlab.families.lambert_sphere.program.runtime.energy_scale`)."""
    total = runtime_sum(parts, normalisation)
    # unevaluated: sympy would try to order 0 and the whole sum (factor it, ask its sign), seconds for nothing
    return sp.Max(0, total if scale == 1 else sp.Mul(scale, total, evaluate=False), evaluate=False)
