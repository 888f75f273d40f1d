"""Typed hook contracts (issue 32, item 3): what each family hook returns meets a typing.Protocol, checked when
the hook is resolved, with a one-line error naming the missing member; a family's codegen is checked when the
family registers."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from fitlab.core import (
    AuditHook,
    BrdfGrid,
    BrdfGridHook,
    Family,
    ImagesHook,
    RenderHook,
    ReportHook,
    TableExportHook,
    TablesHook,
    families,
    family_service,
    register_family,
    resolve_hook,
    unregister_family,
)
from fitlab.core._hooks import BENCHES, BrdfReportHook, _members


def _fn(*args, **kwargs):
    return None


def _full(protocol, **extra) -> SimpleNamespace:
    """An object with every member of ``protocol``, callables for its methods."""
    return SimpleNamespace(**{n: _fn for n in _members(protocol)}, **extra)


def _without(obj: SimpleNamespace, name: str) -> SimpleNamespace:
    return SimpleNamespace(**{k: v for k, v in vars(obj).items() if k != name})


@pytest.fixture
def toy():
    made = []

    def register(hooks, codegen=None):
        family = register_family(Family("toy_hooks", "a toy family", (), hooks=hooks, codegen=codegen))
        made.append(family.name)
        return family

    yield register
    for name in made:
        unregister_family(name)


@pytest.mark.parametrize("hook,protocol", [("tables", TablesHook), ("audit", AuditHook), ("render", RenderHook),
                                           ("report", ReportHook), ("table_export", TableExportHook),
                                           ("images", ImagesHook), ("brdf_grid", BrdfGridHook)])  # fmt: skip
def test_a_hook_that_lacks_a_member_is_refused_in_one_line_naming_it(toy, hook, protocol):
    complete = _full(protocol)
    for member in _members(protocol):
        toy({hook: lambda member=member: _without(complete, member)})
        with pytest.raises(TypeError) as err:
            family_service(hook, "toy_hooks")
        text = str(err.value)
        assert "\n" not in text and repr(member) in text and "toy_hooks" in text and protocol.__name__ in text
        unregister_family("toy_hooks")
    toy({hook: lambda: complete})
    assert family_service(hook, "toy_hooks") is complete
    assert resolve_hook("toy_hooks", hook) is complete


def test_a_method_member_must_be_callable(toy):
    toy({"audit": lambda: SimpleNamespace(audit=3)})
    with pytest.raises(TypeError, match="lacks 'audit'"):
        family_service("audit", "toy_hooks")


def test_a_bench_hook_needs_one_bench(toy):
    toy({"bench": lambda: SimpleNamespace(other=_fn)})
    with pytest.raises(TypeError) as err:
        family_service("bench", "toy_hooks")
    assert "\n" not in str(err.value) and all(repr(b) in str(err.value) for b in BENCHES)
    unregister_family("toy_hooks")
    toy({"bench": lambda: SimpleNamespace(bench_mc=_fn)})
    assert family_service("bench", "toy_hooks").bench_mc is _fn


def test_the_report_hook_of_a_brdf_family_gives_the_signature_and_settings(toy):
    """A report hook with exact_brdf is the measured BRDF's: it must give BRDF_INPUTS, REPORT_SETTINGS, ..."""
    complete = _full(BrdfReportHook, **{n: _fn for n in _members(ReportHook)})
    for member in ("BRDF_INPUTS", "REPORT_SETTINGS", "measure_engines", "engine_sections", "REPORT_TEXT"):
        toy({"report": lambda member=member: _without(complete, member)})
        with pytest.raises(TypeError, match=f"lacks '{member}' \\(fitlab.core.BrdfReportHook\\)"):
            resolve_hook("toy_hooks", "report")
        unregister_family("toy_hooks")


def test_a_plain_tuple_is_no_brdf_grid(toy):
    toy({"brdf_grid": lambda: (("mu_i",), _fn, "relative")})
    with pytest.raises(TypeError, match="lacks 'axes'"):
        resolve_hook("toy_hooks", "brdf_grid")
    unregister_family("toy_hooks")
    toy({"brdf_grid": lambda: BrdfGrid(("mu_i",), _fn, "relative")})
    axes, grid, measure = resolve_hook("toy_hooks", "brdf_grid")
    assert axes == ("mu_i",) and grid is _fn and measure == "relative"


def test_a_codegen_that_is_no_program_is_refused_when_the_family_registers():
    with pytest.raises(TypeError) as err:
        register_family(Family("toy_hooks", "a toy family", (), codegen=SimpleNamespace(name="toy")))
    assert "\n" not in str(err.value) and "'fits'" in str(err.value) and "ProgramContract" in str(err.value)
    assert "toy_hooks" not in families()


def test_the_builtin_families_meet_every_contract():
    for name, family in families().items():
        for hook in family.hooks:
            assert resolve_hook(name, hook) is not None
