"""A third-party family whose entry point fails (it raises, names no family class, or its targets fail to import)
is left out in one line on stderr; the built-in families, ``fitlab --help``, ``refit --list`` and ``codegen`` work
as before."""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint

import pytest

import fitlab.core._registry as registry
from fitlab.cli import main

RAISES = """
from fitlab.core import Family, register_family


class HalfRegistered(Family, name="half_registered", description="registers, then fails", target_names=()):
    def targets(self):
        return ()

    def forms(self):
        return ()


register_family(HalfRegistered())
raise RuntimeError("broken on purpose\\nsecond line")
"""

#: a module of three entry points: no family class, a family whose targets fail to import, a working family
OTHERS = """
from fitlab.core import Family


class NotAFamily:
    pass


class FailingTargets(Family, name="failing_targets", description="its targets fail", target_names=("ft_x",)):
    def targets(self):
        raise ImportError("no module named ft_engine")

    def forms(self):
        return ()
"""


@pytest.fixture
def broken(monkeypatch, tmp_path):
    """Broken entry points (one raises after registering a family, one names a missing module, one names no family
    class, one a family whose targets fail to import); the registry loads again with them."""
    (tmp_path / "fitlab_test_broken_family.py").write_text(RAISES)
    (tmp_path / "fitlab_test_other_families.py").write_text(OTHERS)
    monkeypatch.syspath_prepend(str(tmp_path))
    eps = [
        EntryPoint("raises", "fitlab_test_broken_family", "fitlab.families"),
        EntryPoint("missing", "fitlab_test_no_such_module:family", "fitlab.families"),
        EntryPoint("no_class", "fitlab_test_other_families:NotAFamily", "fitlab.families"),
        EntryPoint("failing", "fitlab_test_other_families:FailingTargets", "fitlab.families"),
    ]
    monkeypatch.setattr(registry, "entry_points", lambda group: eps if group == "fitlab.families" else [])
    monkeypatch.setattr(registry, "_REGISTRY", registry._Registry())
    yield
    for module in ("fitlab_test_broken_family", "fitlab_test_other_families"):
        sys.modules.pop(module, None)


def _lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip()]


def test_refit_list_names_the_broken_ones_once_and_lists_the_others(broken, capsys):
    assert main(["refit", "--list"]) == 0
    out, err = capsys.readouterr()
    assert "H0" in out and "E_ggx_sep" in out  # both built-in families
    lines = _lines(err)
    assert len(lines) == 4, err
    assert "'raises'" in lines[0] and "RuntimeError: broken on purpose; second line" in lines[0]
    assert "'missing'" in lines[1] and "ModuleNotFoundError" in lines[1]
    assert "'no_class'" in lines[2] and "TypeError: fitlab_test_other_families:NotAFamily is no subclass" in lines[2]
    assert "'failing'" in lines[3] and "ImportError: no module named ft_engine" in lines[3]
    assert all("left out" in line for line in lines)
    assert "half_registered" not in registry.families()  # what it registered before it failed is gone
    assert "failing_targets" not in registry.families() and "ft_x" not in registry.target_names()
    assert set(registry.broken_families()) == {"raises", "missing", "no_class", "failing"}
    # where the listing came from the cache, the registry loaded only now and said the lines itself (once)
    capsys.readouterr()
    assert main(["refit", "--list"]) == 0  # loaded once: said once
    assert capsys.readouterr().err == ""


@pytest.mark.e2e
def test_help_and_codegen_work_beside_a_broken_family(broken, capsys, tmp_path):
    with pytest.raises(SystemExit) as exit_:
        main(["--help"])
    assert exit_.value.code == 0
    assert "refit" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_:
        main(["refit", "--help"])  # its help lists the targets: the families load here
    out, err = capsys.readouterr()
    assert exit_.value.code == 0 and "--target" in out and "H0" in out
    assert len(_lines(err)) >= 3 and "'raises'" in err and "'missing'" in err and "'no_class'" in err, err
    assert main(["codegen", "--lang", "python", "--out", str(tmp_path / "gen"), "--quiet"]) == 0
    assert (tmp_path / "gen" / "lambert_sphere.py").is_file()
    assert "Traceback" not in capsys.readouterr().err


def test_a_broken_builtin_family_is_still_an_error(monkeypatch):
    from fitlab.families.microfacet_energy import MicrofacetEnergy

    def failing(self):
        raise ImportError("built-in broken on purpose")

    monkeypatch.setattr(MicrofacetEnergy, "targets", failing)
    monkeypatch.setattr(registry, "_REGISTRY", registry._Registry())
    for _ in range(2):  # every time
        with pytest.raises(ImportError, match="built-in broken on purpose"):
            registry.targets()
    assert registry.get_target("H0").family == "lambert_sphere"  # the others work
