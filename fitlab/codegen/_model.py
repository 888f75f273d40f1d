r"""The data of a program: a :class:`Routine` (one generated function), a :class:`Program` (the routines of one
generated file set), a :class:`ProgramSpec` (what a family prints), its :class:`Model` (a named choice of fits)
and :class:`Claim` (the accuracy of the model as a whole), and the per-material set-up
(:class:`MaterialSpec`, :class:`Material`).

A routine's expression calls other routines through undefined sympy functions (``call("h0", mu_i, c)``), so
that a model assembled from parts reads as the sum of its terms and each part is evaluated once per call.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

import sympy as sp
from sympy.codegen.rewriting import Optimization

from fitlab.codegen._rewrites import STABLE, stable

if TYPE_CHECKING:
    from fitlab.store import FitFunction

__all__ = [
    "DEFAULT_FORMS",
    "Model",
    "Routine",
    "Program",
    "Claim",
    "ProgramSpec",
    "MaterialSpec",
    "Material",
    "outputs",
    "symbols_of",
]

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
    (:func:`.with_domain`, applied by :func:`.build_program` to every routine; each
    argument must have one).
    out: the name of a 3-vector the routine gives besides its value (a sampler's direction), or "";
    then ``expr`` is ``sp.Tuple(value, x, y, z)`` (:func:`outputs`), printed as a C function that
    returns the value and writes ``out[3]``, a numpy function that returns (vector, value), and a
    shader function that returns vec4(x, y, z, value).
    inline: the routines it calls are put in its body when the program is built (:func:`.build_program`), so that
    work its callees share is done once per call (a composed model's one log per direction, where each term
    would take its own); the callees stay routines of their own.
    """

    name: str
    args: tuple[str, ...]
    expr: sp.Expr
    doc: str
    vectors: dict = field(default_factory=dict)
    domain: dict = field(default_factory=dict)
    out: str = ""
    inline: bool = False

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
    """What a family prints (the ``program()`` of a family that is a :class:`fitlab.codegen.HasProgram`).

    name: the generated files' base name and the functions' prefix.
    fits: the targets whose fits the program is built from, in the order of the banner.
    parts: those of them printed as one routine each, their fit as it stands (:func:`.part_routine`).
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
        optimisations, applied in order by :meth:`rewrite`): :func:`.part_routine` applies them to every part
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


@dataclass(frozen=True)
class MaterialSpec:
    """What a program's per-material set-up holds (the ``material`` of a :class:`ProgramSpec`).

    params: the material's parameters (Lambert sphere: ("c",)): every subexpression of an evaluator
        that depends on them alone is computed once per material (:func:`.material_of`).
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
    evaluators: routines whose expressions read the fields as the symbols :func:`.field_symbol`
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


def symbols_of(expr: sp.Basic) -> set[sp.Symbol]:
    """``expr.free_symbols``, which sympy annotates as a set of Basic: a routine's are symbols."""
    return cast("set[sp.Symbol]", expr.free_symbols)
