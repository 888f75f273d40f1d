r"""The NaN and domain policy of generated code, kept once for every language: :func:`with_domain` clamps every
routine's inputs into its :attr:`fitlab.codegen.Routine.domain`, and the printers print every Max and Min
through :func:`minmax_piecewise` and safe_pow from :data:`SAFE_POW`, so that NaN in any input gives NaN, +-inf
and other out-of-domain inputs are clamped, and every other input gives a finite value.
"""

from __future__ import annotations

from dataclasses import replace
from typing import cast

import sympy as sp

from fitlab.codegen._model import Routine, symbols_of

__all__ = ["clamp", "clamped", "minmax_piecewise", "SAFE_POW", "with_domain", "unused_inputs"]

# ---- the NaN and domain policy ------------------------------------------------
#
# One policy, the same in every language, because every language prints the same
# symbolic definitions below:
#
# * NaN in any input propagates: the result is NaN.
# * A finite input outside its routine's domain, and +-inf, is clamped into the
#   domain (Routine.domain: mu, c, kd to [0, 1], cos_phi to [-1, 1]).
# * Hence every routine is finite for every input that is not NaN.
#
# Max and Min are printed in every language as :func:`minmax_piecewise`, a
# conditional that returns its non-constant argument when a comparison is false,
# so a NaN passes through (C's fmax/fmin and GLSL's max/min would drop it, numpy's
# maximum would keep it: the three languages would disagree).  The safe_pow
# helper is printed from :data:`SAFE_POW` (NaN in, NaN out).


def clamp(x, lo, hi) -> sp.Expr:
    """min(hi, max(lo, x)): printed through :func:`minmax_piecewise`, so NaN stays NaN and +-inf clamps."""
    return sp.Min(hi, sp.Max(lo, x))


def clamped(*names_and_bounds) -> dict:
    """{symbol: clamp(symbol, lo, hi)} for (symbol, lo, hi) triples."""
    return {s: clamp(s, lo, hi) for s, lo, hi in names_and_bounds}


def minmax_piecewise(expr) -> sp.Expr:
    """The one definition of Max and Min in generated code, with NaN propagating.

    * Max(x, k1, k2, ...), numbers k and one other argument x: Piecewise((k, x < k), (x, True)),
      k = max(k1, k2, ...) (Min likewise with x > k).  A NaN x fails the comparison and is returned.
    * Max(a, b), neither a number: Piecewise((b, a < b), (a, a >= b), (a + b, True)): both comparisons
      fail only when a or b is NaN, and then a + b is NaN (Min likewise).
    * Anything else (more arguments) is a ValueError: :mod:`fitlab.codegen.languages` splits it into pairs,
      each in a temporary, before printing.
    """
    is_max = isinstance(expr, sp.Max)
    if not is_max and not isinstance(expr, sp.Min):
        raise TypeError(f"{expr} is not a Max or Min")
    args = cast("tuple[sp.Expr, ...]", expr.args)  # a Max's or Min's arguments are expressions
    consts = [a for a in args if a.is_number]
    others = [a for a in args if not a.is_number]
    if len(others) == 1 and consts:
        (x,) = others
        k = (sp.Max if is_max else sp.Min)(*consts)
        return sp.Piecewise((k, x < k if is_max else x > k), (x, True))
    if len(others) == 2 and not consts:
        a, b = others
        beats, holds = (a < b, a >= b) if is_max else (a > b, a <= b)
        return sp.Piecewise((b, beats), (a, holds), (a + b, True), evaluate=False)
    raise ValueError(f"{expr}: print max/min of more than two expressions as pairs (NaN policy; emit splits them)")


_x, _p = sp.Symbol("x", real=True), sp.Symbol("p", real=True)
_not_positive = _x <= 0
#: the generated safe_pow helper: x^p for x > 0, 0 for x <= 0, NaN for NaN (the comparison fails);
#: the inner conditional keeps pow away from x <= 0 where every branch is evaluated (numpy)
SAFE_POW = sp.Piecewise(
    (0, _not_positive), (sp.Pow(sp.Piecewise((1, _not_positive), (_x, True)), _p, evaluate=False), True)
)


def with_domain(routine: Routine) -> Routine:
    """``routine`` with every input clamped into its domain (:attr:`Routine.domain`) at entry."""
    missing = [a for a in routine.args if a not in routine.domain]
    if missing:
        raise ValueError(f"routine {routine.name}: no domain for {', '.join(missing)} (Routine.domain)")
    by_name = {s.name: s for s in symbols_of(routine.expr)}
    subs = {by_name[a]: clamp(by_name[a], *routine.domain[a]) for a in routine.args if a in by_name}
    # evaluated, unlike a table export's (the Lambert sphere's program.table_export): what sympy makes of the
    # Max, Min, products and powers the clamped inputs reach (min(1/2, min(1, x)) -> min(1/2, x),
    # sqrt(a b) -> sqrt(a) sqrt(b) for a, b >= 0, ...) is part of what the committed files print
    return replace(routine, expr=routine.expr.xreplace(subs))


def unused_inputs(routine: Routine) -> list[sp.Expr]:
    """Every scalar argument of ``routine`` that its expression does not use (a vector's components
    excepted), clamped into its domain: ``clamp(x, lo, hi)``.  The emitters add 0 times each to the routine's
    value, in every language, so that such an input follows the NaN and domain policy like any other: NaN
    gives NaN, and +-inf, clamped first, adds exactly 0 (0 times the bare input is NaN at +-inf; the blog's
    lobe exponent eta(alpha) takes mu_i and does not use it)."""
    used = {s.name for s in symbols_of(routine.expr)}
    parts = {c for comps in routine.vectors.values() for c in comps}
    out = []
    for a in routine.args:
        if a not in used and a not in parts:
            x = sp.Symbol(a, real=True)
            out.append(clamp(x, *routine.domain[a]) if a in routine.domain else x)
    return out
