"""The registry is lazy: resolving a target imports its own family only, and the names of every target (``refit
--help``, ``--target`` checks) and the families offering a hook come from the families' manifests, importing no
family; a family that differs from its manifest is refused at registration."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from fitlab.core import Family, Target, families, target_names, targets
from fitlab.core._registry import _check_manifest, _Pending, manifest_hooks

PROBE = r'''
import json, sys
import fitlab.cli
from fitlab.cli.refit import _requested, add_arguments  # what `fitlab refit` imports
from fitlab.core import families_offering, get_target, target_names
from fitlab.codegen import model_form
from fitlab.store import resolve_form

loaded = lambda: sorted(m for m in sys.modules if m.startswith("fitlab.families."))
names = target_names()
offering = families_offering("tables")
before = loaded()
target = get_target("H0")  # as refit resolves --target H0: the target, its default model form, the form
form = resolve_form("H0", model_form("H0"), None)
import fitlab.fit.refit  # the fit itself: optimistix and JAX
print(json.dumps({"names": list(names), "offering": offering, "before": before, "after": loaded(),
                  "form": form.name, "forms": list(target.forms),
                  "scipy": sorted(m for m in sys.modules if m == "scipy" or m.startswith("scipy."))}))
'''


@pytest.fixture(scope="module")
def probe():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=600, check=True)
    return json.loads(out.stdout.splitlines()[-1])


def test_resolving_h0_imports_no_module_of_another_family(probe):
    assert probe["form"] in probe["forms"]
    assert any(m.startswith("fitlab.families.lambert_sphere") for m in probe["after"])
    assert [m for m in probe["after"] if not m.startswith("fitlab.families.lambert_sphere")] == []


def test_refit_imports_no_scipy(probe):
    """The exact engine imports scipy where it computes: a refit reads its exact values from the cache, and
    scipy's integrate and optimize were about a third of a second of its start (issue 32, item 6)."""
    assert probe["scipy"] == []


def test_target_names_and_hook_offers_import_no_family(probe):
    assert probe["before"] == []  # target_names() and families_offering() read the manifests only
    assert "H0" in probe["names"] and "E_ggx_sep" in probe["names"] and "F_cu_r" in probe["names"]
    assert probe["offering"] == ["fresnel", "lambert_sphere", "microfacet_energy"]


def test_the_manifests_name_every_target_in_order():
    assert target_names() == tuple(targets())
    for name, family in families().items():
        assert all(t.family == name for t in family.targets)


def test_a_family_that_differs_from_its_manifest_is_refused():
    target = Target(name="lazy_x", description="x", variables=(), default_form="f", published=(),
                    training=lambda: None, validation=lambda: None)  # fmt: skip
    family = Family("lazy_toy", "a toy", (target,), hooks=manifest_hooks("fitlab", {"tables": "store"}))
    pending = _Pending(name="lazy_toy", module="lazy_toy", targets=("lazy_x",), hooks=family.hooks,
                       default_program=False, program=False)  # fmt: skip
    _check_manifest(family, pending)  # as stated: no error
    stale = _Pending(name="lazy_toy", module="lazy_toy", targets=("lazy_x", "lazy_y"), hooks=family.hooks,
                     default_program=False, program=False)  # fmt: skip
    with pytest.raises(ValueError, match="its MANIFEST .* lists the targets lazy_x, lazy_y; it registers lazy_x"):
        _check_manifest(family, stale)
    no_hooks = _Pending(name="lazy_toy", module="lazy_toy", targets=("lazy_x",), hooks={}, default_program=False,
                        program=False)  # fmt: skip
    with pytest.raises(ValueError, match="lists the hooks ; it registers tables"):
        _check_manifest(family, no_hooks)


def test_a_manifest_hook_imports_its_module_when_called():
    import fitlab.store

    hooks = manifest_hooks("fitlab", {"module": "store", "attr": "store:PARAM_LIMIT", "call": "core:target_names()"})
    assert hooks["module"]() is fitlab.store
    assert hooks["attr"]() == fitlab.store.PARAM_LIMIT
    assert hooks["call"]() == target_names()
