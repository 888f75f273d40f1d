r"""Forms of the sampler's mixture parameters (docs/model.md, "Importance sampling"): the weight w and
the exponent n of the back-scatter lobe as functions of (mu_i, c), mu_i and c in [0, 1].

s = sqrt(1 - c) as in every Lambert-sphere form (the optimum changes fastest near c = 1), and
t = 2 acos(mu_i)/pi, the incidence angle over a right angle: the optimum moves fast near normal incidence
(within mu_i in [0.99, 1], where t is still in [0, 0.09]), so a polynomial in t follows it where one in
mu_i cannot (on the validation table, degrees (4, 6): RMS relative error 2.7 % against 8.4 % for the
weight).  The weight lies in (0, 1) and the exponent is positive for every parameter vector: a logistic
and an exponential of a polynomial in (s, t), written in the centred variables 2s - 1 and 2t - 1: the
same fit in powers of s and t has coefficients up to 3.5e4 that cancel to O(1) (float32 loses the third
digit of w), in centred powers they stay below 4.
"""

from __future__ import annotations

import sympy as sp

from fitlab.forms.form import Form
from fitlab.forms.symbolic import symbols

mu_i, c = symbols(("mu_i", "c"))
s = sp.sqrt(1 - c)
t = 2 * sp.acos(mu_i) / sp.pi

#: (degree in s, degree in t) of the polynomials
DEGREES = {"sample_weight": (4, 6), "sample_exponent": (4, 6)}


def _mixture_form(target: str, name: str, link, link_text: str, start: float, bound: str) -> Form:
    """``link(P)``, P = sum_jk a_jk (2s - 1)^j (2t - 1)^k, degrees :data:`DEGREES` [target]; a00 starts at ``start``."""
    s_degree, mu_degree = DEGREES[target]
    names = tuple(f"a{j}{k}" for j in range(s_degree + 1) for k in range(mu_degree + 1))
    coef = dict(zip(names, symbols(names)))
    x, y = 2 * s - 1, 2 * t - 1
    p = sum(coef[f"a{j}{k}"] * x**j * y**k for j in range(s_degree + 1) for k in range(mu_degree + 1))
    return Form(
        target=target,
        name=name,
        inputs=("mu_i", "c"),
        params=names,
        expr=link(p),
        start={n: (start if n == "a00" else 0.0) for n in names},
        description=(
            f"{link_text}, P = sum_jk a_jk (2s - 1)^j (2t - 1)^k, t = 2 acos(mu_i)/pi, j <= {s_degree}, "
            f"k <= {mu_degree}: {bound} for every parameter vector"
        ),
    )


FORMS = (
    _mixture_form(
        "sample_weight", "logistic_poly", lambda p: 1 / (1 + sp.exp(-p)), "w = 1/(1 + exp(-P))", -1.0, "in (0, 1)"
    ),
    _mixture_form("sample_exponent", "exp_poly", sp.exp, "n = exp(P)", 1.0, "positive"),
)
