r"""What every form of the family is written with: the input symbols, the grazing-layer variables,
floors, and the complement that turns a form of E into a form of 1 - E.

Grazing-layer variables (GGX): with m = max(mu + alpha, GRAZING_FLOOR),

    u = min(1, mu / m),    v = min(1, alpha / m),

so that u = mu/(mu + alpha) and v = alpha/(mu + alpha) exactly, u + v = 1, wherever mu + alpha >= GRAZING_FLOOR
= 2^-126 (the smallest normal float32: every input pair a float32 shader holds as normal numbers), and u = v = 0
at the corner (0, 0).

For small alpha, E depends on mu through t = mu/alpha = u/v next to grazing (the layer of
:mod:`fitlab.families.microfacet_energy.targets.datasets`), and a polynomial in v and alpha follows that layer
where no polynomial in mu and alpha can: v = 1 at grazing (mu = 0, alpha > 0), v = 0 on the mirror line
alpha = 0, and at the corner itself v = 0, the mirror's value, the one the exact engine defines there.
Along any line mu = t alpha a form is therefore the same function of t for every alpha down to the floor
(v = 1/(1 + t)), and its limit as alpha -> 0 is its value at (v, alpha) = (1/(1 + t), 0): the exact
engine's limit to the fit's accuracy (tests/test_microfacet_energy_targets.py measures it).
v is written as alpha/m, not 1 - u, so that it keeps every digit when alpha << mu.  The min(1, .) is
what keeps the ratio one quantity: without it sympy writes v^4 as alpha^4/m^4, whose numerator and
denominator underflow in float32 for mu + alpha below about 1e-10 (0/0 in a shader); a power of
min(1, alpha/m) stays a power of a number in [0, 1].  The floor only decides the corner (0/0); a floor
large enough for m^4 to be a normal float32 (1e-8) would blend the corner's value with the layer's for
every mu + alpha below it.
"""

from __future__ import annotations

import itertools

import sympy as sp

from fitlab.forms import Form
from fitlab.forms.symbolic import symbols

__all__ = ["mu", "alpha", "GRAZING_FLOOR", "LOG_FLOOR", "u", "v", "safe_log", "complement", "monomials", "polynomial"]

mu, alpha = symbols(("mu", "alpha"))

#: the floor of mu + alpha in u and v: 2^-126, the smallest normal float32 (decides only the corner 0/0; u and v are
#: exact above it: module docstring)
GRAZING_FLOOR = sp.Float(2.0**-126)
#: the floor of the argument of a logarithm: x log(x) at x = 0 is 0 * (-69), i.e. 0, not 0 * (-inf) = nan
LOG_FLOOR = sp.Float("1e-30")

_m = sp.Max(mu + alpha, GRAZING_FLOOR)
u = sp.Min(1, mu / _m)
v = sp.Min(1, alpha / _m)


def safe_log(x) -> sp.Expr:
    """log(max(x, LOG_FLOOR)): finite at x = 0, where the forms multiply it by a power of x."""
    return sp.log(sp.Max(x, LOG_FLOOR))


def monomials(variables: dict, degree: int, constant: bool = True) -> dict:
    """label -> product of powers of ``variables`` (name -> expression) of total degree <= ``degree``
    (from 0 when ``constant``, else from 1), labelled by the exponents, e.g. "21" for v^2 alpha."""
    names = list(variables)
    out = {}
    for total in range(0 if constant else 1, degree + 1):
        for powers in itertools.product(range(total + 1), repeat=len(names)):
            if sum(powers) == total:
                out["".join(map(str, powers))] = sp.Mul(*(variables[n] ** p for n, p in zip(names, powers)))
    return out


def polynomial(prefix: str, terms: dict) -> tuple[tuple[str, ...], sp.Expr]:
    """(parameter names, sum of parameter * term) with parameters ``prefix + label``."""
    params = tuple(prefix + label for label in terms)
    return params, sp.Add(*(sp.Symbol(p, real=True) * t for p, t in zip(params, terms.values())))


def complement(form: Form, target: str) -> Form:
    """The form 1 - (``form``) of ``target`` (the 1 - E target of ``form``'s E target): same name,
    parameters, presets, start and fixed values; sympy cancels the 1 of forms written as 1 - (...).

    A published shape (a form with presets) is measured on the 1 - E target but not refit by ``fitlab refit
    --all``: shaped for E's absolute error, it stays far from 1 - E relatively wherever E is near 1, refit
    or not."""
    return Form(
        target=target,
        name=form.name,
        inputs=form.inputs,
        params=form.params,
        expr=1 - form.expr,
        presets=form.presets,
        start=form.start,
        fixed=form.fixed,
        description=f"1 - E with E = {form.description}",
        refit_by_default=form.refit_by_default and not form.presets,
    )
