r"""The cancellation-free rewrites of generated expressions, and the one-pass tree rebuild they are written with.

Rewrites are ``sympy.codegen.rewriting`` optimisations (``ReplaceOptim`` and its kin, applied in order by
``optimize``): :data:`STABLE`, the rewrites that know no family (:func:`stable`); a program names those of
its family in :attr:`fitlab.codegen.ProgramSpec.rewrites` (the Lambert sphere's, which know its symbols:
:mod:`fitlab.families.lambert_sphere.program.rewrites`, written with :class:`SumSubsOptim` and
:func:`rebuilt`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import sympy as sp
from sympy.codegen.cfunctions import expm1, log1p
from sympy.codegen.rewriting import Optimization, ReplaceOptim, optimize

from fitlab.forms.symbolic import safe_pow

__all__ = ["rebuilt", "with_args", "SumSubsOptim", "ONE_MINUS_SQUARES", "ONE_MINUS_POW", "STABLE", "stable"]


def with_args(e: sp.Basic, args: tuple) -> sp.Basic:
    """``e`` with the arguments ``args``: a Max or Min unevaluated unless they are all numbers (:func:`rebuilt`)."""
    if isinstance(e, (sp.Max, sp.Min)) and not all(a.is_number for a in args):
        return e.func(*args, evaluate=False)
    return e.func(*args)


def rebuilt(expr: sp.Basic, node: Callable[[sp.Basic], sp.Basic]) -> sp.Basic:
    """``expr`` rebuilt bottom-up in one pass: every node, its arguments rebuilt first, becomes ``node(e)``
    (``e`` itself where nothing applies); a subtree met twice is rebuilt once.

    A Max or Min whose arguments changed is rebuilt unevaluated unless they are all numbers.  sympy's own
    evaluation would try to order each pair of arguments (``_find_localzeros``: factor their difference, ask
    its sign), which takes seconds on the large terms of a program and, where it cannot decide, gives the same
    node; a Max it could have shortened is only longer, never another value.  ``xreplace`` and ``subs``
    re-evaluate them, and ``subs`` also compares every unchanged argument with itself node by node
    (``Basic.is_same``), quadratic in the depth of the tree."""
    memo: dict[int, tuple[sp.Basic, sp.Basic]] = {}

    def walk(e):
        hit = memo.get(id(e))
        if hit is not None:
            return hit[1]
        out = e
        if e.args:
            args = tuple(walk(a) for a in e.args)
            if any(a is not b for a, b in zip(args, e.args)):
                out = with_args(e, args)
        out = node(out)
        memo[id(e)] = (e, out)  # e kept alive with its id
        return out

    return walk(expr)


class SumSubsOptim(Optimization):
    """``expr.subs(old, new)`` for ``old`` a sum with a rational constant term (1 - s), in one pass over the
    tree (:func:`rebuilt`): the matches of sympy's ``Add._eval_subs``, which are the only ones a sum can have.
    In a sum whose constant term is rational and whose other terms are old's terms (old's terms negated) and
    possibly more, old's terms are replaced by new minus old's constant term (by its negative); 2 - s + x
    becomes 1 + new + x for old = 1 - s.  sympy's ``subs`` gives the same tree, in time quadratic in the tree's
    depth (see :func:`rebuilt`)."""

    def __init__(self, old, new, **kwargs):
        super().__init__(**kwargs)
        old, new = sp.sympify(old), sp.sympify(new)
        constant, terms = old.as_coeff_Add()
        if not (old.is_Add and constant.is_Rational):
            raise ValueError(f"{old}: SumSubsOptim replaces a sum with a rational constant term")
        self.new, self.constant, self.terms = new, constant, terms
        self.plus, self.minus = frozenset(sp.Add.make_args(terms)), frozenset(sp.Add.make_args(-terms))

    def _node(self, e):
        if not e.is_Add:
            return e
        constant, terms = e.as_coeff_Add()
        if not constant.is_Rational:
            return e
        if terms == self.terms:
            return sp.Add(self.new, constant, -self.constant)
        if terms == -self.terms:
            return sp.Add(-self.new, constant, self.constant)
        own = sp.Add.make_args(terms)
        if len(self.plus) < len(own):
            own_set = frozenset(own)
            if self.plus < own_set:
                return sp.Add(self.new, constant, -self.constant, *(own_set - self.plus))
            if self.minus < own_set:
                return sp.Add(-self.new, constant, self.constant, *(own_set - self.minus))
        return e

    def __call__(self, expr):
        return rebuilt(expr, self._node)


def _is_one_minus_pow(e) -> bool:
    """Whether ``e`` is 1 - safe_pow(1 + ..., p)."""
    if not (e.is_Add and len(e.args) == 2 and sp.S.One in e.args):
        return False
    other = next(a for a in e.args if a != sp.S.One)
    coeff, rest = other.as_coeff_Mul()
    return float(coeff) == -1.0 and isinstance(rest, safe_pow) and rest.args[0].is_Add and sp.S.One in rest.args[0].args


def _one_minus_pow(e):
    """1 - (1 - x)^p -> -expm1(p log1p(-x)) for x < 1/2 (see :func:`stable`)."""
    other = next(a for a in e.args if a != sp.S.One)
    base, p = other.as_coeff_Mul()[1].args
    # sympy annotates .args as Basic (base, of a safe_pow, is an Expr) and a Function call as its class
    x = 1 - base  # pyright: ignore[reportOperatorIssue]
    small = -expm1(p * log1p(-sp.Min(x, sp.Rational(1, 2))))  # pyright: ignore[reportOperatorIssue]
    return sp.Piecewise((small, x < sp.Rational(1, 2)), (e, True))


def _square_root(e):
    """X when ``e`` is 1 - X^2, else None."""
    if not (e.is_Add and len(e.args) == 2 and sp.S.One in e.args):
        return None
    coeff, rest = e.args[1 - e.args.index(sp.S.One)].as_coeff_Mul()
    return rest.base if coeff == -1 and rest.is_Pow and rest.exp == 2 else None


def _is_one_minus_square(e) -> bool:
    """Whether ``e`` is sqrt(1 - X^2) or max(0, 1 - X^2)."""
    if e.is_Pow and e.exp == sp.S.Half:
        return _square_root(e.base) is not None
    return (isinstance(e, sp.Max) and len(e.args) == 2 and sp.S.Zero in e.args
            and any(_square_root(a) is not None for a in e.args))  # fmt: skip


def _one_minus_square(e):
    """sqrt(1 - X^2) -> sqrt((1 - X)(1 + X)), max(0, 1 - X^2) -> max(0, (1 - X)(1 + X)) (see :func:`stable`)."""
    if e.is_Pow:
        x = _square_root(e.base)
        assert x is not None  # _is_one_minus_square(e)
        return sp.sqrt((1 - x) * (1 + x))
    x = next(_square_root(a) for a in e.args if _square_root(a) is not None)
    assert x is not None
    return sp.Max(0, (1 - x) * (1 + x))


#: sqrt(1 - X^2) -> sqrt((1 - X)(1 + X)) and max(0, 1 - X^2) -> max(0, (1 - X)(1 + X)) (:func:`stable`)
ONE_MINUS_SQUARES = ReplaceOptim(_is_one_minus_square, _one_minus_square)
#: 1 - (1 - x)^p -> -expm1(p log1p(-x)) where x < 1/2 (:func:`stable`)
ONE_MINUS_POW = ReplaceOptim(_is_one_minus_pow, _one_minus_pow)
#: the cancellation-free rewrites that know no family, in the order they are applied (:func:`stable`);
#: every :class:`.ProgramSpec`'s :attr:`~.ProgramSpec.rewrites` unless the family gives its own
STABLE: tuple[Optimization, ...] = (ONE_MINUS_SQUARES, ONE_MINUS_POW)


def stable(expr: sp.Expr, rewrites: Sequence[Optimization] = STABLE) -> sp.Expr:
    """Rewrite the cancellations the forms contain into forms that keep every digit: ``rewrites``
    (``sympy.codegen.rewriting`` optimisations) applied in order; by default :data:`STABLE`, the rewrites
    that know no family:

    * sqrt(1 - x^2) -> sqrt((1 - x)(1 + x)), max(0, 1 - x^2) -> max(0, (1 - x)(1 + x))
      (:data:`ONE_MINUS_SQUARES`): as |x| -> 1, 1 - x*x keeps only eps/(1 - |x|) of its value (1 - x and
      1 + x are exact there).  The Lambert sphere's phase function has sqrt(1 - u^2) - u acos(u): in
      forward scattering at grazing 1 - u ~ (mu_i + mu_o)^2/2, and written directly the rounding of u*u
      cost 37 % of single scattering in double at mu_i = 1e-6, mu_o = 1e-4; both terms read from the
      same u, they cancel to full accuracy.
    * 1 - (1 - x)^p -> -expm1(p log1p(-x)) for x < 1/2 (:data:`ONE_MINUS_POW`; the exact zero of the
      Lambert sphere's c(kd) at kd = 0); for x >= 1/2 there is no cancellation and (1 - x)^p stays.

    A family's own rewrites (those that know its symbols) are its program's
    (:attr:`.ProgramSpec.rewrites`: :meth:`.ProgramSpec.rewrite`).
    """
    return optimize(expr, rewrites)
