"""A table of one's own at the edges: every limit of the fit-file format checked before any work, and the
table's text, values and size refused in one line before the fit starts; the limits docs/reliability.md
states; ill-conditioning said; the cache lock's wait and export's cost said; misspelled names answered with
the closest; the listings answered without importing the families.

Each refusal replays a failure: one line on stderr, exit status 2 (or 1 where stated), nothing written, and
the fit never started (``run_fit`` is replaced by one that fails the test).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import fitlab.cli.fit
import fitlab.fit.user
import fitlab.fit.user._split
from fitlab.cli import main
from fitlab.fit.user import UserDataError, limits_text, prepare, read_csv_table, table_from_arrays
from fitlab.store import FitFileError, check_fit, fit_limits, fit_schema, load, read_table

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def no_fit(monkeypatch):
    """The fit itself fails the test: a refusal must come before it."""

    def started(*args, **kwargs):
        raise AssertionError("the fit started")

    monkeypatch.setattr(fitlab.fit.user, "run_fit", started)


def _csv(path: Path, columns: dict, text: str | None = None) -> Path:
    names = list(columns)
    lines = [",".join(names)] + [",".join(v if isinstance(v, str) else repr(float(v)) for v in row)
                                 for row in zip(*columns.values())]  # fmt: skip
    path.write_text(text if text is not None else "\n".join(lines) + "\n", encoding="utf-8", newline="")
    return path


def _inputs_table(tmp_path: Path, d: int, n: int = 120) -> Path:
    rng = np.random.default_rng(d)
    xs = {f"x{i}": rng.uniform(0.0, 1.0, n) for i in range(d)}
    y = 1.0 + sum(0.1 * (i + 1) * x for i, x in enumerate(xs.values())) + 1e-3 * rng.normal(size=n)
    return _csv(tmp_path / f"in{d}.csv", {**xs, "y": y})


def _small(tmp_path: Path, **edits) -> Path:
    """z = 1 + 0.5 x + 0.25 y on a 6 x 5 grid; ``edits``: {column: (row, text)}."""
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 6), np.linspace(1, 2, 5), indexing="ij"))
    cols = {"x": [repr(float(v)) for v in x], "y": [repr(float(v)) for v in y],
            "z": [repr(float(v)) for v in 1 + 0.5 * x + 0.25 * y]}  # fmt: skip
    for name, (row, text) in edits.items():
        cols[name][row] = text
    return _csv(tmp_path / "t.csv", cols)


def _refused(tmp_path, capsys, argv, *words, status=2, command="fit"):
    out = tmp_path / "out"
    got = main([*argv, "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert got == status, err
    assert err.startswith(f"fitlab {command}: error: ") and "\n" not in err and "Traceback" not in err, err
    assert "unexpected" not in err, err
    for w in words:
        assert w in err, (w, err)
    assert not out.exists()
    return err


# -- the limits of the format ------------------------------------------------------------
def _schema_file() -> dict:
    return json.loads((ROOT / "fitlab" / "schemas" / "fit-1.schema.json").read_text())


def test_the_limits_are_the_schemas():
    """Derived here from the schema file on its own: the longest name by the schema's own validator, the counts
    from every place a fit's inputs stand (the worst point names them beside exact and approx)."""
    import jsonschema

    schema = _schema_file()
    props = schema["properties"]
    validator = jsonschema.Draft202012Validator(props["target"])
    longest = max(n for n in range(1, 200) if validator.is_valid("a" * n))
    worst = props["validation"]["properties"]["worst"]["maxProperties"]
    inputs = min(props["inputs"]["maxItems"], props["domain"]["maxProperties"],
                 props["user_data"]["properties"]["columns"]["maxItems"] - 1, worst - 2)  # fmt: skip
    lim = fit_limits()
    assert (lim.inputs, lim.params, lim.name, lim.expression) == (
        inputs,
        props["params"]["maxProperties"],
        longest,
        props["expression"]["maxLength"],
    )
    assert lim.inputs == props["inputs"]["maxItems"] == 16  # as docs/your_own_data.md promises: the worst point fits
    assert fit_schema() == schema
    fitlab.fit.user.check_name("a" + "b" * (lim.name - 1), "input")
    with pytest.raises(UserDataError, match=f"at most {lim.name}"):
        fitlab.fit.user.check_name("a" + "b" * lim.name, "input")


def test_a_fit_at_the_limits_is_checked_writable_before_the_fit(tmp_path):
    """16 inputs and a name of the longest length: the record the fit will write, made from the start values
    and checked as the store checks a record it writes, passes; the worst point holds 18 fields."""
    lim = fit_limits()
    table = read_csv_table(_inputs_table(tmp_path, lim.inputs))
    form = "a0 + " + " + ".join(f"a{i + 1}*x{i}" for i in range(lim.inputs))
    prep = prepare(table, "y", form, name="n" * lim.name)
    assert len(prep.form.inputs) == lim.inputs and prep.form.name == "n" * lim.name
    from fitlab.fit.refit import fit_record
    from fitlab.fit.solver import FitResult

    stub = FitResult(prep.form.vector(prep.start), 0, 0, 0, "", 0.0, 0.0, 0.0, 0.0)
    record = fitlab.fit.user.user_record(
        fit_record(prep.rows.target_object(prep.form.name), prep.form, stub, prep.rows.train, prep.rows.valid,
                   prep.rows.domain, 0), prep.rows, 0)  # fmt: skip
    record["user_data"]["file"] = "y.csv"
    assert len(check_fit(record)["validation"]["worst"]) == lim.inputs + 2


@pytest.mark.e2e
def test_fitlab_fit_of_16_inputs_is_written_and_printed(tmp_path, capsys):
    """The failure replayed: 15 and 16 inputs ran the whole fit, then 'not a valid fit file at validation/worst'."""
    for d in (15, 16):
        form = "a0 + " + " + ".join(f"a{i + 1}*x{i}" for i in range(d))
        out = tmp_path / f"fits{d}"
        assert (
            main(
                [
                    "fit",
                    str(_inputs_table(tmp_path, d)),
                    "--target",
                    "y",
                    "--form",
                    form,
                    "--name",
                    "lin",
                    "--minimax-rounds",
                    "0",
                    "--out",
                    str(out),
                    "--quiet",
                ]
            )
            == 0
        ), capsys.readouterr().err
        assert main(["codegen", "--fit", str(out / "y.lin.json"), "--lang", "c", "--out", str(tmp_path / f"c{d}"),
                     "--quiet"]) == 0  # fmt: skip
        assert f"y_lin({', '.join(f'double x{i}' for i in range(d))})" in (tmp_path / f"c{d}" / "y.h").read_text()


@pytest.mark.parametrize(
    "what, make, words",
    [
        (
            "17 inputs",
            lambda d: ("a0 + " + " + ".join(f"a{i + 1}*x{i}" for i in range(d + 1)), d + 1),
            ["17 inputs", "at most 16"],
        ),
        (
            "65 parameters",
            lambda d: (" + ".join(f"a{i}*x{i % d}" for i in range(65)), d),
            ["65 parameters", "at most 64"],
        ),
        ("a parameter of 70 digits", lambda d: ("a0 + a" + "1" * 70 + "*x0", d), ["71 characters", "at most 64"]),
        ("a parameter of 400 digits", lambda d: ("a0 + a" + "7" * 400 + "*x0", d), ["401 characters"]),
        ("a parameter of 5000 digits", lambda d: ("a0 + a" + "9" * 5000 + "*x0", d), ["5001 characters"]),
        ("a name of 65 characters", lambda d: ("a0 + a1*x0", d), ["at most 64"]),
    ],
)
def test_a_limit_of_the_format_is_refused_before_the_fit(tmp_path, capsys, no_fit, what, make, words):
    """The failures replayed: 65 parameters or a parameter name of 70 digits ran a 29 s fit, then 'not a valid
    fit file at params'; 400 and 5000 digits ended in 'unexpected OverflowError' / 'unexpected ValueError'."""
    form, d = make(16)
    name = ["--name", "n" * 65] if "name of" in what else []
    _refused(tmp_path, capsys, ["fit", str(_inputs_table(tmp_path, d)), "--target", "y", "--form", form, *name], *words)


def test_a_start_value_beyond_the_stores_limit_is_refused_before_the_fit(tmp_path, capsys, no_fit):
    _refused(tmp_path, capsys, ["fit", str(_small(tmp_path)), "--target", "z", "--form", "a0 + a1*x + a2*y",
                                "--start", "a1=1e13"], "could not be saved", "a1", "1e+12")  # fmt: skip


def test_a_huge_integer_in_a_fit_file_is_refused_when_read(tmp_path):
    """The failure replayed: an integer parameter 10**400 ended in 'code generation failed: int too large'."""
    record = json.loads((ROOT / "fitlab" / "fits" / "H0.json").read_text())
    for value in (10**400, -(10**5000)):
        bad = json.loads(json.dumps(record))
        bad["params"][next(iter(bad["params"]))] = value
        with pytest.raises(FitFileError, match="an integer of about .* digits"):
            check_fit(bad, "H0.json")
    bad = json.loads(json.dumps(record))
    bad["params"][next(iter(bad["params"]))] = 10**400
    (tmp_path / "H0.json").write_text(json.dumps(bad))
    with pytest.raises(FitFileError, match="H0.json: params/.* is an integer of about 401 digits"):
        load(tmp_path / "H0.json")


def test_the_limits_in_docs_reliability_are_the_checks_constants():
    text = (ROOT / "docs" / "reliability.md").read_text()
    block = re.search(r"<!-- limits: generated by [^>]*-->\n(.*?)<!-- limits: end -->", text, re.S)
    assert block is not None and block.group(1) == limits_text()
    lim = fit_limits()
    for number in (lim.inputs, lim.params, lim.name):
        assert f"at most {number}" in block.group(1)


# -- the table's text and values ----------------------------------------------------------
@pytest.mark.parametrize("cell", ["995_099", "\u0661\u0662", "\uff11\uff12", "0x10", "1e5e5", "1 5"])
def test_only_plain_decimal_numbers_are_read(tmp_path, capsys, no_fit, cell):
    """995_099 and Arabic-Indic or full-width digits, which Python's float() reads, are no numbers of a table."""
    path = _small(tmp_path, y=(4, cell))  # row 4 is line 6 (the header is line 1)
    _refused(
        tmp_path,
        capsys,
        ["fit", str(path), "--target", "z", "--form", "a0 + a1*x + a2*y"],
        "line 6",
        "column y",
        "not a number",
    )


def test_an_exact_table_holds_only_plain_decimal_numbers(tmp_path):
    good = "# grid: g\na,b\n1.5,-2e-3\n+.5,inf\n"
    (tmp_path / "t.csv").write_text(good)
    header, data = read_table(tmp_path / "t.csv", ("a", "b"), infinite=("b",))
    assert data.tolist() == [[1.5, -2e-3], [0.5, float("inf")]]
    for cell, line in (("995_099", 4), ("\u0661", 4), ("\uff12", 4)):
        (tmp_path / "t.csv").write_text(good.replace("+.5", cell))
        with pytest.raises(Exception, match=f"line {line}: .* is not a number"):
            read_table(tmp_path / "t.csv", ("a", "b"), infinite=("b",))
    (tmp_path / "t.csv").write_text(good.replace("+.5", "0.5\u20280.25"))
    with pytest.raises(Exception, match="line 4: holds U\\+2028"):
        read_table(tmp_path / "t.csv", ("a", "b"), infinite=("b",))


def test_a_quoted_cell_holding_a_line_break_is_refused_with_the_editors_line(tmp_path, capsys, no_fit):
    """The failure replayed: '"1\\n"' was read as a number and every later line number was one off."""
    text = 'x,y,z\n# a comment\n0,1,1.25\n0.2,"1\n",1.35\n0.4,1,1.45\n'
    _refused(tmp_path, capsys, ["fit", str(_csv(tmp_path / "q.csv", {}, text)), "--target", "z",
                                "--form", "a0 + a1*x"], "line 4", "a quoted cell runs over the end")  # fmt: skip


@pytest.mark.parametrize("char", ["\u2028", "\u2029", "\x85", "\x0c", "\x1e"])
def test_a_character_some_readers_take_for_a_line_break_is_refused(tmp_path, capsys, no_fit, char):
    """U+2028 inside a cell split the row (str.splitlines splits there; text editors do not)."""
    text = f"x,y,z\r\n0,1,1.25\r\n0.2,1{char}5,1.35\r\n"
    _refused(tmp_path, capsys, ["fit", str(_csv(tmp_path / "u.csv", {}, text)), "--target", "z",
                                "--form", "a0 + a1*x"], "line 3", f"U+{ord(char):04X}")  # fmt: skip


def test_lines_are_numbered_as_editors_number_them(tmp_path, capsys, no_fit):
    """CR LF, CR and LF each end a line: the bad cell of line 5 is named line 5."""
    text = "x,y,z\r\n0,1,1\r0.2,1,1.1\n\n0.4,1,abc\n"
    _refused(tmp_path, capsys, ["fit", str(_csv(tmp_path / "e.csv", {}, text)), "--target", "z",
                                "--form", "a0 + a1*x"], "line 5", "column z", "'abc'")  # fmt: skip


@pytest.mark.parametrize(
    "column, scale, shown", [("z", 5e307, "5e+307"), ("z", 1e-320, "9.99989e-321"), ("x", 1e200, "1e+200")]
)
def test_values_whose_scale_the_fit_cannot_represent_are_refused(tmp_path, capsys, no_fit, column, scale, shown):
    """The failure replayed: y near 5e307 or 1e-320 ended after the fit with 'a0 has no effect' or a leaked
    RuntimeWarning."""
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 6), np.linspace(1, 2, 5), indexing="ij"))
    z = (1 + 0.5 * x + 0.25 * y) * (scale if column == "z" else 1.0)
    cols = {"x": x * (scale if column == "x" else 1.0), "y": y, "z": z}
    err = _refused(tmp_path, capsys, ["fit", str(_csv(tmp_path / "s.csv", cols)), "--target", "z",
                                      "--form", "a0 + a1*x + a2*y"], f"column {column}", "rescale it")  # fmt: skip
    assert "between 1e-150 and 1e150" in err


def test_rows_times_parameters_are_bounded_before_the_fit(tmp_path, capsys, no_fit, monkeypatch):
    """The failure replayed: 1e6 rows x 15 inputs (within every other limit) reached 2.6 GB, then 'unexpected
    JaxRuntimeError: RESOURCE_EXHAUSTED'.  The bound, lowered here so that a small table meets it."""
    monkeypatch.setattr(fitlab.fit.user._split, "MAX_ROW_PARAMETERS", 50)  # where the check reads it
    _refused(
        tmp_path,
        capsys,
        ["fit", str(_small(tmp_path)), "--target", "z", "--form", "a0 + a1*x + a2*y"],
        "23 rows to fit x 3 parameters = 69",
        "at most 50",
    )


def test_running_out_of_memory_is_said_never_unexpected(tmp_path, capsys, monkeypatch):
    class JaxRuntimeError(RuntimeError):
        pass

    def exhausted(*args, **kwargs):
        raise JaxRuntimeError("RESOURCE_EXHAUSTED: Out of memory allocating 2147483648 bytes.")

    monkeypatch.setattr(fitlab.fit.user, "run_fit", exhausted)
    err = _refused(
        tmp_path,
        capsys,
        ["fit", str(_small(tmp_path)), "--target", "z", "--form", "a0 + a1*x + a2*y"],
        "out of memory",
        "RESOURCE_EXHAUSTED",
        status=1,
    )
    assert "unexpected" not in err


# -- ill-conditioning ----------------------------------------------------------------------
def test_an_ill_conditioned_solution_is_named():
    """a0 + a1/(a2 + x) with a2 far beyond x: the columns of a1 and a2 and the constant nearly coincide."""
    x = np.linspace(0.0, 1.0, 40)
    table = table_from_arrays({"x": x}, 1.0 + 2.0 / (3.0 + x), "z")
    prep = prepare(table, "z", "a0 + a1/(a2 + x)", inputs=["x"])
    well = fitlab.fit.user.conditioning(prep, [1.0, 2.0, 3.0])
    assert well["condition"] < 1e6 and not well["large"]
    assert fitlab.fit.user.conditioning_warning(well) is None
    ill = fitlab.fit.user.conditioning(prep, [1.0, 2.0e7, 1.0e7])
    assert ill["condition"] > 1e12 and [p for p, _ in ill["large"]] == ["a1", "a2"]
    assert set(ill["weak"]) >= {"a1", "a2"}
    line = fitlab.fit.user.conditioning_warning(ill)
    assert "a1 = 2e+07, a2 = 1e+07 beyond 1e+06" in line and "condition number" in line and "\n" not in line


def test_fitlab_fit_warns_of_a_parameter_beyond_1e6(tmp_path, capsys):
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0, 1, 6), np.linspace(1, 2, 5), indexing="ij"))
    path = _csv(tmp_path / "big.csv", {"x": x, "y": y, "z": 1e7 * (1 + x) + 3e7 * y})
    out = tmp_path / "fits"
    assert main(["fit", str(path), "--target", "z", "--form", "a0 + a1*x + a2*y", "--name", "lin",
                 "--minimax-rounds", "0", "--out", str(out), "--quiet"]) == 0  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert err.startswith("fitlab fit: warning: z/lin: ill-conditioned: ") and "\n" not in err, err
    assert re.search(r"a0 = 1e\+07, a1 = 1e\+07, a2 = 3e\+07 beyond 1e\+06", err), err


@pytest.mark.e2e
def test_the_docs_example_forms_fit_well_conditioned(tmp_path, capsys):
    """The forms docs/your_own_data.md and `fitlab fit --help` fit to the packaged example table: no parameter
    beyond 1e6, no condition number beyond 1e12, no warning."""
    from fitlab.resources import package_folder

    table = package_folder("data", "examples", "renderer_E.csv")
    v = "alpha/(mu + alpha)"
    forms = {"rational": f"(a0 + a1*sqrt(alpha) + a2*alpha + (a3 + a4*sqrt(alpha) + a5*{v})*{v}) / "
                         f"(1 + a6*sqrt(alpha) + a7*alpha + (a8 + a9*sqrt(alpha) + a10*{v})*{v})",
             "help": "(a0 + a1*mu)/(1 + a2*alpha + a3*mu)"}  # fmt: skip
    for name, form in forms.items():
        assert main(["fit", str(table), "--target", "E", "--form", form, "--name", name, "--out", str(tmp_path),
                     "--json", "--quiet"]) == 0  # fmt: skip
        summary = json.loads(capsys.readouterr().out)
        assert summary["warning"] is None, summary["warning"]
        assert max(abs(p) for p in summary["params"].values()) < 10 and summary["conditioning"]["condition"] < 1e6


# -- the cache lock, export's cost ---------------------------------------------------------
def test_a_wait_on_another_process_s_cache_lock_is_said(tmp_path, monkeypatch, capsys):
    """The failure replayed: a refit waiting on the lock a stopped process held waited silently."""
    import fitlab.cache as cache

    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("FITLAB_NO_CACHE", raising=False)
    monkeypatch.setattr(cache, "WAIT_NOTICE_S", 0.3)
    key = cache.cache_key({"what": "waited"})
    lock = tmp_path / "cache" / "locks" / f"demo-{key}.npz.lock"
    lock.parent.mkdir(parents=True)
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT); "
        "fcntl.flock(fd, fcntl.LOCK_EX); os.write(fd, f'{os.getpid()}\\n'.encode()); print('held', flush=True); "
        "time.sleep(60)"), str(lock)], stdout=subprocess.PIPE, text=True)  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "held"
        os.kill(holder.pid, signal.SIGSTOP)  # stopped, as a suspended job is: it holds the lock
        threading.Timer(1.5, holder.kill).start()  # its end releases the lock
        values = cache.cached_arrays("demo", {"what": "waited"}, lambda: {"v": np.arange(3.0)}, ("v",))
    finally:
        holder.kill()
        holder.wait()
    assert values["v"].tolist() == [0.0, 1.0, 2.0]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"fitlab: waiting for process {holder.pid}, which is computing the cache entry "
                   f"demo-{key}.npz (its lock: {lock})"]  # fmt: skip
    assert lock.read_text().strip() == str(os.getpid())  # the lock now names this process


def test_export_says_when_the_tables_will_take_more_than_a_minute(tmp_path, capsys, monkeypatch):
    """The failure replayed: `export dfg_karis --size 1024` would take about 2 h 20 min without a word.  A table
    whose steps take 0.05 s, with the bound lowered to 0.2 s."""
    import fitlab.cli.export as export
    from fitlab.export import Image, ImageSpec

    def build(size, tick=lambda: None):
        for _ in range(size):
            time.sleep(0.05)
            tick()
        return Image("slow", np.zeros((size, size, 1)), ("zero",), ("a slow table",))

    spec = ImageSpec("a slow table", build, (8,), 8, steps=lambda size: size, formats=("c",))
    monkeypatch.setattr(export, "_offered", lambda: {"slow": ("test", spec)})
    monkeypatch.setattr(export, "SLOW_EXPORT_SECONDS", 0.2)
    assert main(["export", "slow", "--format", "c", "--out", str(tmp_path / "t"), "--quiet"]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("fitlab export: warning: slow at size 8 will take about "), err
    assert "(8 steps, " in err[0] and "Ctrl-C stops it" in err[0]
    monkeypatch.setattr(export, "SLOW_EXPORT_SECONDS", 60.0)
    assert main(["export", "slow", "--format", "c", "--out", str(tmp_path / "u"), "--quiet"]) == 0
    assert not capsys.readouterr().err.strip()


# -- names, listings -----------------------------------------------------------------------
@pytest.mark.parametrize(
    "argv, words",
    [
        (["refit", "--target", "h0"], ["unknown target 'h0'; did you mean H0?"]),
        (["refit", "--target", "E_ggx_corr"], ["did you mean E_ggx_cor"]),
        (["export", "dfg_kars", "--out", "x"], ["no table 'dfg_kars'; did you mean dfg_karis?"]),
        (["discover", "--target", "H00"], ["did you mean H0?"]),
        (["codegen", "--lang", "c", "--form", "H00=x"], ["no target 'H00'; did you mean H0?"]),
    ],
)
def test_a_misspelled_name_gets_the_closest(tmp_path, capsys, argv, words):
    os.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and all(w in err for w in words), err


def test_refit_and_export_list_from_the_cache_without_the_families(tmp_path, monkeypatch, capsys):
    """`fitlab refit --list` and `fitlab export --list` imported every family (JAX, sympy: 4 to 6 s): a warm
    listing, keyed by fitlab's code, imports none of them."""
    from fitlab.cli import export, refit

    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("FITLAB_NO_CACHE", raising=False)
    for name, module in (("refit", refit), ("export", export)):
        assert main([name, "--list"]) == 0
        first = capsys.readouterr().out
        assert first == module.listing_text() and first.strip()
        code = ("import sys; from fitlab.cli import main; status = main([sys.argv[1], '--list']); "
                "assert status == 0; heavy = [m for m in ('jax', 'sympy', 'fitlab.families') if m in sys.modules]; "
                "assert not heavy, heavy")  # fmt: skip
        env = {**os.environ, "FITLAB_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(ROOT)}
        done = subprocess.run([sys.executable, "-c", code, name], capture_output=True, text=True, env=env, timeout=120)
        assert done.returncode == 0, done.stderr[-2000:]
        assert done.stdout == first
