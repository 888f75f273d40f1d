r"""Candidate-term libraries: the shapes symbolic regression may combine.

A :class:`Library` describes a family of models for one target

    y = P + Q (n0 + sum_k a_k f_k) / (d0 + sum_j b_j g_j)

with P (the offset), Q (the factor), n0 and d0 (1 unless a library says
otherwise) fixed expressions that carry what is known exactly (H0(0, c) = 1,
kd(0) = 0, c(1) = 1, the exact single scattering of the BRDF), f_k the
numerator's candidate terms and g_j the denominator's (none: a linear model).
A target may have several libraries (:data:`LIBRARIES`); discover searches
them all and puts their candidates on one front.  Every term is a sympy
expression in the target's inputs, so a model sparse regression picks becomes
a :class:`fitlab.forms.Form` with no formula written twice.

The libraries of :data:`LIBRARIES` are products of a few "shape" factors per
input, chosen for what these functions are known to do:

* powers of s = sqrt(1 - c): the H-functions and constants are smooth in s,
  not in c (their expansions about c = 1 are in powers of s);
* L(mu) = mu log(1 + 1/mu): the first iterate of the H-equation is
  1 + (c/2) mu log((1 + mu)/mu) for isotropic scattering, so H - 1 has a
  mu log mu singularity at grazing that no power of mu reproduces (the
  published mu^d shape is why the paper's H0 is worst at small mu);
* sqrt(mu), and for the BRDF the pole 1/(mu_i + mu_o), the azimuthal factor
  S cos(phi), and log(mu_i + mu_o) (the exact f_r grows like log(1/mu) as
  mu_i = mu_o -> 0 at phi = pi, where single scattering vanishes; eq. 41's
  shapes cannot follow that).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import sympy as sp

from ..forms.brdf import SINGLE
from ..forms.symbolic import lambdify_numpy, symbols

__all__ = ["Library", "LIBRARIES", "get_library", "get_libraries", "products"]

mu, c, kd, mu_i, mu_o, phi = symbols(("mu", "c", "kd", "mu_i", "mu_o", "phi"))
s = sp.sqrt(1 - c)


@dataclass(frozen=True, eq=False)
class Library:
    """Candidate terms for y = offset + factor (n0 + sum a f) / (d0 + sum b g).

    name: the library's name (a target may have several).
    target: the fitlab target (fitlab.fit.targets) whose data it is fitted to.
    numerator, denominator: candidate terms by name; names are short labels
        used in tables ("c mu s").
    """

    name: str
    target: str
    inputs: tuple[str, ...]
    numerator: Mapping[str, sp.Expr]
    denominator: Mapping[str, sp.Expr] = field(default_factory=dict)
    offset: sp.Expr = sp.S.Zero
    factor: sp.Expr = sp.S.One
    n0: sp.Expr = sp.S.Zero
    d0: sp.Expr = sp.S.One  # the denominator's fixed term: its scale, which the linearisation must pin
    nonnegative: bool = False  # the model is max(0, ...): a BRDF must not go negative where a fit undershoots
    description: str = ""

    def __post_init__(self):
        allowed = set(symbols(self.inputs))
        for label, e in (*self.numerator.items(), *self.denominator.items(),
                         ("offset", self.offset), ("factor", self.factor), ("n0", self.n0),
                         ("d0", self.d0)):  # fmt: skip
            extra = sp.sympify(e).free_symbols - allowed
            if extra:
                raise ValueError(f"library {self.name}: {label} uses {sorted(map(str, extra))}, not inputs {self.inputs}")
        if not self.numerator:
            raise ValueError(f"library {self.name}: no numerator terms")

    @property
    def columns(self) -> tuple[tuple[str, str], ...]:
        """(part, label) of every column of the regression: numerator first."""
        return tuple(("num", k) for k in self.numerator) + tuple(("den", k) for k in self.denominator)

    def _numeric(self, exprs):
        f = lambdify_numpy(symbols(self.inputs), list(exprs))
        return f

    def evaluate(self, inputs: Mapping[str, np.ndarray]) -> dict:
        """Every term, offset, factor, n0 and d0 at the points ``inputs`` (name -> array)."""
        names = list(self.numerator) + [f"den:{k}" for k in self.denominator] + ["_offset", "_factor", "_n0", "_d0"]
        exprs = [*self.numerator.values(), *self.denominator.values(), self.offset, self.factor, self.n0, self.d0]
        xs = [np.asarray(inputs[n], dtype=float) for n in self.inputs]
        shape = np.broadcast_shapes(*(x.shape for x in xs))
        with np.errstate(all="ignore"):
            values = self._numeric(exprs)(*xs)
        out = {k: np.broadcast_to(np.asarray(v, dtype=float), shape) for k, v in zip(names, values)}
        bad = [k for k, v in out.items() if not np.all(np.isfinite(v))]
        if bad:
            raise ValueError(f"library {self.name}: terms {bad} are not finite on the data (fix the term or the data)")
        return out

    def model(self, num: Mapping[str, sp.Expr], den: Mapping[str, sp.Expr]) -> sp.Expr:
        """offset + factor (n0 + sum num[k] f_k) / (d0 + sum den[j] g_j): coefficients may be symbols or numbers."""
        n = self.n0 + sum((coef * self.numerator[k] for k, coef in num.items()), sp.S.Zero)
        d = self.d0 + sum((coef * self.denominator[k] for k, coef in den.items()), sp.S.Zero)
        return self.clamped(self.offset + self.factor * n / d)

    def clamped(self, expr: sp.Expr) -> sp.Expr:
        return sp.Max(0, expr) if self.nonnegative else expr


def products(*factor_sets: Mapping[str, sp.Expr], skip=()) -> dict[str, sp.Expr]:
    """All products of one factor from each set, labelled "a b" (a "1" factor drops out of the label)."""
    out = {}
    for combo in itertools.product(*(fs.items() for fs in factor_sets)):
        label = " ".join(k for k, _ in combo if k != "1") or "1"
        if label in skip:
            continue
        out[label] = sp.Mul(*(e for _, e in combo))
    return out


#: floor of mu in mu log(1 + 1/mu) and of mu_i + mu_o in log(mu_i + mu_o): written directly, both are
#: 0 * inf = nan at 0 (their limits are 0 and a finite floor); 1e-30 is a normal float, so the float C
#: back end keeps the floor too
LOG_FLOOR = sp.Float("1e-30")


def _mu_log(x):
    return x * sp.log(1 + 1 / sp.Max(x, LOG_FLOOR))


_S_POWERS = {"1": sp.S.One, "s": s, "s2": s**2}
_MU_SHAPES = {"mu": mu, "mu2": mu**2, "sqrt(mu)": sp.sqrt(mu), "L": _mu_log(mu), "mu L": mu * _mu_log(mu)}


def _h_library(target: str) -> Library:
    # every term carries the factor c, so that H = 1 at c = 0 exactly; every one vanishes at mu = 0 (H(0) = 1)
    terms = products({"c": c}, _MU_SHAPES, _S_POWERS)
    return Library(
        name="rational_mu_s",
        target=target,
        inputs=("mu", "c"),
        numerator=terms,
        denominator=terms,
        n0=sp.S.One,
        description=(
            f"{target} = (1 + c sum a_k m_k(mu) s^j)/(1 + c sum b_k m_k(mu) s^j), m in {{mu, mu^2, sqrt(mu), "
            "L = mu log(1 + 1/mu), mu L}, j in {0, 1, 2}: exact at mu = 0 and at c = 0"
        ),
    )


def _kd_of_c() -> Library:
    # kd = (1 - s) R(s), R(0) = 1: kd(0) = 0 and kd(1) = 1 exactly, as in the refitted eq. 40
    powers = {"s": s, "s2": s**2, "s3": s**3, "s4": s**4}
    return Library(
        name="rational_s",
        target="kd_of_c",
        inputs=("c",),
        numerator=powers,
        denominator=powers,
        factor=1 - s,
        n0=sp.S.One,
        description="kd = (1 - s)(1 + sum a_k s^k)/(1 + sum b_k s^k), k = 1..4: kd(0) = 0, kd(1) = 1",
    )


def _c_of_kd() -> Library:
    # c = kd R(kd): c(0) = 0 exactly; near kd = 1, 1 - c ~ (1 - kd)^2, which a rational in kd can follow
    t = 1 - kd
    shapes = {"kd": kd, "kd2": kd**2, "kd3": kd**3, "sqrt(1-kd)": sp.sqrt(t), "(1-kd)^(3/2)": t * sp.sqrt(t)}
    return Library(
        name="rational_kd",
        target="c_of_kd",
        inputs=("kd",),
        numerator={"1": sp.S.One, **shapes},
        denominator=shapes,
        factor=kd,
        description=(
            "c = kd (a_0 + sum a_k t_k)/(1 + sum b_k t_k), t in {kd, kd^2, kd^3, sqrt(1-kd), (1-kd)^(3/2)}: c(0) = 0"
        ),
    )


def _c_of_kd_ratio() -> Library:
    # c = kd N/(kd + sum b t^q), t = 1 - kd, every t^q and N - 1 vanishing at kd = 1: c(0) = 0 and
    # c(1) = 1 exactly. The denominator's fixed term is kd, not 1, so that kd/(kd + b t^2), one
    # parameter and five operations, is a single term (rational_kd needs three terms for it)
    t = 1 - kd
    powers = {"t^(1/2)": sp.sqrt(t), "t": t, "t^(3/2)": t * sp.sqrt(t), "t^2": t**2, "t^(5/2)": t**2 * sp.sqrt(t),
              "t^3": t**3}  # fmt: skip
    return Library(
        name="ratio_kd",
        target="c_of_kd",
        inputs=("kd",),
        numerator=powers,
        denominator=powers,
        factor=kd,
        n0=sp.S.One,
        d0=kd,
        description=(
            "c = kd (1 + sum a_k t^q_k)/(kd + sum b_k t^q_k), t = 1 - kd, q in {1/2, 1, 3/2, 2, 5/2, 3}: "
            "c(0) = 0, c(1) = 1"
        ),
    )


def _fast_brdf() -> Library:
    # f_r = f_1 (exact single scattering) + a linear model of the multiple scattering fm0 + fm1 cos phi
    sum_ = mu_i + mu_o
    S = sp.sqrt((1 - mu_i**2) * (1 - mu_o**2))
    albedo = {"c2": c**2, "c3": c**3, "kd": kd, "kd2": kd**2}
    angular = {
        "1": sp.S.One,
        "m": sum_,
        "p": mu_i * mu_o,
        "1/m": 1 / sum_,
        "p/m": mu_i * mu_o / sum_,
        "log m": sp.log(sp.Max(sum_, LOG_FLOOR)),
        "Scos": S * sp.cos(phi),
        "Scos/m": S * sp.cos(phi) / sum_,
        "Scos log m": S * sp.cos(phi) * sp.log(sp.Max(sum_, LOG_FLOOR)),
    }
    return Library(
        name="linear_ms",
        target="fast_brdf",
        inputs=("mu_i", "mu_o", "phi", "c", "kd"),
        numerator=products(albedo, angular),
        offset=SINGLE,
        nonnegative=True,
        description=(
            "f_r = f_1 + sum a_k g_k(c, kd) h_k(mu_i, mu_o, phi): f_1 exact single scattering (true phase function), "
            "g in {c^2, c^3, kd, kd^2}, h in {1, m, p, 1/m, p/m, log m, S cos phi, S cos phi/m, S cos phi log m}, "
            "m = mu_i + mu_o, p = mu_i mu_o"
        ),
    )


#: the libraries of each target; the first is its primary library (its forms' names carry no library tag)
LIBRARIES: dict[str, tuple[Library, ...]] = {
    "H0": (_h_library("H0"),),
    "H1": (_h_library("H1"),),
    "kd_of_c": (_kd_of_c(),),
    "c_of_kd": (_c_of_kd(), _c_of_kd_ratio()),
    "fast_brdf": (_fast_brdf(),),
}


def get_libraries(target: str) -> tuple[Library, ...]:
    if target not in LIBRARIES:
        raise KeyError(f"no discovery library for target {target!r}; targets: {', '.join(LIBRARIES)}")
    return LIBRARIES[target]


def get_library(target: str, name: str | None = None) -> Library:
    """The target's library called ``name``, or its primary library."""
    libs = get_libraries(target)
    if name is None:
        return libs[0]
    for lib in libs:
        if lib.name == name:
            return lib
    raise KeyError(f"no library {name!r} for {target}; libraries: {', '.join(lib.name for lib in libs)}")
