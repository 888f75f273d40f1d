r"""The Lambert sphere's rewrites of its generated program: ``sympy.codegen.rewriting`` optimisations that
know the family's symbols (mu_i, mu_o, phi, c, cos_phi), moved here from the generic code generator.

* :data:`REWRITES`: the cancellation-free rewrites of every routine of the family's program
  (:attr:`fitlab.codegen.ProgramSpec.rewrites` of :data:`fitlab.families.lambert_sphere.program.spec.PROGRAM`,
  applied by :func:`fitlab.codegen.part_routine` to every part and by the program to its terms): the
  generic ones of :data:`fitlab.codegen.STABLE` with :data:`ALBEDO_ZERO` between them, in the
  order the program has always applied them (:func:`stable`).
* :data:`FLOOR_POLES` (every pole 1/(mu_i + mu_o) floored at :data:`POLE_FLOOR`) and
  :data:`AZIMUTH_TO_COSINE` (phi -> cos phi): the runtime terms' and the fast variant's, applied by the
  program where it builds them (:func:`floor_poles`, :func:`azimuth_to_cosine`).
"""

from __future__ import annotations

import sympy as sp
from sympy.codegen.rewriting import Optimization, ReplaceOptim, optimize

from fitlab.codegen import ONE_MINUS_POW, ONE_MINUS_SQUARES, SumSubsOptim, rebuilt
from fitlab.forms.symbolic import symbols

__all__ = ["POLE_FLOOR", "ALBEDO_ZERO", "FLOOR_POLES", "AZIMUTH_TO_COSINE", "REWRITES", "stable", "floor_poles",
           "azimuth_to_cosine"]  # fmt: skip

#: mu_i + mu_o is floored at this value wherever it divides
POLE_FLOOR = sp.Rational(1, 10**6)

mu_i, mu_o, phi, c, cos_phi = symbols(("mu_i", "mu_o", "phi", "c", "cos_phi"))

_S = sp.sqrt(1 - c)
#: 1 - sqrt(1 - c) -> c / (1 + sqrt(1 - c)): the exact zero at c = 0 of B-F and kd(c); written directly it
#: loses all relative accuracy as c -> 0 (float: 1 % at c = 1e-5)
ALBEDO_ZERO = SumSubsOptim(1 - _S, c / (1 + _S))

#: 1/(mu_i + mu_o)^k -> 1/max(mu_i + mu_o, POLE_FLOOR)^k
FLOOR_POLES = ReplaceOptim(
    lambda e: e.is_Pow and e.base == mu_i + mu_o and e.exp.is_negative,
    lambda e: sp.Pow(sp.Max(mu_i + mu_o, POLE_FLOOR), e.exp),
)


class _AzimuthToCosine(Optimization):
    """Forms take phi in [-pi, pi]; routines take cos(phi): |phi| = acos(cos phi).  ValueError when phi
    remains (a form that is not a function of cos phi alone).

    Both are whole nodes, swapped in one pass over the tree (:func:`fitlab.codegen.rebuilt`), which
    gives what ``subs`` gives in a fraction of its time on the large runtime terms."""

    def __init__(self, mapping, **kwargs):
        super().__init__(**kwargs)
        self.mapping = mapping

    def __call__(self, expr):
        out = rebuilt(expr, lambda e: self.mapping.get(e, e))
        if phi in out.free_symbols:
            raise ValueError(f"cannot express {expr} through cos(phi) alone")
        return out


#: phi -> cos phi: cos(phi) -> cos_phi, |phi| -> acos(cos_phi)
AZIMUTH_TO_COSINE: Optimization = _AzimuthToCosine({sp.cos(phi): cos_phi, sp.Abs(phi): sp.acos(cos_phi)})

#: the rewrites of every routine of the program, in order (:attr:`fitlab.codegen.ProgramSpec.rewrites`)
REWRITES: tuple[Optimization, ...] = (ONE_MINUS_SQUARES, ALBEDO_ZERO, ONE_MINUS_POW)


def stable(expr: sp.Expr) -> sp.Expr:
    """``expr`` with the program's cancellation-free rewrites (:data:`REWRITES`) applied, in order."""
    return optimize(expr, REWRITES)


def floor_poles(expr: sp.Expr) -> sp.Expr:
    """1/(mu_i + mu_o)^k -> 1/max(mu_i + mu_o, POLE_FLOOR)^k (:data:`FLOOR_POLES`)."""
    return FLOOR_POLES(expr)


def azimuth_to_cosine(expr: sp.Expr) -> sp.Expr:
    """Forms take phi in [-pi, pi]; routines take cos(phi): |phi| = acos(cos phi) (:data:`AZIMUTH_TO_COSINE`)."""
    return AZIMUTH_TO_COSINE(expr)
