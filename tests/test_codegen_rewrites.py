"""A program's rewrites are its family's: a toy program with its own rewrite gets it
applied to its parts, and the Lambert sphere's rewrite (1 - sqrt(1 - c) -> c/(1 + sqrt(1 - c)), which knows
the family's albedo c) is applied to the Lambert sphere's routines only."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.codegen.rewriting import ReplaceOptim

from fitlab.codegen import STABLE, HasProgram, ProgramSpec, build_program, part_routine, program_spec, stable
from fitlab.core import Dataset, Family, Input, Target, register_family, unregister_family
from fitlab.forms import Form
from fitlab.store import FitFunction

c = sp.Symbol("c", real=True)
ALBEDO_FORM = 1 - sp.sqrt(1 - c)  # the Lambert sphere's cancellation, written in a toy family's input c
#: a toy family's own rewrite: sqrt(X) -> toy_sqrt(X)
TOY_SQRT = sp.Function("toy_sqrt")
TOY_REWRITE = ReplaceOptim(lambda e: e.is_Pow and e.exp == sp.S.Half, lambda e: TOY_SQRT(e.base))


def _set():
    x = np.linspace(0.0, 1.0, 11)
    return Dataset({"c": x}, 1.0 - np.sqrt(1.0 - x), "c = k/10")


def _family(name: str, program: ProgramSpec | None) -> Family:
    target = Target(
        name=f"{name}_t",
        description="1 - sqrt(1 - c)",
        variables=(Input("c", (0.0, 1.0), "albedo"),),
        default_form="plain",
        published=(),
        training=_set,
        validation=_set,
        routine=f"{name}_t",
    )
    form = Form(
        f"{name}_t",
        "plain",
        ("c",),
        ("a",),
        sp.Symbol("a", real=True) * ALBEDO_FORM,
        presets={"one": {"a": 1.0}},
        description="a (1 - sqrt(1 - c))",
    )

    class Toy(Family, name=name, description="a toy family", target_names=(target.name,)):
        def targets(self):
            return (target,)

        def forms(self):
            return (form,)

    if program is None:
        return Toy()

    class ToyWithProgram(Toy, HasProgram, name=name, description="a toy family", target_names=(target.name,)):
        def program(self) -> ProgramSpec:
            return program

    return ToyWithProgram()


def _fit(target: str) -> FitFunction:
    """A FitFunction of ``target``'s form at a = 1 (no file)."""
    fit = FitFunction.__new__(FitFunction)
    fit.record, fit.path, fit.target, fit.form = {"target": target, "form": "plain"}, None, target, "plain"
    fit.inputs, fit.params, fit.domain, fit.expression, fit.measured = (
        ("c",),
        {"a": 1.0},
        {"c": (0.0, 1.0)},
        ALBEDO_FORM,
        None,
    )
    fit._f = None
    return fit


@pytest.fixture
def toy_families():
    own = ProgramSpec(
        name="toy_own",
        fits=("toy_own_t",),
        parts=("toy_own_t",),
        rewrites=(TOY_REWRITE,),
        routines=lambda fits, terms: [part_routine(fits["toy_own_t"])],
    )
    register_family(_family("toy_own", own))
    register_family(_family("toy_plain", None))  # no program of its own: one routine per target
    try:
        yield
    finally:
        unregister_family("toy_own")
        unregister_family("toy_plain")


def test_a_program_with_its_own_rewrite_gets_it_applied(toy_families):
    program = build_program({"toy_own_t": _fit("toy_own_t")}, family="toy_own")
    expr = program.routine("toy_own_t").expr
    assert expr.has(TOY_SQRT) and not expr.has(sp.sqrt(1 - sp.Min(1, sp.Max(0, c))))
    assert program_spec("toy_own").rewrite(ALBEDO_FORM) == 1 - TOY_SQRT(1 - c)
    # only the program's: the generic rewrites are not added to a program that gives its own
    assert program_spec("toy_own").rewrites == (TOY_REWRITE,)


def test_the_lambert_rewrite_is_not_applied_to_another_familys_program(toy_families):
    from fitlab.families.lambert_sphere.program.rewrites import ALBEDO_ZERO, REWRITES
    from fitlab.families.lambert_sphere.program.rewrites import stable as lambert_stable

    assert program_spec("toy_plain").rewrites == STABLE and ALBEDO_ZERO not in STABLE
    program = build_program({"toy_plain_t": _fit("toy_plain_t")}, family="toy_plain")
    clamped = sp.Min(1.0, sp.Max(0.0, c))
    assert program.routine("toy_plain_t").expr == 1 - sp.sqrt(1 - clamped)  # as it stands, but clamped
    assert stable(ALBEDO_FORM) == ALBEDO_FORM
    # the Lambert sphere's program rewrites it, in its own routines
    assert program_spec("lambert_sphere").rewrites == REWRITES
    assert lambert_stable(ALBEDO_FORM) == c / (1 + sp.sqrt(1 - c))
    assert part_routine(_fit("toy_plain_t"), REWRITES).expr == c / (1 + sp.sqrt(1 - c))
    # the microfacet_energy program takes the generic rewrites alone
    assert program_spec("microfacet_energy").rewrites == STABLE


def test_the_lambert_rewrites_are_optimisations_that_keep_the_old_order():
    """The program's rewrites as sympy.codegen.rewriting optimisations give what the one function stable() gave
    (one minus squares, then 1 - sqrt(1 - c), then 1 - (1 - x)^p)."""
    from sympy.codegen.rewriting import Optimization

    from fitlab.families.lambert_sphere.program.rewrites import FLOOR_POLES, POLE_FLOOR, REWRITES, azimuth_to_cosine

    assert all(isinstance(o, Optimization) for o in REWRITES)
    mu_i, mu_o, phi, cos_phi = (sp.Symbol(n, real=True) for n in ("mu_i", "mu_o", "phi", "cos_phi"))
    assert FLOOR_POLES(c / (mu_i + mu_o) ** 2) == c / sp.Max(mu_i + mu_o, POLE_FLOOR) ** 2
    assert azimuth_to_cosine(sp.cos(phi) + sp.Abs(phi)) == cos_phi + sp.acos(cos_phi)
    with pytest.raises(ValueError, match="cos\\(phi\\) alone"):
        azimuth_to_cosine(sp.sin(phi))


# ---- one-pass substitutions: what sympy's subs gives ---------------------------------------------------------

_x, _y = sp.symbols("x y", real=True)
_s = sp.sqrt(1 - c)
#: leaves that hold the old sum, its terms, their negatives and numbers beside them
_LEAVES = (
    _x,
    _y,
    c,
    _s,
    -_s,
    1 - _s,
    2 - _s,
    _s - 1,
    3 * _s,
    _x - _s,
    sp.Rational(3, 2),
    sp.Float(0.25),
    sp.Integer(2),
)


def _expressions():
    from hypothesis import strategies as st

    def grow(children):
        pair = st.tuples(children, children)
        return st.one_of(
            pair.map(lambda p: p[0] + p[1]),
            pair.map(lambda p: p[0] * p[1]),
            pair.map(lambda p: p[0] - 2 * p[1]),
            children.map(lambda a: a**2),
            children.map(sp.sqrt),
            children.map(sp.exp),
            children.map(lambda a: sp.Max(0, a)),
            pair.map(lambda p: sp.Min(p[0], p[1] + _x)),
            pair.map(lambda p: sp.Piecewise((p[0], _x < p[1]), (p[1], True))),
        )

    return st.recursive(st.sampled_from(_LEAVES), grow, max_leaves=12)


def test_sum_subs_gives_what_subs_gives():
    """SumSubsOptim(old, new) == expr.subs(old, new), structurally, on random trees holding old's terms in
    every position (a whole sum, inside a larger one, negated, scaled, under max, min, powers and branches)."""
    from hypothesis import given, settings

    from fitlab.codegen import SumSubsOptim

    new = c / (1 + _s)
    rewrites = [(old, SumSubsOptim(old, new)) for old in (1 - _s, 2 - _x - _s)]

    @settings(max_examples=300, deadline=None, derandomize=True)
    @given(_expressions())
    def check(e):
        for old, rewrite in rewrites:
            assert rewrite(e) == e.subs(old, new), (e, old)

    check()
    with pytest.raises(ValueError, match="rational constant term"):
        SumSubsOptim(_x, new)


def test_azimuth_to_cosine_gives_what_subs_gives_on_the_runtime_terms():
    """The runtime terms and the single scattering, phi -> cos phi in one pass, are what sympy's subs gives."""
    from fitlab.families.lambert_sphere.forms.brdf import ORDER2_PART, RUNTIME_PARTS, SINGLE, runtime_terms
    from fitlab.families.lambert_sphere.program.rewrites import AZIMUTH_TO_COSINE, azimuth_to_cosine
    from fitlab.families.lambert_sphere.targets import TARGETS

    phi = sp.Symbol("phi", real=True)
    calls = {p: sp.Function(TARGETS[p].routine)(*(sp.Symbol(a, real=True) for a in TARGETS[p].inputs))
             for p in (*RUNTIME_PARTS, ORDER2_PART)}  # fmt: skip
    exprs = (SINGLE, *runtime_terms(calls).values())
    assert sum(phi in e.free_symbols for e in exprs) >= 2
    for e in exprs:
        assert azimuth_to_cosine(e) == e.subs(AZIMUTH_TO_COSINE.mapping)


def test_rebuilt_keeps_max_and_min_unevaluated_unless_all_numbers():
    from fitlab.codegen import rebuilt

    e = sp.Max(0, _x + _y) + sp.Min(1, _x)
    out = rebuilt(e, lambda n: {_x: c, _y: sp.Integer(-3)}.get(n, n))
    assert out == sp.Max(0, c - 3, evaluate=False) + sp.Min(1, c, evaluate=False)
    assert rebuilt(sp.Max(_x, _y), lambda n: {_x: sp.Integer(2), _y: sp.Integer(5)}.get(n, n)) == 5
    assert rebuilt(e, lambda n: n) is e  # nothing changed: the same object
