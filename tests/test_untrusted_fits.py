"""Fit files are data: a zoo of hostile files, each refused with one line and no side effect.

Every file is refused by fitlab.store.load, by `fitlab refit --init`, by `fitlab codegen --fits`
and by `fitlab report --fits`, and nothing it holds is ever run: the canary file that the
code in the zoo would create never appears.
"""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path

import pytest

from fitlab.cli import main
from fitlab.store import FitFileError, fit_schema, load, read_fit

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"


def _base(name="m.json"):
    return json.loads((FITS / name).read_text())


def _zoo(canary: Path):
    code = f"__import__('os').system('touch {canary}') or c"
    zoo = {}

    def add(label, mutate, name="m.json", source="m.json", raw=None):
        rec = _base(source)
        if mutate is not None:
            mutate(rec)
        zoo[label] = (name, raw if raw is not None else json.dumps(rec))

    add("code in expression", lambda r: r.update(expression=code))
    add("code in discovered expression", lambda r: r.update(expression=code, form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("dunder name", lambda r: r.update(expression="c.__class__.__mro__", form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("lambda", lambda r: r.update(expression="(lambda: c)()", form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("code in target", lambda r: r.update(target=code))
    add("code in form", lambda r: r.update(form=code))
    add("code in a description", lambda r: r.update(form_description='*/ system("rm -rf /"); /*'))
    add("quote in a description", lambda r: r.update(note='"""\nimport os\n"""'))
    add("dunder param", lambda r: r.update(params={"__class__": 1.0}))
    add("huge parameter", lambda r: r["params"].update(m1=1e300))
    add("nan parameter (string)", lambda r: r["params"].update(m1="nan"))
    add("inf parameter (literal)", None, raw=(FITS / "m.json").read_text().replace('"m1": ', '"m1": Infinity, "x": ', 1))
    add("NaN literal", None, raw='{"format": "fitlab-fit/1", "params": {"a": NaN}}')
    add("deep nesting", None, raw="[" * 100_000 + "]" * 100_000)
    add("huge exponent", lambda r: r.update(expression="c**99999999999", form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("deep expression", lambda r: r.update(expression="(" * 300 + "c" + ")" * 300, form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("wrong type: domain", lambda r: r.update(domain="abc"))
    add("wrong type: inputs", lambda r: r.update(inputs=5))
    add("wrong type: params", lambda r: r.update(params=[1, 2]))
    add("short domain", lambda r: r.update(domain={"c": [0]}))
    add("domain outside", lambda r: r.update(domain={"c": [-5, 50]}))
    add("unknown input", lambda r: r.update(inputs=["z"], domain={"z": [0, 1]}))
    add("another target under this name", None, name="H0.json", source="H1.json")
    add("another form under this name", None, name="H0.json", source="H0.hapke_rational.json")
    add("expression not the registered form's", lambda r: r.update(expression="c"))
    add("missing format", lambda r: r.pop("format"))
    add("wrong format", lambda r: r.update(format="fitlab-fit/0"))
    add("unknown field", lambda r: r.update(payload="x"))
    add("not an object", None, raw="[1, 2, 3]")
    add("not JSON", None, raw="{'format': ")
    add("binary", None, raw="\udcff\x00")
    return zoo


@pytest.fixture(scope="module")
def canary(tmp_path_factory):
    return tmp_path_factory.mktemp("canary") / "ran"


@pytest.fixture(scope="module")
def zoo(canary):
    return _zoo(canary)


def _write(folder: Path, name: str, raw: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(raw.encode("utf-8", "surrogateescape"))
    return path


def test_the_schema_accepts_every_committed_fit():
    assert fit_schema()["properties"]["format"] == {"const": "fitlab-fit/1"}
    for path in sorted(FITS.glob("*.json")):
        assert read_fit(path)["target"] == path.name.split(".")[0]


@pytest.mark.parametrize("label", list(_zoo(Path("/nonexistent")).keys()))
def test_load_refuses_each_hostile_file(zoo, canary, tmp_path, label):
    name, raw = zoo[label]
    path = _write(tmp_path, name, raw)
    with pytest.raises(FitFileError) as info:
        load(path)
    assert "\n" not in str(info.value) and len(str(info.value)) < 400
    assert not canary.exists()


@pytest.mark.parametrize("label", ["code in expression", "huge parameter", "wrong type: domain", "another target under this name",
                                   "deep nesting", "NaN literal", "code in a description"])
def test_refit_init_refuses_hostile_files(zoo, canary, tmp_path, capsys, label):
    name, raw = zoo[label]
    path = _write(tmp_path / "init", name, raw)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["refit", "--target", "m", "--init", str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert list(out.iterdir()) == [] and not canary.exists()


@pytest.mark.parametrize("label", ["code in expression", "another target under this name", "code in a description",
                                   "huge parameter"])
def test_codegen_refuses_hostile_fits(zoo, canary, tmp_path, capsys, label):
    name, raw = zoo[label]
    fits = tmp_path / "fits"
    shutil.copytree(FITS, fits, ignore=shutil.ignore_patterns("generated"))
    _write(fits, name if name != "m.sr_1_abcdef.json" else "m.json", raw)
    out = tmp_path / "gen"
    # the default-forms model reads the files the zoo replaces (m.json, H0.json, ...)
    code = main(["codegen", "--lang", "c", "--fits", str(fits), "--out", str(out), "--model", "default-forms"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "Traceback" not in err
    assert not out.exists() or list(out.iterdir()) == []
    assert not canary.exists()


@pytest.mark.parametrize("label", ["code in discovered expression", "another target under this name", "huge parameter",
                                   "code in a description"])
def test_report_refuses_hostile_fits_before_any_work(zoo, canary, tmp_path, capsys, monkeypatch, label):
    import fitlab.report.run as report_run

    def no_work(*args, **kwargs):  # the validation sets must not be computed for a refused folder
        raise AssertionError("the report started computing")

    monkeypatch.setattr(report_run, "_measure", no_work)
    name, raw = zoo[label]
    fits = tmp_path / "fits"
    shutil.copytree(FITS, fits, ignore=shutil.ignore_patterns("generated"))
    _write(fits, name, raw)
    out = tmp_path / "docs"
    code = main(["report", "--quick", "--fits", str(fits), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.count("\n") == 0 and "Traceback" not in err and "report started" not in err
    assert not out.exists() or list(out.iterdir()) == []
    assert not canary.exists()
