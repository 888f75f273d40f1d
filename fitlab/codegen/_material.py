r"""A program's per-material set-up: each evaluator's routine inlined (:func:`inline_calls`), products of
exponentials merged (:func:`merge_exp_products`), and every subexpression in the material's parameters alone
hoisted into fields computed once per material (:func:`hoist_params`): :func:`material_of`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import cast

import sympy as sp
from sympy.core.function import AppliedUndef

from fitlab.codegen._model import Material, MaterialSpec, Routine, symbols_of
from fitlab.codegen._rewrites import rebuilt, with_args

__all__ = [
    "field_symbol",
    "inline_calls",
    "merge_exp_products",
    "inlined",
    "collected_by_params",
    "hoist_params",
    "material_of",
]


def field_symbol(k: int) -> sp.Symbol:
    """The symbol an evaluator reads the material's field k as (printers print it as the struct's k[k])."""
    return sp.Symbol(f"material_{k}", real=True)


def inline_calls(expr: sp.Expr, routines: Mapping[str, Routine]) -> sp.Expr:
    """``expr`` with every call of a routine (:func:`.call`) replaced by that routine's expression, recursively;
    a routine called with an argument its caller has clamped into the same domain clamps it once
    (clamp(clamp(x, lo, hi), lo, hi) -> clamp(x, lo, hi)).  Max and Min are rebuilt unevaluated, as in
    :func:`rebuilt`, and a routine's arguments are put in through :func:`rebuilt`, not ``xreplace`` (printing the
    exported tables' C built 78,500 Max and Min before, 20,700 after)."""
    # one bottom-up pass with every distinct subexpression visited once: a model's tree repeats its clamped
    # inputs and its calls many times, and sympy's replace would walk each copy (and each inlined body once
    # per level of calls)
    done: dict = {}

    def visit(e):
        out = done.get(e)
        if out is None:
            out = done[e] = rebuilt_node(e)
        return out

    def rebuilt_node(e):
        if e.args:
            args = tuple(visit(a) for a in e.args)
            if args != e.args:
                e = with_args(e, args)
        if isinstance(e, AppliedUndef) and e.func.__name__ in routines:
            r = routines[e.func.__name__]
            by_name = {s.name: s for s in symbols_of(r.expr)}
            given: dict[sp.Basic, sp.Basic] = {by_name[a]: v for a, v in zip(r.args, e.args) if a in by_name}
            return visit(rebuilt(r.expr, lambda n: given.get(n, n)))
        if _clamped_twice(e):
            parts = _clamp_parts(e)
            assert parts is not None  # _clamped_twice: e is a clamp
            return parts[2]
        return e

    return cast(sp.Expr, visit(expr))


def _clamp_parts(e) -> tuple | None:
    """(lo, hi, x) when ``e`` is min(hi, max(lo, x)) with numbers lo, hi (:func:`.clamp`), else None."""
    if not isinstance(e, sp.Min) or len(e.args) != 2:
        return None
    hi = [a for a in e.args if a.is_number]
    inner = [a for a in e.args if isinstance(a, sp.Max) and len(a.args) == 2]
    if len(hi) != 1 or len(inner) != 1:
        return None
    lo = [a for a in inner[0].args if a.is_number]
    x = [a for a in inner[0].args if not a.is_number]
    return (lo[0], hi[0], x[0]) if len(lo) == 1 and len(x) == 1 else None


def _clamped_twice(e) -> bool:
    """Whether ``e`` is clamp(clamp(x, lo, hi), lo, hi)."""
    outer = _clamp_parts(e)
    inner = outer and _clamp_parts(outer[2])
    if not inner or not outer:
        return False
    return float(inner[0]) == float(outer[0]) and float(inner[1]) == float(outer[1])


def merge_exp_products(expr: sp.Expr) -> sp.Expr:
    """exp(a) exp(b) ... -> exp(a + b + ...) in every product: one exp where the model multiplies two
    (the Lambert sphere's H(mu_i) H(mu_o) of log-exp forms).  The same value to rounding wherever the
    product does not overflow."""
    if expr.is_Atom:
        return expr
    args = [merge_exp_products(a) for a in cast("tuple[sp.Expr, ...]", expr.args)]
    if isinstance(expr, sp.Mul):
        exps = [a for a in args if isinstance(a, sp.exp)]
        if len(exps) > 1:
            rest = [a for a in args if not isinstance(a, sp.exp)]
            return sp.Mul(*rest, sp.exp(sp.Add(*(cast(sp.Expr, a.args[0]) for a in exps))))
    return expr if all(a is b for a, b in zip(args, expr.args)) else expr.func(*args)


def inlined(expr: sp.Expr, routines: Mapping[str, Routine]) -> sp.Expr:
    """``expr`` with its calls inlined (:func:`inline_calls`) and products of exponentials merged
    (:func:`merge_exp_products`); call it under ``sp.evaluate(False)``, as the clamps are rebuilt unevaluated."""
    return merge_exp_products(inline_calls(expr, routines))


def collected_by_params(expr: sp.Expr, params: Sequence[str]) -> sp.Expr:
    """``expr`` with its terms collected as :func:`hoist_params` collects them (k1(c) mu^2 + k2(c) mu^2 ->
    (k1 + k2)(c) mu^2), the fields written back as their expressions: each coefficient computed once per call."""
    (out,), fields = hoist_params([expr], params)
    return cast(sp.Expr, out.xreplace({field_symbol(k): f for k, f in enumerate(fields)}))


def hoist_params(exprs: Sequence[sp.Expr], params: Sequence[str]) -> tuple[list[sp.Expr], list[sp.Expr]]:
    r"""Split ``exprs`` into per-material fields and what is left per evaluation.

    Every maximal subexpression whose free symbols are all among ``params`` (numbers aside) becomes a
    field (:func:`field_symbol`); of an Add or Mul whose terms mix, the terms in ``params`` alone are
    gathered into one field.  Returns (the expressions in the field symbols, the fields in ``params``).
    Conditions (relations) stay where they are: only numbers are hoisted.
    """
    names = set(params)
    fields: dict = {}
    free_names: dict = {}  # node -> names of its free symbols, each node's computed once from its arguments'

    def free(e) -> frozenset:
        out = free_names.get(e)
        if out is None:
            out = frozenset((e.name,)) if e.is_Symbol else frozenset().union(*(free(a) for a in e.args))
            free_names[e] = out
        return out

    def only_params(e) -> bool:
        # (a Symbol is also a sympy Boolean: relations and logic are what stay)
        logic = (sp.core.relational.Relational, sp.logic.boolalg.BooleanFunction, sp.logic.boolalg.BooleanAtom)
        if not isinstance(e, sp.Expr) or isinstance(e, logic):
            return False
        names_here = free(e)
        return bool(names_here) and names_here <= names

    def field(e):
        if e not in fields:
            fields[e] = field_symbol(len(fields))
        return fields[e]

    def factors(term) -> list:
        return [f for a in term.args for f in factors(a)] if isinstance(term, sp.Mul) else [term]

    def split(term) -> tuple:
        """(the factors of ``term`` in the parameters or numbers, the product of the others in a canonical order)."""
        fs = factors(term)
        mine = tuple(a for a in fs if only_params(a) or a.is_number)
        others = sorted((a for a in fs if not (only_params(a) or a.is_number)), key=sp.default_sort_key)
        return mine, sp.Mul(*others)

    def distributed(term) -> list:
        """k(c) (a + b mu + ...) -> [k a, k b mu, ...], recursively: the terms of an Add nested in a product
        with the parameters, so that they collect with their peers."""
        mine, rest = split(term)
        if isinstance(rest, sp.Add) and any(only_params(a) for a in mine):
            return [d for t in rest.args for d in distributed(sp.Mul(*mine, t))]
        return [term]

    def collected(terms) -> sp.Expr | None:
        """An Add's terms collected by what they hold besides the parameters, k1(c) mu^2 + k2(c) mu^2 ->
        field(k1 + k2) mu^2 (one multiply per power where a form's polynomial in (s, mu) has one per
        coefficient); None where no two terms share a rest."""
        groups: dict = {}  # rest -> [(term, its factors in the parameters or numbers)]
        for a in (d for t in terms for d in distributed(t)):
            mine, rest = split(a)
            groups.setdefault(rest, []).append((a, mine))
        if all(len(g) == 1 for g in groups.values()):
            return None
        out = []
        for rest, group in groups.items():
            whole = [a for a, _ in group]
            coeffs = [sp.Mul(*mine) for _, mine in group]
            if rest == 1:  # the terms in the parameters alone, and numbers
                out.append(field(sp.Add(*whole)) if any(only_params(a) for a in whole) else sp.Add(*whole))
            elif len(group) > 1 and any(only_params(k) for k in coeffs):
                out.append(sp.Mul(field(sp.Add(*coeffs)), visit(rest)))
            else:
                out.extend(visit(a) for a in whole)
        return sp.Add(*out)

    def visit(e):
        if only_params(e):
            return field(e)
        if e.is_Atom:
            return e
        args = list(e.args)
        if isinstance(e, sp.Add):
            grouped = collected(args)
            if grouped is not None:
                return grouped
        if isinstance(e, (sp.Add, sp.Mul)):
            # numbers go with the material: 0.3 k(c) mu^2 reads one field times mu^2
            mine = [a for a in args if only_params(a) or a.is_number]
            if len(mine) > 1 and any(only_params(a) for a in mine):
                rest = [visit(a) for a in args if not (only_params(a) or a.is_number)]
                return e.func(field(e.func(*mine)), *rest)
        new = [visit(a) for a in args]
        return e if all(a is b for a, b in zip(new, args)) else e.func(*new)

    out = [visit(e) for e in exprs]
    return out, list(fields)


def material_of(routines: Sequence[Routine], spec: MaterialSpec) -> Material:
    """The :class:`Material` of a program's routines: each evaluator's routine inlined (:func:`inline_calls`), products
    of exponentials merged (:func:`merge_exp_products`),
    its subexpressions in ``spec.params`` alone hoisted (:func:`hoist_params`, one set of fields for every
    evaluator)."""
    by_name = {r.name: r for r in routines}
    kept = {name: source for name, source in spec.evaluators.items() if source in by_name}  # optional routines
    sources = [by_name[name] for name in kept.values()]
    # rebuilt unevaluated: sympy's evaluation of the nested Max and Min (the clamps) costs tens of seconds
    # and changes nothing that is printed
    with sp.evaluate(False):
        exprs, fields = hoist_params([inlined(r.expr, by_name) for r in sources], spec.params)
    evaluators = []
    for (name, source), r, e in zip(kept.items(), sources, exprs):
        args = tuple(a for a in r.args if a not in spec.params)
        doc = (
            f"{source} with the per-material set-up hoisted: the material m comes from "
            f"{' or '.join(['prepare_' + '_'.join(spec.params), *spec.setups])}. " + r.doc
        )
        evaluators.append(Routine(name, args, e, doc, r.vectors, {a: r.domain[a] for a in args}, r.out))
    setups = tuple((name, arg, routine) for name, (arg, routine) in spec.setups.items())
    return Material(tuple(spec.params), tuple(fields), tuple(evaluators), setups, kept)
