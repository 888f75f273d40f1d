"""The registry is lazy: knowing the families is importing their classes only (``fitlab.families.BUILTIN``), which
name their targets; resolving a target imports its own family's modules only, and the names of every target
(``refit --help``, ``--target`` checks) and the families that have a capability come from the classes; a
capability's service is imported when its method is called."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

from fitlab.core import families, target_names, targets

ROOT = Path(__file__).resolve().parents[1]
#: the packages whose import declares a built-in family: its class, nothing else
DECLARATIONS = ["fitlab.families.fresnel", "fitlab.families.lambert_sphere", "fitlab.families.microfacet_energy"]

PROBE = r"""
import json, sys
import fitlab.cli
from fitlab.cli.refit import _requested, add_arguments  # what `fitlab refit` imports
from fitlab.core import HasMonteCarlo, HasTables, get_target, offering, target_names
from fitlab.codegen import family_programs, model_form
from fitlab.store import resolve_form

loaded = lambda: sorted(m for m in sys.modules if m.startswith("fitlab.families."))
names = target_names()
having = {"tables": list(offering(HasTables)), "monte carlo": list(offering(HasMonteCarlo))}
programs = family_programs()
before = loaded()
target = get_target("H0")  # as refit resolves --target H0: the target, its default model form, the form
form = resolve_form("H0", model_form("H0"), None)
import fitlab.fit.refit  # the fit itself: optimistix and JAX
after = loaded()
tables = offering(HasTables)["fresnel"].tables()  # a service: its module is imported now
print(json.dumps({"names": list(names), "having": having, "programs": programs, "before": before, "after": after,
                  "form": form.name, "forms": list(target.forms), "tables": tables.__name__,
                  "with_tables": loaded(),
                  "scipy": sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))}))
"""


@pytest.fixture(scope="module")
def probe():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=600, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def test_resolving_h0_imports_no_module_of_another_family_but_its_class(probe):
    assert probe["form"] in probe["forms"]
    assert any(m.startswith("fitlab.families.lambert_sphere.") for m in probe["after"])
    others = [m for m in probe["after"] if not m.startswith("fitlab.families.lambert_sphere")]
    assert others == [d for d in DECLARATIONS if d != "fitlab.families.lambert_sphere"]


def test_refit_imports_no_scipy(probe):
    """The exact engine imports scipy where it computes: a refit reads its exact values from the cache, and
    scipy's integrate and optimize were about a third of a second of its start."""
    assert probe["scipy"] == []


def test_target_names_and_capabilities_import_no_family_module_but_the_classes(probe):
    assert probe["before"] == DECLARATIONS  # target_names() and offering() read the classes only
    assert "H0" in probe["names"] and "E_ggx_sep" in probe["names"] and "F_cu_r" in probe["names"]
    assert probe["having"] == {"tables": ["fresnel", "lambert_sphere", "microfacet_energy"],
                               "monte carlo": ["lambert_sphere", "microfacet_energy"]}  # fmt: skip


def test_family_programs_reads_the_classes_and_agrees_with_the_built_families(probe):
    """What the codegen cache keys (which families have a program, which declares the default), read before any
    family's targets are imported (``before``), against the families built and the rule that chooses."""
    from fitlab.codegen import HasProgram, default_program_family

    built = families()
    default = default_program_family()
    assert [tuple(p) for p in probe["programs"]] == [
        (name, isinstance(f, HasProgram), name == default) for name, f in built.items()
    ]


def test_a_service_is_imported_when_its_method_is_called(probe):
    assert probe["tables"] == "fitlab.families.fresnel.targets.tabulate"
    assert "fitlab.families.fresnel.targets.tabulate" not in probe["after"]
    assert "fitlab.families.fresnel.targets.tabulate" in probe["with_tables"]


def test_the_classes_name_every_target_in_order():
    assert target_names() == tuple(targets())
    for name, family in families().items():
        assert tuple(t.name for t in family.targets()) == family.target_names
        assert all(t.family == name for t in family.targets())


def _imported(node: ast.AST) -> list[str]:
    if isinstance(node, ast.Import):
        return [a.name for a in node.names]
    if isinstance(node, ast.ImportFrom):
        return [node.module or ""]
    return []


@pytest.mark.parametrize("package", DECLARATIONS)
def test_a_declaration_imports_its_own_modules_only_inside_its_methods(package):
    """A family's package imports, at its top, the contract (fitlab's generic packages) and typing only: its targets,
    forms and services are imported inside the methods that return them."""
    path = ROOT / Path(*package.split(".")) / "__init__.py"
    tree = ast.parse(path.read_text())
    top = [m for node in tree.body for m in _imported(node)]
    top += [m for node in tree.body if isinstance(node, ast.If) for child in node.body for m in _imported(child)]
    assert top and not [m for m in top if m.startswith("fitlab.families")], top
    inside = [m for node in ast.walk(tree) if isinstance(node, ast.FunctionDef) for child in ast.walk(node)
              for m in _imported(child)]  # fmt: skip
    assert inside and all(m.startswith(package + ".") or m == package for m in inside), inside


def test_the_lazy_codegen_names_are_listed_once_in_each_place():
    """fitlab.codegen keeps its public names three times, for three readers: ``_LAZY`` (the import on first use),
    ``__all__`` (ruff, mkdocstrings) and the TYPE_CHECKING imports (basedpyright); they must name the same set,
    each from the module that defines it."""
    import ast
    import importlib
    import inspect

    import fitlab.codegen as codegen

    lazy = codegen._LAZY
    assert sorted(codegen.__all__) == sorted(["LANGUAGE_NAMES", "LOOKUPS", *lazy])
    tree = ast.parse(inspect.getsource(codegen))
    guarded = next(n for n in tree.body if isinstance(n, ast.If) and ast.unparse(n.test) == "TYPE_CHECKING")
    typed = {a.name: node.module for node in guarded.body if isinstance(node, ast.ImportFrom) for a in node.names}
    assert typed == lazy
    for name, module in lazy.items():
        assert hasattr(importlib.import_module(module), name), (name, module)
