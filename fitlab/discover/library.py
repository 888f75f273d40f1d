r"""Candidate-term libraries: the shapes symbolic regression may combine.

A :class:`Library` describes a family of models for one target

    y = P + Q (n0 + sum_k a_k f_k) / (d0 + sum_j b_j g_j)

with P (the offset), Q (the factor), n0 and d0 (1 unless a library says
otherwise) fixed expressions that carry what is known exactly (H0(0, c) = 1,
kd(0) = 0, c(1) = 1, the exact single scattering of the BRDF), f_k the
numerator's candidate terms and g_j the denominator's (none: a linear model).
A target may have several libraries (each family registers them, see
:func:`libraries_of`); discover searches them all and puts their candidates on one
front.  Every term is a sympy expression in the target's inputs, so a model sparse
regression picks becomes a :class:`fitlab.forms.Form` with no formula written twice.
"""

from __future__ import annotations

import abc
import itertools
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from fitlab.core import Capability, did_you_mean, offering
from fitlab.forms.symbolic import lambdify_numpy, symbols

__all__ = ["Library", "HasLibraries", "libraries_of", "get_library", "get_libraries", "products"]


@dataclass(frozen=True, eq=False)
class Library:
    """Candidate terms for y = offset + factor (n0 + sum a f) / (d0 + sum b g).

    name: the library's name (a target may have several).
    target: the name of the registered target whose data it is fitted to.
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
            extra = sp.sympify(e, strict=True).free_symbols - allowed
            if extra:
                raise ValueError(
                    f"library {self.name}: {label} uses {sorted(map(str, extra))}, not inputs {self.inputs}"
                )
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


class HasLibraries(Capability):
    """A family whose targets ``fitlab discover`` searches."""

    noun = "discovery libraries"

    @abc.abstractmethod
    def libraries(self) -> Mapping[str, tuple[Library, ...]]:
        """target -> its libraries, the first its primary one (pysindy loads only when discover calls this)."""


def libraries_of() -> dict[str, tuple[Library, ...]]:
    """target -> its libraries, over every family that has them (the first of each is its primary library)."""
    out = {}
    for family in offering(HasLibraries).values():
        out.update(family.libraries())
    return out


def get_libraries(target: str) -> tuple[Library, ...]:
    libraries = libraries_of()
    if target not in libraries:
        raise KeyError(f"no discovery library for target {target!r}{did_you_mean(target, libraries)}")
    return libraries[target]


def get_library(target: str, name: str | None = None) -> Library:
    """The target's library called ``name``, or its primary library."""
    libs = get_libraries(target)
    if name is None:
        return libs[0]
    for lib in libs:
        if lib.name == name:
            return lib
    raise KeyError(f"no library {name!r} for {target}; libraries: {', '.join(lib.name for lib in libs)}")
