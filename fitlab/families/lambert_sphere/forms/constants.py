r"""Forms for the constants of the runtime model as functions of c in [0, 1].

l, m (eqs. 26-27) enter f^(1); B, C, D, F (eqs. 34-37) enter Q of f^(0).
A = 69c/128 and E (eq. 33) are exact closed forms and need no fit.
s = sqrt(1 - c).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from fitlab.forms.form import Form
from fitlab.forms.symbolic import symbols

(c,) = symbols(("c",))
s = sp.sqrt(1 - c)

#: the exact constants the runtime model needs besides the fitted ones
A_EXACT = sp.Rational(69, 128) * c
E_EXACT = sp.Rational(15, 128) * (1 - c) * c * (sp.Rational(4, 3) * c + 3)


def _l_forms():
    l1, l2, l3 = symbols(("l1", "l2", "l3"))
    quadratic = Form(
        target="l",
        name="quadratic",
        inputs=("c",),
        params=("l1", "l2"),
        expr=l1 * c + l2 * c**2,
        presets={
            "paper": dict(l1=-0.0589037, l2=-0.00473696),
            "renderer": dict(l1=-0.05890107167021953, l2=-0.004740543453386809),
        },
        description="l = l1 c + l2 c^2 (eq. 26); exact l(0) = 0.",
    )
    cubic = Form(
        target="l",
        name="cubic",
        inputs=("c",),
        params=("l1", "l2", "l3"),
        expr=l1 * c + l2 * c**2 + l3 * c**3,
        start=dict(l1=-0.0589037, l2=-0.00473696, l3=0.0),
        description="l = l1 c + l2 c^2 + l3 c^3: eq. 26 with one more power of c.",
    )
    return quadratic, cubic


def _m_forms():
    m1, m2 = symbols(("m1", "m2"))
    linear = Form(
        target="m",
        name="linear",
        inputs=("c",),
        params=("m1",),
        expr=1 + m1 * c,
        presets={"paper": dict(m1=0.44038), "renderer": dict(m1=0.44)},
        description="m = 1 + m1 c (eq. 27); exact m(0) = 1.",
    )
    quadratic = Form(
        target="m",
        name="quadratic",
        inputs=("c",),
        params=("m1", "m2"),
        expr=1 + m1 * c + m2 * c**2,
        start=dict(m1=0.44038, m2=0.0),
        description="m = 1 + m1 c + m2 c^2: eq. 27 with one more power of c.",
    )
    return linear, quadratic


# Printed coefficients of eqs. 34-37: numerator s^3..s^0, denominator s^2..s^0.
_PRINTED = {
    "B": ((0.346689, -0.777574, 0.515357, -0.084463), (0.182602, -0.665502, 0.964893)),
    "C": ((-5602.45, 7487.99, -2567.74, 682.848), (1480.25, -4008.33, 5850.6)),
    "D": ((166.883, -327.428, 160.397, 0.285529), (596.423, -412.984, 674.191)),
    "F": ((266.063, -21.9141, -242.16, -1.9209), (215.773, 457.42, 1499.9)),
}


def _printed(name: str) -> Form:
    n3, n2, n1, n0, d2, d1, d0 = symbols(("n3", "n2", "n1", "n0", "d2", "d1", "d0"))
    (p3, p2, p1, p0), (q2, q1, q0) = _PRINTED[name]
    return Form(
        target=name,
        name="printed",
        inputs=("c",),
        params=("n3", "n2", "n1", "n0", "d2", "d1", "d0"),
        expr=(n3 * s**3 + n2 * s**2 + n1 * s + n0) / (d2 * s**2 + d1 * s + d0),
        presets={"paper": dict(n3=p3, n2=p2, n1=p1, n0=p0, d2=q2, d1=q1, d0=q0)},
        fixed={"d0": q0},
        description=f"{name} = cubic/quadratic in s as printed (eqs. 34-37); nothing forces {name}(c=0) = 0.",
        refit_by_default=False,
    )


def _zero_at_c0_start(name: str, extra: int) -> dict:
    # The printed numerator, scaled to a unit denominator constant, divided by
    # (1 - s) with the remainder dropped: a start inside the constrained family.
    (p3, p2, p1, p0), (q2, q1, q0) = _PRINTED[name]
    num = np.array([p0, p1, p2, p3]) / q0
    quotient, _ = np.polynomial.polynomial.polydiv(num, np.array([1.0, -1.0]))
    start = {f"a{k}": float(v) for k, v in enumerate(quotient)}
    start.update(b1=q1 / q0, b2=q2 / q0)
    for k in range(extra):
        start[f"a{3 + k}"] = 0.0
        start[f"b{3 + k}"] = 0.0
    return start


def _rational(name: str, num_degree: int) -> Form:
    """(1 - s) * (polynomial of degree num_degree - 1) / (1 + b1 s + ... + b_{den} s^den), den = num_degree - 1."""
    den_degree = num_degree - 1
    a = symbols(tuple(f"a{k}" for k in range(num_degree)))
    b = symbols(tuple(f"b{k}" for k in range(1, den_degree + 1)))
    num = (1 - s) * sum(ak * s**k for k, ak in enumerate(a))
    den = 1 + sum(bk * s ** (k + 1) for k, bk in enumerate(b))
    return Form(
        target=name,
        name=f"rational_{num_degree}_{den_degree}",
        inputs=("c",),
        params=tuple(str(x) for x in a + b),
        expr=num / den,
        start=_zero_at_c0_start(name, num_degree - 3),
        description=(
            f"{name} = (1 - s) P(s)/R(s), degrees {num_degree}/{den_degree} in s, R(0) = 1: "
            + ("the printed cubic-over-quadratic shape (eqs. 34-37) " if num_degree == 3 else "a richer rational ")
            + f"with the exact limit {name}(c=0) = 0 built in."
        ),
    )


#: the O(c) coefficient of B, C, D, F, exactly: with H0 = 1 + O(c), f0 = H0 H0 Q/(2 pi (mu_i + mu_o)) equals the
#: order-0 single scattering f0_ss (eq. 38) to first order in c, so Q = 2 pi (mu_i + mu_o) f0_ss + O(c^2) =
#: c (207 + 256 mu_i mu_o - 45 (mu_i^2 + mu_o^2) + 135 mu_i^2 mu_o^2)/384 + O(c^2) (A and E agree to all orders)
FIRST_ORDER = {"B": sp.S.Zero, "C": sp.Rational(256, 384), "D": sp.S.Zero, "F": sp.Rational(-45, 384)}


def _c2_rational(name: str) -> Form:
    """X1 c + c^2 P(s)/R(s), P cubic, R cubic with R(0) = 1: exact at c = 0 and to first order in c."""
    a = symbols(tuple(f"a{k}" for k in range(4)))
    b = symbols(tuple(f"b{k}" for k in range(1, 4)))
    # P(s) and R(s) are written as polynomials in u = 1 - s = c/(1 + s) (no cancellation): a fit may put a
    # zero and a pole of P/R close to c = 0, where P(1) and R(1) are small differences of O(1) coefficients
    # that float arithmetic in s would lose; the coefficients in u are those differences, taken in double
    num = _in_u(a)
    den = _in_u((1, *b))
    return Form(
        target=name,
        name="c2_rational_4_3",
        inputs=("c",),
        params=tuple(str(x) for x in a + b),
        expr=FIRST_ORDER[name] * c + c**2 * num / den,
        start={str(x): 0.0 for x in a + b},
        description=(
            f"{name} = {FIRST_ORDER[name]} c + c^2 P(s)/R(s), P and R cubic in s, R(0) = 1: the O(c) term exact "
            "(Q = 2 pi (mu_i + mu_o) f0_ss + O(c^2)), so that the runtime fm0 = f0 - f0_ss is O(c^2) like the "
            "exact one and keeps its relative accuracy as c -> 0."
        ),
    )


def _in_u(coefficients) -> sp.Expr:
    """sum_k p_k s^k rewritten as sum_j q_j u^j with u = 1 - s = c/(1 + s): q_j = (-1)^j sum_k binom(k, j) p_k."""
    u = c / (1 + s)
    n = len(coefficients)
    return sum(
        (-1) ** j * sum(sp.binomial(k, j) * p for k, p in enumerate(coefficients) if k >= j) * u**j for j in range(n)
    )


def _constant_forms():
    out = []
    for name in ("B", "C", "D", "F"):
        out += [_printed(name), _rational(name, 3), _rational(name, 4), _c2_rational(name)]
    return out


FORMS = (*_l_forms(), *_m_forms(), *_constant_forms())
