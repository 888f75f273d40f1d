r"""Forms of E_avg(alpha) = 2 int_0^1 E(mu) mu dmu (Kulla-Conti's normalisation, in [0, 1]), alpha in [0, 1].

Published approximations:

* ``patapom_quartic``: Patapom (Benoit Mayaux), "MSBRDF Energy Compensation" (blog; Patapom/webgl,
  Web/blog/patapom/docs/BRDF/MSBRDFEnergyCompensation.md; no licence found, so only the formula is
  cited): E_avg_blog(alpha) = pi - 0.446898 alpha - 5.72019 alpha^2 + 6.61848 alpha^3 - 2.41727 alpha^4 for
  GGX (his BRDF has separable Smith) and pi - 7.49231 alpha^2 + 11.4409 alpha^3 - 5.05903 alpha^4 for
  Oren-Nayar (0.33, sigma = (pi/2) alpha).  His E_avg is int E mu dw = pi times Kulla-Conti's, so the
  form is his divided by pi: 1 + (p1 alpha + p2 alpha^2 + p3 alpha^3 + p4 alpha^4)/pi (pi/pi = 1 exactly).
* ``patapom_zonal``: the same blog, part 2 (MSBRDFEnergyCompensation2.md), fits the zonal-harmonic
  coefficient E0 of 1 - E: E0 = -0.017923 alpha^(1/2) + 1.056128 alpha^(3/2) - 0.486550 alpha^(5/2) (GGX) and
  -0.09196 alpha^(1/2) + 1.46704 alpha^(3/2) - 1.67354 alpha^(5/2) + 0.60780 alpha^(7/2) (Oren-Nayar).  Read as
  the constant zonal coefficient of (1 - E(mu)) mu on the hemisphere (the reading of the research note
  /tmp/kc_approximations.md, an inference: the blog's definition was not re-derived here),
  E0 = Y00 2 pi int_0^1 (1 - E) mu dmu = Y00 pi (1 - E_avg), Y00 = 1/(2 sqrt(pi)), so
  E_avg = 1 - 2 E0/sqrt(pi) (the note writes 1 - E0/0.886227, 0.886227 = sqrt(pi)/2 rounded).
* ``karis_linear``: Karis's EnvBRDFApprox at F0 = F90 = 1 (:mod:`.ggx`) has no dependence on mu, so it
  is its own average: a baseline for GGX.

Richer forms:

* ``log_rational`` (GGX): E_avg = 1 - alpha^2 (c0 + c1 log(alpha) + c2 alpha + c3 alpha^2)/(1 + d1 alpha + d2 alpha^2).
  The logarithm is the grazing layer's: 1 - E tends to a function of t = mu/alpha decaying like 1/t^2
  (:mod:`fitlab.families.microfacet_energy.targets.datasets`), whose integral against 2 mu dmu over
  mu in (0, 1] is alpha^2 (C log(1/alpha) + O(1)).  Starts from E_avg = 1 - alpha^2.
* ``a_plus_kappa_b`` (Oren-Nayar): E_avg = A(sigma) + kappa B(sigma) exactly (:mod:`.oren_nayar`: the
  identity E = A + B g gives kappa = 2 int g mu dmu); one parameter, started at kappa = 1/2 = g(0).
* ``rational_alpha2`` (Oren-Nayar): (1 + a1 alpha^2 + a2 alpha^4)/(1 + b1 alpha^2 + b2 alpha^4): A + kappa B is
  a rational of this degree in sigma^2, so the form holds the exact E_avg; starts from 1 (Lambert).
"""

from __future__ import annotations

import sympy as sp

from fitlab.families.microfacet_energy.forms.common import alpha, safe_log
from fitlab.families.microfacet_energy.forms.ggx import karis_linear
from fitlab.families.microfacet_energy.forms.oren_nayar import A_ON, B_ON
from fitlab.forms import Form

__all__ = [
    "PATAPOM_GGX",
    "PATAPOM_ON",
    "PATAPOM_ZONAL_GGX",
    "PATAPOM_ZONAL_ON",
    "average_forms",
    "patapom_quartic",
    "patapom_zonal",
    "log_rational",
    "a_plus_kappa_b",
    "rational_alpha2",
]

#: Patapom's quartics (Patapom/webgl Web/blog/patapom/docs/BRDF/MSBRDFEnergyCompensation.md, no licence found:
#: the formula cited), the coefficients of alpha^k in his pi-normalised E_avg
PATAPOM_GGX = {"p1": -0.446898, "p2": -5.72019, "p3": 6.61848, "p4": -2.41727}
PATAPOM_ON = {"p2": -7.49231, "p3": 11.4409, "p4": -5.05903}
#: Patapom's zonal-harmonic E0 fits (the same blog, MSBRDFEnergyCompensation2.md), coefficients of alpha^(k/2), k odd
PATAPOM_ZONAL_GGX = {"z1": -0.017923, "z3": 1.056128, "z5": -0.486550}
PATAPOM_ZONAL_ON = {"z1": -0.09196, "z3": 1.46704, "z5": -1.67354, "z7": 0.60780}


def patapom_quartic(target: str, coefficients: dict, published: bool) -> Form:
    params = tuple(coefficients)
    expr = 1 + sp.Add(*(sp.Symbol(p, real=True) * alpha ** int(p[1:]) for p in params)) / sp.pi
    return Form(
        target=target,
        name="patapom_quartic",
        inputs=("alpha",),
        params=params,
        expr=expr,
        presets={"patapom": dict(coefficients)} if published else {},
        start=None if published else dict(coefficients),
        description=(
            "Patapom's E_avg quartic divided by pi: 1 + ("
            + " + ".join(f"{p} alpha^{p[1:]}" for p in params)
            + ")/pi"
            + ("" if published else "; starts from his coefficients, fitted to separable Smith")
        ),
    )


def patapom_zonal(target: str, coefficients: dict) -> Form:
    params = tuple(coefficients)
    e0 = sp.Add(*(sp.Symbol(p, real=True) * alpha ** sp.Rational(int(p[1:]), 2) for p in params))
    return Form(
        target=target,
        name="patapom_zonal",
        inputs=("alpha",),
        params=params,
        expr=1 - 2 * e0 / sp.sqrt(sp.pi),
        presets={"patapom": dict(coefficients)},
        description=(
            "Patapom's zonal-harmonic fit E0 = "
            + " + ".join(f"{p} alpha^({p[1:]}/2)" for p in params)
            + " of 1 - E, as E_avg = 1 - E0/(Y00 pi) = 1 - 2 E0/sqrt(pi)"
        ),
        refit_by_default=False,  # the second published shape; its refit is on request
    )


def log_rational(target: str) -> Form:
    c0, c1, c2, c3, d1, d2 = sp.symbols(("c0", "c1", "c2", "c3", "d1", "d2"), real=True)
    return Form(
        target=target,
        name="log_rational",
        inputs=("alpha",),
        params=("c0", "c1", "c2", "c3", "d1", "d2"),
        expr=1 - alpha**2 * (c0 + c1 * safe_log(alpha) + c2 * alpha + c3 * alpha**2) / (1 + d1 * alpha + d2 * alpha**2),
        start={"c0": 1.0, "c1": 0.0, "c2": 0.0, "c3": 0.0, "d1": 0.0, "d2": 0.0},
        description=(
            "1 - alpha^2 (c0 + c1 log(alpha) + c2 alpha + c3 alpha^2)/(1 + d1 alpha + d2 alpha^2): the grazing layer "
            "gives 1 - E_avg an alpha^2 log(1/alpha) term"
        ),
    )


def a_plus_kappa_b(target: str) -> Form:
    kappa = sp.Symbol("kappa", real=True)
    return Form(
        target=target,
        name="a_plus_kappa_b",
        inputs=("alpha",),
        params=("kappa",),
        expr=A_ON + kappa * B_ON,
        start={"kappa": 0.5},
        description="A(sigma) + kappa B(sigma), A, B the exact Oren-Nayar coefficients, sigma = (pi/2) alpha: exact "
        "for kappa = 2 int_0^1 g(mu) mu dmu",
    )


def rational_alpha2(target: str) -> Form:
    a1, a2, b1, b2 = sp.symbols(("a1", "a2", "b1", "b2"), real=True)
    return Form(
        target=target,
        name="rational_alpha2",
        inputs=("alpha",),
        params=("a1", "a2", "b1", "b2"),
        expr=(1 + a1 * alpha**2 + a2 * alpha**4) / (1 + b1 * alpha**2 + b2 * alpha**4),
        start={"a1": 0.0, "a2": 0.0, "b1": 0.0, "b2": 0.0},
        description="(1 + a1 alpha^2 + a2 alpha^4)/(1 + b1 alpha^2 + b2 alpha^4): holds A + kappa B exactly",
    )


def average_forms(target: str, model: str) -> tuple[Form, ...]:
    """Every form of the E_avg target ``target`` of ``model``."""
    if model == "ggx_separable":
        return (
            patapom_quartic(target, PATAPOM_GGX, True),
            patapom_zonal(target, PATAPOM_ZONAL_GGX),
            karis_linear(target, ("alpha",)),
            log_rational(target),
        )
    if model == "ggx_correlated":
        return (patapom_quartic(target, PATAPOM_GGX, False), karis_linear(target, ("alpha",)), log_rational(target))
    return (
        patapom_quartic(target, PATAPOM_ON, True),
        patapom_zonal(target, PATAPOM_ZONAL_ON),
        a_plus_kappa_b(target),
        rational_alpha2(target),
    )
