r"""From a sparse candidate to a validated form: a :class:`Form`, its nonlinear
refit, and what it costs to evaluate.

The candidate's linearised coefficients start an optimistix refit of the
nonlinear form against the target's own error measure (``fitlab.fit.refit``:
relative least squares, then Lawson minimax where the target asks for it), and
the refit is validated on the target's validation set, points the regression
and the refit never saw.  Cost is counted as sympy operations of the
expression with numbers for parameters, after common-subexpression
elimination and a Horner arrangement: what a compiler is left to do.
"""

from __future__ import annotations

import hashlib
import itertools

import sympy as sp

from fitlab.discover.library import Library
from fitlab.discover.regression import Candidate
from fitlab.forms import Form
from fitlab.forms.symbolic import symbols

__all__ = ["candidate_form", "operation_count", "arranged", "form_name"]


def form_name(candidate: Candidate, tag: str = "") -> str:
    """``sr_<terms>_<6 hex digits of the support>``: stable across runs, distinct per support.

    ``tag`` (a library's name) keeps apart equal labels of two libraries of one target; the
    primary library's forms are untagged, so their names stay as libraries are added.
    """

    text = "|".join(candidate.support[0]) + "/" + "|".join(candidate.support[1]) + (f"@{tag}" if tag else "")
    return f"sr_{candidate.n_terms}_{hashlib.sha256(text.encode()).hexdigest()[:6]}"


def candidate_form(library: Library, candidate: Candidate, name: str | None = None) -> Form:
    """The candidate as a Form: parameters a1.. (numerator) and b1.. (denominator), started at
    the candidate's coefficients."""
    a = symbols(tuple(f"a{k + 1}" for k in range(len(candidate.num))))
    b = symbols(tuple(f"b{k + 1}" for k in range(len(candidate.den))))
    num = dict(zip(candidate.num, a))
    den = dict(zip(candidate.den, b))
    start = {str(p): v for p, v in zip((*a, *b), (*candidate.num.values(), *candidate.den.values()))}
    terms = "; ".join(
        part + ": " + ", ".join(f"{p} [{label}]" for label, p in mapping.items())
        for part, mapping in (("numerator", num), ("denominator", den))
        if mapping
    )
    return Form(
        target=library.target,
        name=name or form_name(candidate),
        inputs=library.inputs,
        params=tuple(str(p) for p in (*a, *b)),
        expr=arranged(library, num, den),
        start=start,
        description=f"found by fitlab discover (library {library.name}: {library.description}); {terms}",
        refit_by_default=False,
    )


def _horner(poly_expr: sp.Expr, coefficients=frozenset()) -> sp.Expr:
    """``poly_expr`` as built or in Horner form, whichever takes fewer operations.

    The expression is a polynomial in its symbols and its non-polynomial pieces (sqrt(1 - c),
    log(...)), each of which stands in for one variable; every order of up to 5 variables is tried.
    """
    best = poly_expr
    pieces = sorted(
        (a for a in sp.expand(poly_expr).atoms(sp.Function, sp.Pow) if not (a.is_Pow and a.exp.is_Integer)),
        key=sp.default_sort_key,
    )
    outer = [p for p in pieces if not any(p != q and q.has(p) for q in pieces)]
    stand_in = {p: sp.Dummy(f"v{k}") for k, p in enumerate(outer)}
    expanded = sp.expand(sp.expand(poly_expr).xreplace(stand_in))
    variables = sorted(expanded.free_symbols - set(coefficients), key=sp.default_sort_key)
    if not variables or len(variables) > 5:
        return best
    back = {v: p for p, v in stand_in.items()}
    for order in itertools.permutations(variables):
        try:
            h = sp.horner(sp.Poly(expanded, *order), *order).xreplace(back)
        except sp.PolynomialError:  # not a polynomial in these variables (e.g. 1/(1 + s)): keep it as built
            return best
        if operation_count(h) < operation_count(best):
            best = h
    return best


def arranged(library: Library, num: dict, den: dict) -> sp.Expr:
    """offset + factor N/D with N = n0 + sum num[k] f_k, D = d0 + sum den[j] g_j, each arranged by
    :func:`_horner`; coefficients are numbers or parameter symbols."""
    coefs = {v for v in (*num.values(), *den.values()) if isinstance(v, sp.Symbol)}

    def value(v):
        return v if isinstance(v, sp.Basic) else sp.Float(repr(float(v)), 17)

    n = library.n0 + sum((value(v) * library.numerator[k] for k, v in num.items()), sp.S.Zero)
    d = library.d0 + sum((value(v) * library.denominator[k] for k, v in den.items()), sp.S.Zero)
    return library.clamped(library.offset + library.factor * _horner(n, coefs) / _horner(d, coefs))


def operation_count(expr: sp.Expr) -> int:
    """Operations to evaluate ``expr``: sympy's count_ops summed over the common subexpressions
    and the reduced expression (each shared piece counted once)."""
    reps, reduced = sp.cse(expr)
    return int(sum(sp.count_ops(e) for _, e in reps) + sum(sp.count_ops(e) for e in reduced))
