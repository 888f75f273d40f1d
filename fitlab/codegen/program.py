r"""The language-neutral program that every back end prints, built from fit records.

A :class:`Routine` is one generated function: scalar arguments, one sympy
expression, a docstring.  Expressions call other routines through undefined
sympy functions (``call("h0", mu_i, c)``), so that a model assembled from parts
reads as the sum of its terms and each part is evaluated once per call.  A
:class:`Program` is the routines of one generated file set, with what its
banner names.

:func:`build_program` takes data (fit records by target: the dicts of fit files,
or :class:`fitlab.store.FitFunction` objects) and returns a Program; it reads
no file (:func:`fitlab.codegen.load_program` reads a fits folder through
:mod:`fitlab.store`).  What is printed is the family's choice: a family whose
``codegen`` is a :class:`ProgramSpec` contributes its own routines (for the
Lambert sphere, the runtime BRDF assembled from its parts:
:mod:`fitlab.families.lambert_sphere.program.spec`); a family without one gets one
routine per target that names a ``routine`` (:attr:`fitlab.core.Target.routine`),
its saved fit as it stands (:func:`part_routine`).  Where no family is named, the program is the default
family's (:func:`default_program_family`: the one that declares ``HasProgram.default_program``).

The helpers a family's program is written with are public here:
:func:`call`, :func:`part_routine`, :func:`stable` (the cancellation-free rewrites that know no
family: :data:`STABLE`), :class:`SumSubsOptim`, :func:`rebuilt`, :func:`clamp` and :func:`clamped`.  Rewrites are
``sympy.codegen.rewriting`` optimisations (``ReplaceOptim`` and its kin, applied in order by
``optimize``); a program names those of its family in :attr:`ProgramSpec.rewrites` (the Lambert
sphere's, which know its symbols: :mod:`fitlab.families.lambert_sphere.program.rewrites`), and
:func:`part_routine` applies the program's rewrites to every part, and only that program's.

The NaN and domain policy is kept here, once for every language (see the
section below): :func:`build_program` clamps every routine's inputs into its
:attr:`Routine.domain` (:func:`with_domain`), and the printers print every Max
and Min through :func:`minmax_piecewise` and safe_pow from :data:`SAFE_POW`, so
that NaN in any input gives NaN, +-inf and other out-of-domain inputs are
clamped, and every other input gives a finite value.
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import ClassVar, cast

import sympy as sp
import sympy.core.random as sympy_random
from sympy.codegen.cfunctions import expm1, log1p
from sympy.codegen.rewriting import Optimization, ReplaceOptim, optimize
from sympy.core.function import AppliedUndef

from fitlab.core import Capability, Family, families, get_family, get_target
from fitlab.forms.symbolic import safe_pow
from fitlab.store import FitFunction

__all__ = ["Routine", "Program", "ProgramSpec", "HasProgram", "build_program", "part_routine", "program_spec",
           "default_program_family", "model_form", "parse_terms",
           "call", "stable", "STABLE", "ONE_MINUS_SQUARES", "ONE_MINUS_POW", "SumSubsOptim", "rebuilt", "clamp",
           "clamped",
           "minmax_piecewise", "with_domain", "unused_inputs", "SAFE_POW", "DEFAULT_FORMS", "Model", "Claim",
           "MaterialSpec",
           "Material",
           "material_of", "field_symbol", "outputs", "inline_calls", "hoist_params", "merge_exp_products"]  # fmt: skip

#: the model every program has: each target's default form (:attr:`ProgramSpec.models`)
DEFAULT_FORMS = "default-forms"


@dataclass(frozen=True)
class Model:
    """A named choice of the fits a program is built from (``fitlab codegen --model NAME``).

    forms: {target: form} (a target not named takes its default form).
    description: what the model is, in one phrase (the banner's).
    folder: the subfolder of the packaged fits its fits are read from ("": the packaged fits themselves); a
        ``--fits`` folder overlays it as it overlays the packaged fits.
    physics: the physics every one of the program's :attr:`ProgramSpec.physics_parts` must have been fitted to
        (:attr:`fitlab.store.FitFunction.physics`), or None (no such rule): a part fitted to other physics is
        refused unless mixing is asked for by name.
    """

    name: str
    forms: Mapping[str, str]
    description: str
    folder: str = ""
    physics: str | None = None


@dataclass(frozen=True)
class Routine:
    """One generated function: ``name(args) = expr``.

    args: scalar argument names, in order; ``vectors`` groups consecutive ones
    into a 3-vector argument (name -> its three component names).
    domain: arg name -> (lo, hi), the closed interval every input is clamped into
    (:func:`with_domain`, applied by :func:`build_program` to every routine; each
    argument must have one).
    out: the name of a 3-vector the routine gives besides its value (a sampler's direction), or "";
    then ``expr`` is ``sp.Tuple(value, x, y, z)`` (:func:`outputs`), printed as a C function that
    returns the value and writes ``out[3]``, a numpy function that returns (vector, value), and a
    shader function that returns vec4(x, y, z, value).
    """

    name: str
    args: tuple[str, ...]
    expr: sp.Expr
    doc: str
    vectors: dict = field(default_factory=dict)
    domain: dict = field(default_factory=dict)
    out: str = ""

    def __post_init__(self):
        if bool(self.out) != isinstance(self.expr, sp.Tuple) or (self.out and len(self.expr.args) != 4):
            raise ValueError(
                f"routine {self.name}: a routine with an output vector has expr Tuple(value, x, y, z), "
                "and only such a routine"
            )

    def signature(self) -> tuple[str, ...]:
        """Arguments as the caller passes them: vectors as one argument."""
        out, seen = [], set()
        for a in self.args:
            owner = next((v for v, comps in self.vectors.items() if a in comps), None)
            if owner is None:
                out.append(a)
            elif owner not in seen:
                seen.add(owner)
                out.append(owner)
        return tuple(out)


@dataclass(frozen=True)
class Program:
    """The routines of one generated file set.

    sources: (fit file, sha256 of its bytes) the banner lists (empty for records that came from no file).
    terms: the optional terms of the family's model that were kept (see :class:`ProgramSpec`).
    name: base name of the files and prefix of every generated function (``lambert_sphere`` ->
        lambert_sphere.c, ``lambert_sphere_h0``).
    about: the banner's lines that say what the files hold.
    doc: the generated Python module's docstring.
    parts: targets whose routine (:attr:`fitlab.core.Target.routine`) is their fit as it stands.
    model: (name, description) of the model the fits were chosen by (:attr:`ProgramSpec.models`), or None.
    claim: the banner's lines on the model's accuracy as a whole, measured (:class:`Claim`), or ().
    material: the per-material set-up and the evaluators that use it (:class:`Material`), or None.
    """

    routines: tuple[Routine, ...]
    sources: tuple[tuple[str, ...], ...]  # (fit file, sha256 of its bytes)
    terms: tuple[str, ...]
    name: str = "fitlab"
    about: tuple[str, ...] = ()
    doc: str = "Generated by fitlab: numpy only.\n"
    parts: tuple[str, ...] = ()
    model: tuple[str, str] | None = None
    material: Material | None = None
    #: one phrase per source, in the order of ``sources``: where the file was read, and the error measured there
    source_notes: tuple[str, ...] = ()
    #: the banner's lines on the model's accuracy as a whole (:attr:`Claim.lines`)
    claim: tuple[str, ...] = ()

    def routine(self, name: str) -> Routine:
        return next(r for r in self.routines if r.name == name)

    @property
    def prefix(self) -> str:
        """The prefix of every generated function's name."""
        return self.name + "_"


@dataclass(frozen=True)
class Claim:
    """What a program's model measures as a whole, against the physics its family takes as the truth (not its
    parts against their own targets): measured where the program is generated (a family's
    :attr:`ProgramSpec.claim`).

    lines: the banner's lines.
    routines: {routine name: a sentence appended to that routine's documentation}.
    """

    lines: tuple[str, ...]
    routines: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class ProgramSpec:
    """What a family prints (the ``program()`` of a family that is a :class:`HasProgram`).

    name: the generated files' base name and the functions' prefix.
    fits: the targets whose fits the program is built from, in the order of the banner.
    parts: those of them printed as one routine each, their fit as it stands (:func:`part_routine`).
    routines: ``routines(fits, terms) -> routines``: every routine, in file order, from the fits
        ({target: FitFunction}) and the terms kept (a subset of ``terms``, in model order).
    terms: the optional terms of the family's model (``fitlab codegen --terms``), in model order.
    about: the banner's description, formatted with ``{terms}`` (the terms kept, comma-separated).
    doc: the generated Python module's docstring.
    models: its named choices of fits (:class:`Model`); every program also has :data:`DEFAULT_FORMS` (each
        target's default form, from the packaged fits).  ``fitlab codegen --model NAME``.
    default_model: the model ``fitlab codegen`` prints when none is named: the one place that choice
        is made (for the Lambert sphere, the most accurate model at its cost: the parts fitted to the true BRDF).
    physics_parts: the fits that make one model together and must share one physics (:attr:`Model.physics`).
    claim: ``claim(fits, terms) -> Claim``: the model's accuracy as a whole, measured from the fits
        ({target: FitFunction}) and the terms kept, or None (a program that states its parts' errors only).
    optional: those of ``fits`` a program can do without (the routines that need them are left out, as
        from a published preset that has no such part: the Lambert sphere's sampler).
    rewrites: the cancellation-free rewrites of this program's routines (``sympy.codegen.rewriting``
        optimisations, applied in order by :meth:`rewrite`): :func:`part_routine` applies them to every part
        of the family, and the family's ``routines`` to what else it chooses.  Default :data:`STABLE`, the
        rewrites that know no family; a family adds those that know its symbols (the Lambert sphere's
        1 - sqrt(1 - c): :data:`fitlab.families.lambert_sphere.program.rewrites.REWRITES`), and they apply to its
        routines only.
    """

    name: str
    fits: tuple[str, ...]
    parts: tuple[str, ...]
    routines: Callable[[Mapping[str, FitFunction], tuple[str, ...]], Sequence[Routine]]
    terms: tuple[str, ...] = ()
    about: str = ""
    doc: str = ""
    models: tuple[Model, ...] = ()
    default_model: str = DEFAULT_FORMS
    physics_parts: tuple[str, ...] = ()
    material: MaterialSpec | None = None
    optional: tuple[str, ...] = ()
    rewrites: tuple[Optimization, ...] = field(default_factory=lambda: STABLE)
    claim: Callable[[Mapping[str, FitFunction], tuple[str, ...]], Claim] | None = None

    def rewrite(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with this program's :attr:`rewrites` applied, in order."""
        return stable(expr, self.rewrites)

    def model_names(self) -> tuple[str, ...]:
        """Every model's name, the default first."""
        names = (*(m.name for m in self.models), DEFAULT_FORMS)
        return (self.default_model, *(n for n in names if n != self.default_model))

    def model(self, name: str | None = None) -> Model:
        """The model ``name`` (None: :attr:`default_model`); ValueError (one line) naming the models for another."""
        name = self.default_model if name is None else name
        if name == DEFAULT_FORMS:
            return Model(DEFAULT_FORMS, {}, "each target's default form")
        for m in self.models:
            if m.name == name:
                return m
        raise ValueError(
            f"unknown model {name!r}; the {self.name} program's models are {', '.join(self.model_names())}"
        )

    def __call__(self, fits: Mapping[str, FitFunction], terms: tuple[str, ...]) -> tuple[Routine, ...]:
        return tuple(self.routines(fits, terms))


class HasProgram(Capability):
    """A family that prints a program of its own (:class:`ProgramSpec`); without one, its program is one routine
    per target that names a routine."""

    noun = "program"
    #: whether its program is the one ``fitlab codegen`` prints when no family is named (at most one family
    #: says so: the Lambert sphere; :func:`default_program_family`)
    default_program: ClassVar[bool] = False

    @abc.abstractmethod
    def program(self) -> ProgramSpec: ...


@dataclass(frozen=True)
class MaterialSpec:
    """What a program's per-material set-up holds (the ``material`` of a :class:`ProgramSpec`).

    params: the material's parameters (Lambert sphere: ("c",)): every subexpression of an evaluator
        that depends on them alone is computed once per material (:func:`material_of`).
    evaluators: {evaluator name: routine}: ``eval`` is ``brdf`` with the set-up hoisted, and takes the
        routine's arguments less ``params``.
    setups: {set-up name: (argument, routine)}: ``prepare(kd)`` is ``prepare_PARAM(ROUTINE(kd))``, for a
        material with one parameter (the routine maps the argument to it).
    """

    params: tuple[str, ...]
    evaluators: Mapping[str, str]
    setups: Mapping[str, tuple[str, str]] = field(default_factory=dict)


@dataclass(frozen=True)
class Material:
    r"""A program's per-material set-up: the quantities that depend on the material's parameters alone.

    fields: k_j(params), j = 0 .. n-1, each an expression in ``params`` (printed as the struct
        ``PREFIX_material`` with ``k[n]``, filled by ``prepare_PARAMS``).
    evaluators: routines whose expressions read the fields as the symbols :func:`field_symbol`
        (``material_j``) and take the source routine's other arguments.
    setups: (name, argument, routine) (see :class:`MaterialSpec`).
    sources: {evaluator name: the routine it evaluates}.
    """

    params: tuple[str, ...]
    fields: tuple[sp.Expr, ...]
    evaluators: tuple[Routine, ...]
    setups: tuple[tuple[str, str, str], ...]
    sources: Mapping[str, str]

    @property
    def prepare_name(self) -> str:
        """The routine that fills the struct from the parameters: ``prepare_c``."""
        return "prepare_" + "_".join(self.params)


def outputs(routine: Routine) -> list[sp.Expr]:
    """The expressions a routine gives: [value], or [value, x, y, z] with an output vector (Routine.out)."""
    return cast("list[sp.Expr]", list(routine.expr.args)) if routine.out else [routine.expr]


def _symbols(expr: sp.Basic) -> set[sp.Symbol]:
    """``expr.free_symbols``, which sympy annotates as a set of Basic: a routine's are symbols."""
    return cast("set[sp.Symbol]", expr.free_symbols)


def field_symbol(k: int) -> sp.Symbol:
    """The symbol an evaluator reads the material's field k as (printers print it as the struct's k[k])."""
    return sp.Symbol(f"material_{k}", real=True)


def inline_calls(expr: sp.Expr, routines: Mapping[str, Routine]) -> sp.Expr:
    """``expr`` with every call of a routine (:func:`call`) replaced by that routine's expression, recursively;
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
                e = _with_args(e, args)
        if isinstance(e, AppliedUndef) and e.func.__name__ in routines:
            r = routines[e.func.__name__]
            by_name = {s.name: s for s in _symbols(r.expr)}
            given: dict[sp.Basic, sp.Basic] = {by_name[a]: v for a, v in zip(r.args, e.args) if a in by_name}
            return visit(rebuilt(r.expr, lambda n: given.get(n, n)))
        if _clamped_twice(e):
            parts = _clamp_parts(e)
            assert parts is not None  # _clamped_twice: e is a clamp
            return parts[2]
        return e

    return cast(sp.Expr, visit(expr))


def _clamp_parts(e) -> tuple | None:
    """(lo, hi, x) when ``e`` is min(hi, max(lo, x)) with numbers lo, hi (:func:`clamp`), else None."""
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

    def visit(e):
        if only_params(e):
            return field(e)
        if e.is_Atom:
            return e
        args = list(e.args)
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
        inlined = [merge_exp_products(inline_calls(r.expr, by_name)) for r in sources]
        exprs, fields = hoist_params(inlined, spec.params)
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


def call(name: str, *args) -> sp.Expr:
    """A call of the generated routine ``name`` (printed as a call of that function in every language)."""
    return sp.Function(name)(*args)


def _with_args(e: sp.Basic, args: tuple) -> sp.Basic:
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
                out = _with_args(e, args)
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
#: every :class:`ProgramSpec`'s :attr:`~ProgramSpec.rewrites` unless the family gives its own
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
    (:attr:`ProgramSpec.rewrites`: :meth:`ProgramSpec.rewrite`).
    """
    return optimize(expr, rewrites)


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
# maximum would keep it: the three languages used to disagree).  The safe_pow
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
    by_name = {s.name: s for s in _symbols(routine.expr)}
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
    used = {s.name for s in _symbols(routine.expr)}
    parts = {c for comps in routine.vectors.values() for c in comps}
    out = []
    for a in routine.args:
        if a not in used and a not in parts:
            x = sp.Symbol(a, real=True)
            out.append(clamp(x, *routine.domain[a]) if a in routine.domain else x)
    return out


def part_routine(fit: FitFunction, rewrites: Sequence[Optimization] | None = None) -> Routine:
    """A target's routine (named by :attr:`fitlab.core.Target.routine`): its fit as it stands, rewritten
    by ``rewrites`` (None: the rewrites of its family's program, :attr:`ProgramSpec.rewrites`), documented
    by the fit's description and validation metrics."""
    target = get_target(fit.target)
    if rewrites is None:
        rewrites = program_spec(target.family).rewrites
    if target.routine is None:
        raise ValueError(f"target {target.name} names no generated routine (Target.routine)")
    desc = fit.record.get("target_description", fit.target)
    doc = f"{desc}; form {fit.form}: {fit.record.get('form_description', '')}"
    measured = fit.measured  # set by fitlab.fit.verify.verify_fit: figures re-measured, never the record's
    domain = {a: target.domain[a] for a in fit.inputs}
    if measured is not None:
        from fitlab.fit.verify import describe_measured

        doc = doc.rstrip() + ("" if doc.rstrip().endswith(".") else ".")
        doc += f" Measured by fitlab codegen: {describe_measured(measured)}."
        if measured["partial"]:
            domain = {a: tuple(measured["domain"][a]) for a in fit.inputs}
    return Routine(target.routine, fit.inputs, stable(fit.expression, rewrites), doc, domain=domain)


def _default_spec(family: Family) -> ProgramSpec:
    """One routine per target of ``family`` that names one: for a family without its own program."""
    parts = tuple(t.name for t in family.targets() if t.routine is not None)
    return ProgramSpec(
        name=family.name, fits=parts, parts=parts,
        routines=lambda fits, terms: [part_routine(fits[t]) for t in parts],
        about=f"{family.description}: one routine per fitted target.",
        doc=f"{family.description}, generated by fitlab: numpy only.\n\n"
            "Every function takes numpy arrays (any broadcastable shapes) and returns an array of float64.\n",
    )  # fmt: skip


def program_spec(family: str | None = None, targets: Sequence[str] = ()) -> ProgramSpec:
    """The :class:`ProgramSpec` of ``family`` (by name), else of the family of ``targets`` (all of one family),
    else of the default family (:func:`default_program_family`)."""
    if family is None and targets:
        names = {get_target(t).family for t in targets}
        if len(names) != 1:
            raise ValueError(f"targets {', '.join(targets)} belong to {len(names)} families; one program holds one")
        (family,) = names
    fam = get_family(family if family is not None else default_program_family())
    return fam.program() if isinstance(fam, HasProgram) else _default_spec(fam)


def model_form(target: str) -> str:
    """The form of ``target`` its family's program prints by default (the form its default model picks: for the
    Lambert sphere's H1, log_exp), else the target's default form: the one form ``fitlab refit`` fits when none is
    named, so that a refit is what ``fitlab codegen --fits`` then prints."""
    t = get_target(target)
    family = get_family(t.family)
    if not isinstance(family, HasProgram):
        return t.default_form
    spec = family.program()
    if target not in spec.fits:
        return t.default_form
    return spec.model().forms.get(target, t.default_form)


def default_program_family() -> str:
    """The family whose program ``fitlab codegen`` (and :func:`fitlab.codegen.generate`, ``load_program``)
    prints when none is named: the one registered family that declares it (:attr:`HasProgram.default_program`:
    the Lambert sphere), else the one family with a program of its own, else the one family there is.

    A declaration, not the order of registration: a family registered at run time can precede the built-in
    ones (registering it loads none of them), and a new family's name must not move the default.  ValueError
    (one line) when several families declare it, or when none does and there is no single candidate."""
    fams = families()
    with_spec = [name for name, f in fams.items() if isinstance(f, HasProgram)]
    declared = [name for name, f in fams.items() if isinstance(f, HasProgram) and f.default_program]
    if len(declared) > 1:
        raise ValueError(f"families {', '.join(declared)} each declare the default program; name one with --family")
    for pool in (declared, with_spec, list(fams)):
        if len(pool) == 1:
            return pool[0]
    raise ValueError(f"name the family to generate: one of {', '.join(fams)}")


def parse_terms(text: str | None, family: str | None = None) -> tuple[str, ...]:
    """'single,m0' -> ('single', 'm0'), in model order; None -> all terms (of ``family``'s program,
    :func:`program_spec`)."""
    available = program_spec(family).terms
    if text is None:
        return available
    asked = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [t for t in asked if t not in available]
    if unknown or not asked:
        raise ValueError(f"--terms takes a comma-separated subset of {', '.join(available) or '(none)'}; got {text!r}")
    return tuple(t for t in available if t in asked)


def _as_fit(target: str, record) -> FitFunction:
    fit = record if isinstance(record, FitFunction) else FitFunction(dict(record))
    if fit.target != target:
        raise ValueError(f"the record given for {target} is a fit of {fit.target}")
    return fit


#: the seed of sympy's random generators while a program is built and printed (:func:`reproducible_sympy`)
SYMPY_SEED = 2


def reproducible_sympy() -> None:
    """Seed sympy's random generators (:func:`sympy.core.random.seed`) with :data:`SYMPY_SEED`.  sympy draws
    from them (its assumptions system evaluates a fact's prerequisites in a shuffled order, and numeric
    equality checks sample points), so a program built and printed after other sympy work could depend on
    what that work drew; with the generators in one state it does not.  (The microfacet program's CSE
    temporaries were seen to differ, rarely, in a test process that had run other tests first; that this was
    the cause is not established.)"""
    sympy_random.seed(SYMPY_SEED)


def build_program(records: Mapping[str, object], terms: Sequence[str] | None = None,
                  sources: Sequence[tuple[str, str]] = (), family: str | None = None,
                  model: tuple[str, str] | None = None, claim: Claim | None = None) -> Program:  # fmt: skip
    """The program of one family from fit records by target ({target: record or FitFunction}).

    The family is ``family``, else that of the records' targets.  ``terms``: the optional terms of its
    model to keep (None: all; see :func:`parse_terms`).  ``sources``: (file, sha256) pairs the banner
    lists (the records read no file here); ``model``: (name, description) the banner names; ``claim``: the
    model's measured accuracy (:attr:`ProgramSpec.claim`), its sentences appended to the routines it names and its
    lines to the banner.  Records of targets the program does not print are ignored; a missing one is a KeyError.
    """
    reproducible_sympy()
    spec = program_spec(family, () if family else tuple(records))
    missing = [t for t in spec.fits if t not in records and t not in spec.optional]
    if missing:
        raise KeyError(f"the {spec.name} program needs fits of {', '.join(missing)}")
    terms = spec.terms if terms is None else tuple(terms)
    unknown = [t for t in terms if t not in spec.terms]
    if unknown:
        raise ValueError(f"terms {unknown}: the {spec.name} program's terms are {', '.join(spec.terms) or '(none)'}")
    fits = {t: _as_fit(t, records[t]) for t in spec.fits if t in records}
    routines = tuple(with_domain(r) for r in spec(fits, terms))
    if claim is not None:
        unknown = sorted(set(claim.routines) - {r.name for r in routines})
        if unknown:
            raise KeyError(f"the claim names routines the {spec.name} program lacks: {', '.join(unknown)}")
        routines = tuple(replace(r, doc=f"{r.doc} {claim.routines[r.name]}") if r.name in claim.routines else r
                         for r in routines)  # fmt: skip
    material = material_of(routines, spec.material) if spec.material is not None else None
    return Program(routines, tuple(tuple(s) for s in sources), terms, spec.name,
                   tuple(spec.about.format(terms=", ".join(terms)).splitlines()), spec.doc, spec.parts, model,
                   material, claim=claim.lines if claim is not None else ())  # fmt: skip
