r"""What every form of the family is written with: the input symbols, the grazing-layer variables,
floors, and the complement that turns a form of E into a form of 1 - E.

Grazing-layer variables (GGX): with m = max(mu + alpha, GRAZING_FLOOR),

    u = mu / m,    v = alpha / m,    u + v = 1 where mu + alpha >= GRAZING_FLOOR; u = v = 0 at (0, 0).

For small alpha, E depends on mu through t = mu/alpha = u/v next to grazing (the layer of
:mod:`fitlab.families.microfacet_energy.datasets`), and a polynomial in v and alpha follows that layer
where no polynomial in mu and alpha can: v = 1 at grazing (mu = 0, alpha > 0), v = 0 on the mirror line
alpha = 0, and at the corner itself v = 0, the mirror's value, the one the exact engine defines there.
v is written as alpha/m, not 1 - u, so that it keeps every digit when alpha << mu.  The floor only
decides the corner (0/0).  Its fourth power (v^4 = alpha^4/m^4 in the quartic forms) must be a normal
float32 too, or the corner is 0/0 in a shader: 1e-8 (1e-32 > 1.2e-38).  Below mu + alpha = 1e-8 (a
mirror for every purpose) u and v are no longer complementary and blend the corner's value with the
layer's.
"""

from __future__ import annotations

import itertools

import sympy as sp

from fitlab.forms import Form
from fitlab.forms.symbolic import symbols

__all__ = ["mu", "alpha", "GRAZING_FLOOR", "LOG_FLOOR", "u", "v", "safe_log", "complement", "monomials", "polynomial"]

mu, alpha = symbols(("mu", "alpha"))

#: the floor of mu + alpha in u and v (decides the corner 0/0; its 4th power is a normal float32: module docstring)
GRAZING_FLOOR = sp.Float("1e-8")
#: the floor of the argument of a logarithm: x log(x) at x = 0 is 0 * (-69), i.e. 0, not 0 * (-inf) = nan
LOG_FLOOR = sp.Float("1e-30")

_m = sp.Max(mu + alpha, GRAZING_FLOOR)
u = mu / _m
v = alpha / _m


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
