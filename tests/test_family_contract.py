"""The family contract: a family is a :class:`fitlab.core.Family` subclass and each capability an abstract class
among its bases, checked by basedpyright where the family is instantiated and where a capability's method returns
its service; the registry checks at first use what only a value can say (its targets are the ones it names, its
forms fit its targets) and finds the families that have a capability without importing them."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import textwrap
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest

from fitlab.codegen import HasProgram, ProgramSpec
from fitlab.core import (
    Benchmarks,
    BrdfGrid,
    Capability,
    Dataset,
    Family,
    HasAudit,
    HasBenchmarks,
    HasBrdfGrid,
    HasImages,
    HasMaterials,
    HasMonteCarlo,
    HasRender,
    HasTableExport,
    HasTables,
    Input,
    MeasuredMaterial,
    Target,
    families,
    family_with,
    get_target,
    offering,
    register_family,
    target_names,
    unregister_family,
)
from fitlab.discover.library import HasLibraries, Library
from fitlab.export import ImageSpec
from fitlab.forms import Form
from fitlab.report.methods import HasBrdfReport, HasReport
from fitlab.scenes import Simulation

ROOT = Path(__file__).resolve().parents[1]
CAPABILITIES = (HasProgram, HasLibraries, HasTables, HasMonteCarlo, HasImages, HasBenchmarks, HasReport,
                HasBrdfReport, HasAudit, HasBrdfGrid, HasTableExport, HasRender, HasMaterials)  # fmt: skip


def _set():
    x = np.linspace(0.0, 1.0, 5)
    return Dataset({"x": x}, 1.0 + x, "x = k/4")


def _target(name: str, default_form: str = "line") -> Target:
    return Target(name=name, description="1 + x", variables=(Input("x", (0.0, 1.0)),), default_form=default_form,
                  published=(), training=_set, validation=_set)  # fmt: skip


def _form(target: str, name: str = "line", inputs=("x",)) -> Form:
    import sympy as sp

    a = sp.Symbol("a", real=True)
    return Form(target, name, inputs, ("a",), 1 + a * sp.Symbol(inputs[0], real=True), presets={"one": {"a": 1.0}})


def _toy(name: str, names: tuple[str, ...], made: tuple[Target, ...], forms: tuple[Form, ...]) -> Family:
    class Toy(Family, name=name, description="a toy family", target_names=names):
        def targets(self):
            return made

        def forms(self):
            return forms

    return Toy()


@pytest.fixture
def registered():
    names = []

    def register(family: Family) -> Family:
        register_family(family)
        names.append(family.name)
        return family

    target_names()  # the built-in families are known first
    yield register
    for name in names:
        unregister_family(name)


def test_the_builtin_families_meet_every_contract():
    """Every capability of every built-in family gives its service (imported now), with what its type promises."""
    for name, family in families().items():
        having = [c for c in CAPABILITIES if isinstance(family, c)]
        assert having or name == "fresnel", name
        own = set(family.target_names)
        if isinstance(family, HasProgram):
            spec = family.program()
            assert isinstance(spec, ProgramSpec) and set(spec.fits) <= own
        if isinstance(family, HasLibraries):
            libraries = family.libraries()
            assert libraries and set(libraries) <= own
            assert all(isinstance(lib, Library) and lib.target == t for t, libs in libraries.items() for lib in libs)
        if isinstance(family, HasTables):
            tables = family.tables()
            assert name == tables.FAMILY_NAME and len(tables.TABLE_FILES) > 0
        if isinstance(family, HasMonteCarlo):
            simulation = family.simulation()
            assert isinstance(simulation, Simulation) and simulation.schema.family == name
        if isinstance(family, HasImages):
            images = family.images()
            assert images and all(isinstance(spec, ImageSpec) for spec in images.values())
        if isinstance(family, HasBenchmarks):
            benchmarks = family.benchmarks()
            assert isinstance(benchmarks, Benchmarks) and any(vars(benchmarks).values())
        if isinstance(family, HasReport):
            assert set(family.report().PARTS) <= own
        if isinstance(family, HasBrdfGrid):
            grid = family.brdf_grid()
            assert isinstance(grid, BrdfGrid) and grid.axes
        if isinstance(family, HasTableExport):
            export = family.table_export()
            assert export.DEFAULT_NODES in export.NODES
        if isinstance(family, HasMaterials):
            materials = family.materials()
            assert materials and all(m.kind in ("conductor", "dielectric") for m in materials.values())
            assert all(
                isinstance(m, MeasuredMaterial) and m.F0.shape == m.F_avg.shape == (3,) for m in materials.values()
            )
    assert list(offering(HasBrdfReport)) == ["lambert_sphere"]  # the one BRDF the report measures


def test_family_with_names_the_families_that_have_a_capability_in_one_line(registered):
    assert family_with(HasMaterials).name == "fresnel"  # the one family that has it
    for name, call in (("fresnel", lambda: family_with(HasMonteCarlo, "fresnel")),
                       ("several", lambda: family_with(HasMonteCarlo)),
                       ("unknown", lambda: family_with(HasTables, "no_such_family"))):  # fmt: skip
        with pytest.raises(KeyError) as err:
            call()
        text = err.value.args[0]
        assert "\n" not in text, name
        if name == "fresnel":
            assert text == "family 'fresnel' has no Monte Carlo; families that have: lambert_sphere, microfacet_energy"
        if name == "several":
            assert text == ("2 families have Monte Carlo (lambert_sphere, microfacet_energy); name one with "
                            "--family")  # fmt: skip
        if name == "unknown":
            assert "unknown family 'no_such_family'" in text


def test_a_toy_capability_is_found_by_its_class_without_calling_it(registered):
    calls = []

    class Tagged(Capability):
        noun = "a tag"

        def tag(self) -> str:
            calls.append(1)
            return "tagged"

    class Toy(Family, Tagged, name="toy_tagged", description="a toy family", target_names=("toy_tag_x",)):
        def targets(self):
            return (_target("toy_tag_x"),)

        def forms(self):
            return (_form("toy_tag_x"),)

    registered(Toy())
    assert list(offering(Tagged)) == ["toy_tagged"] and calls == []
    assert family_with(Tagged).tag() == "tagged" and get_target("toy_tag_x").family == "toy_tagged"


def test_targets_that_differ_from_the_names_a_family_states_are_refused_at_first_use(registered):
    registered(_toy("toy_stale", ("toy_a", "toy_b"), (_target("toy_a"),), (_form("toy_a"),)))
    with pytest.raises(ValueError) as err:
        get_target("toy_a")
    assert str(err.value) == "family toy_stale names the targets toy_a, toy_b; its targets() gives toy_a"


@pytest.mark.parametrize("forms,message", [
    ((_form("toy_other"),), "form toy_other/line names a target the family does not have"),
    ((_form("toy_a"), _form("toy_a")), "form toy_a/line defined twice"),
    ((_form("toy_a", inputs=("y",)),), "form toy_a/line takes ('y',), not its target's inputs"),
    ((_form("toy_a", name="quadratic"),), "target toy_a's default form 'line' is not one of its forms"),
])  # fmt: skip
def test_forms_that_do_not_fit_their_targets_are_refused_at_first_use(registered, forms, message):
    registered(_toy("toy_forms", ("toy_a",), (_target("toy_a"),), forms))
    with pytest.raises(ValueError) as err:
        get_target("toy_a")
    assert str(err.value) == f"family toy_forms: {message}"


def test_a_target_name_is_one_familys(registered):
    with pytest.raises(ValueError, match=r"family toy_clash: target names \['H0'\] are taken"):
        registered(_toy("toy_clash", ("H0",), (), ()))
    registered(_toy("toy_one", ("toy_a",), (), ()))
    with pytest.raises(ValueError, match="a family named 'toy_one' is already registered"):
        registered(_toy("toy_one", ("toy_b",), (), ()))


STATIC = """
from collections.abc import Sequence

from fitlab.core import Family, HasTables, Tables, Target
from fitlab.forms import Form


class Base(Family, name="base", description="a toy family", target_names=()):
    def targets(self) -> Sequence[Target]:
        return ()

    def forms(self) -> Sequence[Form]:
        return ()


class NoTables(Base, HasTables, name="no_tables", description="lacks tables()", target_names=()):
    pass


class WrongModule(Base, HasTables, name="wrong_module", description="a module that is no Tables", target_names=()):
    def tables(self) -> Tables:
        from fitlab.families.fresnel.program import images

        return images


class ShortWriter:
    FAMILY_NAME = "short_writer"
    TABLE_FILES = ("a.csv",)

    def write_tables(self, out):
        return {}

    def check_tables(self, folder, *, show_progress=True):
        return []


class WrongSignature(Base, HasTables, name="wrong_signature", description="write_tables takes no options",
                     target_names=()):
    def tables(self) -> Tables:
        return ShortWriter()


class NoNames(Family, name="no_names", description="states no target names"):
    def targets(self) -> Sequence[Target]:
        return ()

    def forms(self) -> Sequence[Form]:
        return ()


FAMILIES = (NoTables(), WrongModule(), WrongSignature())
"""


@pytest.mark.e2e  # a few seconds: basedpyright's start
def test_basedpyright_checks_the_contract_statically(tmp_path):
    """What basedpyright checks rather than the registry at run time: a family that lacks a capability's method
    cannot be instantiated, a service that is no such service is no return value of its method, a family that
    states no target names is no class."""
    if importlib.util.find_spec("basedpyright") is None:
        pytest.skip('basedpyright is not installed (pip install -e ".[dev]")')
    path = tmp_path / "toy_families.py"
    path.write_text(textwrap.dedent(STATIC))
    run = subprocess.run([sys.executable, "-m", "basedpyright", "--outputjson", str(path)], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    found = {}
    for d in json.loads(run.stdout)["generalDiagnostics"]:
        line = STATIC.splitlines()[d["range"]["start"]["line"]]
        found.setdefault(line.strip(), []).append((d.get("rule"), d["message"]))
    assert set(found) == {"FAMILIES = (NoTables(), WrongModule(), WrongSignature())", "return images",
                          "return ShortWriter()", 'class NoNames(Family, name="no_names", description="states no '
                          'target names"):'}, found  # fmt: skip
    assert any(r == "reportAbstractUsage" and '"HasTables.tables" is not implemented' in m
               for r, m in found["FAMILIES = (NoTables(), WrongModule(), WrongSignature())"])  # fmt: skip
    assert any(r == "reportReturnType" and '"write_tables" is not present' in m for r, m in found["return images"])
    assert any(r == "reportReturnType" and '"write_tables" is an incompatible type' in m
               for r, m in found["return ShortWriter()"])  # fmt: skip
    assert any('"target_names"' in m for _, m in found[next(k for k in found if k.startswith("class NoNames"))])


def test_capabilities_are_mappings_of_their_families():
    """offering() keeps the order of families() and gives the family objects themselves."""
    every = families()
    for capability in CAPABILITIES:
        having = offering(capability)
        assert list(having) == [n for n in every if n in having]
        assert all(isinstance(f, capability) and every[n] is f for n, f in having.items())
    assert isinstance(offering(HasTables), Mapping)
