"""A third-party family whose entry point fails to load is left out in one line on stderr; the built-in
families, ``fitlab --help``, ``refit --list`` and ``codegen`` work as before."""

from __future__ import annotations

import sys
from importlib.metadata import EntryPoint

import pytest

import fitlab.core._registry as registry
from fitlab.cli import main

RAISES = '''
from fitlab.core import Family, register_family
from fitlab.core._registry import _FAMILIES

register_family(Family(name="half_registered", description="registers, then fails", targets=()))
raise RuntimeError("broken on purpose\\nsecond line")
'''


@pytest.fixture
def broken(monkeypatch, tmp_path):
    """Two broken entry points (one raises after registering a family, one names a missing module); the
    registry loads again with them."""
    (tmp_path / "fitlab_test_broken_family.py").write_text(RAISES)
    monkeypatch.syspath_prepend(str(tmp_path))
    eps = [EntryPoint("raises", "fitlab_test_broken_family", "fitlab.families"),
           EntryPoint("missing", "fitlab_test_no_such_module:family", "fitlab.families")]
    monkeypatch.setattr(registry, "entry_points", lambda group: eps if group == "fitlab.families" else [])
    monkeypatch.setattr(registry, "_LOADED", False)
    monkeypatch.setattr(registry, "_BROKEN", {}, raising=False)
    yield
    sys.modules.pop("fitlab_test_broken_family", None)
    registry.unregister_family("half_registered")


def _lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.strip()]


def test_refit_list_names_the_broken_ones_once_and_lists_the_others(broken, capsys):
    assert main(["refit", "--list"]) == 0
    out, err = capsys.readouterr()
    assert "H0" in out and "E_ggx_sep" in out  # both built-in families
    lines = _lines(err)
    assert len(lines) == 2, err
    assert "'raises'" in lines[0] and "RuntimeError: broken on purpose; second line" in lines[0]
    assert "'missing'" in lines[1] and "ModuleNotFoundError" in lines[1]
    assert all("left out" in line for line in lines)
    assert "half_registered" not in registry.families()  # what it registered before it failed is gone
    assert set(registry.broken_families()) == {"raises", "missing"}
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
    assert len(_lines(err)) == 2 and "'raises'" in err and "'missing'" in err, err
    assert main(["codegen", "--lang", "python", "--out", str(tmp_path / "gen"), "--quiet"]) == 0
    assert (tmp_path / "gen" / "lambert_sphere.py").is_file()
    assert "Traceback" not in capsys.readouterr().err


def test_a_broken_builtin_family_is_still_an_error(monkeypatch):
    import importlib

    real = importlib.import_module

    def failing(name, *args):
        if name == "fitlab.families.microfacet_energy":
            raise ImportError("built-in broken on purpose")
        return real(name, *args)

    monkeypatch.setattr(registry.importlib, "import_module", failing)
    monkeypatch.setattr(registry, "_LOADED", False)
    with pytest.raises(ImportError, match="built-in broken on purpose"):
        registry.targets()
