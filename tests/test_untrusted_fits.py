"""Fit files are data: a zoo of hostile files, each refused with one line and no side effect.

Every file is refused by fitlab.store.load, by `fitlab refit --init`, by `fitlab codegen --fits`
and by `fitlab report --fits`, and nothing it holds is ever run: the canary file that the
code in the zoo would create never appears.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp

from fitlab.cli import main
from fitlab.forms.symbolic import parse_expression
from fitlab.store import FitFileError, fit_schema, load, read_fit

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"


def _base(name="m.json"):
    return json.loads((FITS / name).read_text())


#: expressions whose numbers are too large to form, or not finite, or not real
NUMBERS = {
    "tower of powers": "c*((((2**64)**64)**64)**64)",
    "power of a coefficient": "((2*c)**64)**64 + m1",
    "powers combined beyond the limit": "(c**16)**8 + m1",
    "integer literal of 400 digits": "c*" + "7" * 400 + " + m1",
    "nan: 0/0": "m1*c*(0/0)",
    "overflow: 1e308*1e308": "m1*c*1e308*1e308",
    "overflow: exp(800)": "exp(800)*c + m1",
    "underflow: 1e-200*1e-200": "c*(1e-200*1e-200) + m1",
    "complex: acos(2)": "acos(2)*c + m1",
    "complex: sqrt(-1)": "sqrt(-1)*c + m1",
    "complex: (-8)**(1/3)": "(-8)**(1/3)*c + m1",
    "complex: sqrt(-c**2)": "sqrt(-c**2) + m1",
    "division by zero: c/0": "c/0 + m1",
    "division by zero: c/(c - c)": "m1/(c - c)",
    "log(0)": "log(0)*c + m1",
}


def _zoo(canary: Path):
    code = f"__import__('os').system('touch {canary}') or c"
    zoo = {}

    def add(label, mutate, name="m.json", source="m.json", raw=None):
        rec = _base(source)
        if mutate is not None:
            mutate(rec)
        zoo[label] = (name, raw if raw is not None else json.dumps(rec))

    add("code in expression", lambda r: r.update(expression=code))
    add(
        "code in discovered expression",
        lambda r: r.update(expression=code, form="sr_1_abcdef"),
        name="m.sr_1_abcdef.json",
    )
    add(
        "dunder name",
        lambda r: r.update(expression="c.__class__.__mro__", form="sr_1_abcdef"),
        name="m.sr_1_abcdef.json",
    )
    add("lambda", lambda r: r.update(expression="(lambda: c)()", form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add("code in target", lambda r: r.update(target=code))
    add("code in form", lambda r: r.update(form=code))
    add("code in a description", lambda r: r.update(form_description='*/ system("rm -rf /"); /*'))
    add("quote in a description", lambda r: r.update(note='"""\nimport os\n"""'))
    add("dunder param", lambda r: r.update(params={"__class__": 1.0}))
    add("huge parameter", lambda r: r["params"].update(m1=1e300))
    add("nan parameter (string)", lambda r: r["params"].update(m1="nan"))
    add(
        "inf parameter (literal)", None, raw=(FITS / "m.json").read_text().replace('"m1": ', '"m1": Infinity, "x": ', 1)
    )
    add("NaN literal", None, raw='{"format": "fitlab-fit/1", "params": {"a": NaN}}')
    add("deep nesting", None, raw="[" * 100_000 + "]" * 100_000)
    add("huge exponent", lambda r: r.update(expression="c**99999999999", form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
    add(
        "deep expression",
        lambda r: r.update(expression="(" * 300 + "c" + ")" * 300, form="sr_1_abcdef"),
        name="m.sr_1_abcdef.json",
    )
    for label, text in NUMBERS.items():
        add(label, lambda r, text=text: r.update(expression=text, form="sr_1_abcdef"), name="m.sr_1_abcdef.json")
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


@pytest.mark.parametrize(
    "label",
    [
        "code in expression",
        "huge parameter",
        "wrong type: domain",
        "another target under this name",
        "deep nesting",
        "NaN literal",
        "code in a description",
    ],
)
def test_refit_init_refuses_hostile_files(zoo, canary, tmp_path, capsys, label):
    name, raw = zoo[label]
    path = _write(tmp_path / "init", name, raw)
    out = tmp_path / "out"
    out.mkdir()
    assert main(["refit", "--target", "m", "--init", str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert list(out.iterdir()) == [] and not canary.exists()


@pytest.mark.parametrize(
    "label", ["code in expression", "another target under this name", "code in a description", "huge parameter"]
)
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


@pytest.mark.parametrize(
    "label, reason",
    [
        ("complex: sqrt(-1)", "expression part 'sqrt(-1)' has no finite real value"),
        ("overflow: 1e308*1e308", "expression part '1e308' is beyond 1e+300 in magnitude"),
        ("nan: 0/0", "expression part '0/0' divides by zero"),
        ("division by zero: c/0", "expression part 'c/0' divides by zero"),
    ],
)
def test_codegen_refuses_a_discovered_form_with_numbers_out_of_bounds(zoo, tmp_path, capsys, label, reason):
    name, raw = zoo[label]
    fits = tmp_path / "fits"
    shutil.copytree(FITS, fits, ignore=shutil.ignore_patterns("generated"))
    path = _write(fits, name, raw)
    out = tmp_path / "gen"
    code = main(["codegen", "--lang", "c", "--fits", str(fits), "--out", str(out), "--model", "default-forms",
                 "--form", "m=sr_1_abcdef"])  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert (code, err) == (2, f"fitlab codegen: error: {path}: {reason}")
    assert not out.exists() or list(out.iterdir()) == []


@pytest.mark.parametrize(
    "label",
    ["code in discovered expression", "another target under this name", "huge parameter", "code in a description"],
)
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


@pytest.mark.parametrize(
    "text, message",
    [
        ("c*(((2**64)**64)**64)", "part '(2**64)**64' is beyond 1e+300 in magnitude"),  # six levels: in a child, below
        ("((2*c)**64)**64", "part '((2*c)**64)**64' would make a number of more than 300 digits"),
        (
            "c*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)**64",
            "part 'c*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)...' makes a number of more than 300 digits",
        ),
        ("c*((8/7)**64)**8", "part '((8/7)**64)**8' would make a number of more than 300 digits"),
        ("c*1e-100**2*1e-150", "part 'c*1e-100**2*1e-150' would make a number below 1e-300 in magnitude"),
        ("c*1e100**2*1e150", "part 'c*1e100**2*1e150' would make a number beyond 1e+300 in magnitude"),
        ("(1e-100*c)**4", "part '(1e-100*c)**4' would make a number below 1e-300 in magnitude"),
        ("1e-299*1e-299 + c", "part '1e-299*1e-299' is not 0 and below 1e-300 in magnitude"),
        ("c*(9**64*9**64*9**64*9**64*9**64)", "part '9**64*9**64*9**64*9**64*9**64' is beyond 1e+300 in magnitude"),
        ("c + 1e250*1e250", "part '1e250*1e250' is beyond 1e+300 in magnitude"),
        ("c*1e308", "part '1e308' is beyond 1e+300 in magnitude"),
        ("c*1e-400", "part '1e-400' is not 0 and below 1e-300 in magnitude"),
        ("c*1." + "0" * 300 + "1", "holds a number literal of more than 300 digits"),
        ("c*" + "9" * 301, "holds an integer of more than 300 digits"),
        ("c*0/0", "part 'c*0/0' divides by zero"),
        ("c**-1*0**-1", "part '0**-1' divides by zero"),
        ("acos(2)*c", "part 'acos(2)' has no finite real value"),
        ("log(-c*0 - 1) + c", "part 'log(-c*0 - 1)' has no finite real value"),
        ("E**c*exp(1000)", "part 'exp(1000)' is beyond 1e+300 in magnitude"),
        ("(exp(600)*c)*(exp(600)*c)", "part '(exp(600)*c)*(exp(600)*c)' is beyond 1e+300 in magnitude"),
        ("sqrt(-c**2)", "part 'sqrt(-c**2)' makes the imaginary unit I, not a real number"),
        ("(c**16)**8", "part '(c**16)**8' makes the power 128; at most 64 in magnitude"),
        ("safe_pow(3, 1000)*c", "part 'safe_pow(3, 1000)' is beyond 1e+300 in magnitude"),
        ("exp(c + 100*log(3))", "part 'exp(c + 100*log(3))' raises to the power 100; at most 64 in magnitude"),
        ("c/123456789**(1/81)", "part '123456789**(1/81)' would make a number of more than 300 digits"),
        ("2**(c + 100)", "part '2**(c + 100)' makes a power with 100 added to its exponent: raises to the power 100"),
        ("acos(cos(safe_pow(2**60, 7)))", "part 'acos(cos(safe_pow(2**60, 7)))' cannot be formed (AttributeError)"),
    ],
)
def test_parse_expression_bounds_every_number_before_forming_it(text, message):
    with pytest.raises(ValueError) as info:
        parse_expression(text, ("c", "m1"))
    assert message in str(info.value)
    assert "\n" not in str(info.value) and len(str(info.value)) < 200


@pytest.mark.parametrize(
    "text, value",
    [
        ("c*1e300", 1e300),
        ("c*1e-300", 1e-300),
        ("c*2**64*2**64*2**64", 2.0**192),
        ("c*(2**64)**15", 2.0**960),
        ("c*10**64*10**64*10**64*10**64 + 0*m1", 1e256),
        ("c*(1/3)**64", 3.0**-64),
        ("c*exp(690)", math.exp(690)),
        ("c*acos(1) + c*log(1) + c*sqrt(4)", 2.0),
        ("c*8**(1/3)*8**(2/3)*(-1)**2", 8.0),
        ("c*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)**64*(8/7)**64", (8 / 7) ** 320),
        ("((c**8)**8)/c**64*c", 1.0),
        ("safe_pow(-1, 0.5) + c*safe_pow(4, 0.5)", 2.0),
        ("exp(c + 5*log(3))", 243 * math.e),
        ("2**(c + 3)", 16.0),
        ("c*123456789**(-1/3)", 123456789 ** (-1 / 3)),
        ("c*sqrt(2)*sqrt(6)", math.sqrt(12)),
    ],
)
def test_parse_expression_keeps_numbers_within_the_bounds(text, value):
    expr = parse_expression(text, ("c", "m1"))
    assert float(expr.subs(sp.Symbol("c", real=True), 1)) == pytest.approx(value, rel=1e-12)


def test_every_committed_fit_is_within_the_bounds():
    for path in sorted(FITS.glob("*.json")):
        rec = json.loads(path.read_text())
        expr = parse_expression(rec["expression"], (*rec["inputs"], *rec["params"]))
        numbers = expr.atoms(sp.Number)
        assert all(abs(float(n)) <= 1e300 and (n.is_zero or abs(float(n)) >= 1e-300) for n in numbers), path.name
        assert not expr.has(sp.nan, sp.zoo, sp.oo, -sp.oo, sp.I), path.name


TOWER = "c*((((((2**64)**64)**64)**64)**64)**64)"


@pytest.mark.parametrize("command, text, reason", [
    ("load", TOWER, "expression part '(2**64)**64' is beyond 1e+300 in magnitude"),
    ("codegen", TOWER, "expression part '(2**64)**64' is beyond 1e+300 in magnitude"),
    ("load", "safe_pow(3, 123456789)*c + m1", "expression part 'safe_pow(3, 123456789)' is beyond 1e+300 in magnitude"),
    ("load", "exp(c + 123456789*log(3))",
     "expression part 'exp(c + 123456789*log(3))' raises to the power 123456789; at most 64 in magnitude"),
    ("load", "c/123456789**(1/2187) + m1",
     "expression part '123456789**(1/2187)' would make a number of more than 300 digits"),
    ("load", "c**(2**(m1 + 2**60) + 1)",
     "expression part '2**(m1 + 2**60)' makes a power with 1152921504606846976 added to its exponent: "
     "raises to the power 1152921504606846976; at most 64 in magnitude"),
])  # fmt: skip
def test_numbers_sympy_cannot_form_are_refused_at_once(tmp_path, command, text, reason):
    # 2**(64**6), 3**123456789, 123456789**(2186/2187) with its factors, 2**(2**60): before the bounds, loading these
    # took gigabytes and minutes (or forever); now one line naming the file.  The child runs with 2 GiB of address
    # space and a minute, so that the failure it tests for can neither hang the suite nor take the machine's memory
    rec = _base()
    rec.update(expression=text, form="sr_1_abcdef")
    if command == "load":
        path = _write(tmp_path, "m.sr_1_abcdef.json", json.dumps(rec))
        run = ("from fitlab.store import FitFileError, load\n"
               "try:\n    load(sys.argv[1])\nexcept FitFileError as exc:\n    print(exc)")  # fmt: skip
        args = [str(path)]
    else:
        fits = tmp_path / "fits"
        shutil.copytree(FITS, fits, ignore=shutil.ignore_patterns("generated"))
        path = _write(fits, "m.sr_1_abcdef.json", json.dumps(rec))
        run = "from fitlab.cli import main\nsys.exit(main(sys.argv[1:]))"
        args = ["codegen", "--lang", "c", "--fits", str(fits), "--out", str(tmp_path / "gen"),
                "--model", "default-forms", "--form", "m=sr_1_abcdef"]  # fmt: skip
    code = "import resource, sys\nresource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))\n" + run
    try:
        done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{command} of {text} ran for a minute")
    if command == "load":
        assert (done.returncode, done.stdout) == (0, f"{path}: {reason}\n"), done.stderr[-2000:]
    else:
        assert (done.returncode, done.stderr) == (2, f"fitlab codegen: error: {path}: {reason}\n")
        assert not (tmp_path / "gen").exists()
