"""A table of one's own: ``fitlab fit`` and ``fitlab.fit_table`` / ``fit_function``, ``fitlab codegen --fit``,
``fitlab discover TABLE.csv``, and the refusals, each one line before any work.

The table is made here: z(x, y) = (1 + 0.3 x + 0.2 y^2) / (1 + 0.5 x y) + 1e-3 sin(7 x + 3 y) on a 13 x 11 grid,
x in [0, 1], y in [0.5, 2]; the form (a0 + a1*x + a2*y**2)/(1 + a3*x*y) is the smooth part, so the fit's
parameters lie near (1, 0.3, 0.2, 0.5) and its error near the perturbation's 1e-3.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import time

import numpy as np
import pytest

import fitlab
from fitlab.cli import main
from fitlab.codegen.native import build, build_glsl, compiler
from fitlab.codegen.single import generate_fit_file, read_user_fit, user_program
from fitlab.fit.user import UserDataError, held_out_rows, read_csv_table
from fitlab.store import FitFileError, check_fit, load

FORM = "(a0 + a1*x + a2*y**2)/(1 + a3*x*y)"
TRUE = {"a0": 1.0, "a1": 0.3, "a2": 0.2, "a3": 0.5}
ROUNDS = "3"  # a few Lawson rounds: the suite stays quick

needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler on PATH")
needs_glslang = pytest.mark.skipif(
    shutil.which("glslangValidator") is None, reason="glslangValidator not installed (Debian: glslang-tools)"
)


def _grid():
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0.0, 1.0, 13), np.linspace(0.5, 2.0, 11), indexing="ij"))
    z = (1 + 0.3 * x + 0.2 * y**2) / (1 + 0.5 * x * y) + 1e-3 * np.sin(7 * x + 3 * y)
    return x, y, z


def _write_csv(path, columns: dict, comment: str = "# a test table\n"):
    names = list(columns)
    lines = [comment.rstrip("\n"), ",".join(names)] if comment else [",".join(names)]
    lines += [",".join(v if isinstance(v, str) else repr(float(v)) for v in row) for row in zip(*columns.values())]
    path.write_text("\n".join(lines) + "\n")
    return path


def _relative(approx, exact, floor):
    return np.abs(approx - exact) / np.maximum(np.abs(exact), floor)


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """``fitlab fit`` on the test's CSV: (folder, fit file, record, table path)."""
    root = tmp_path_factory.mktemp("user_fit")
    x, y, z = _grid()
    table = _write_csv(root / "table.csv", {"x": x, "y": y, "label": ["p"] * len(x), "z": z})
    out = root / "fits"
    status = main(["fit", str(table), "--target", "z", "--form", FORM, "--name", "rat", "--minimax-rounds", ROUNDS,
                   "--out", str(out), "--quiet"])  # fmt: skip
    assert status == 0
    path = out / "z.rat.json"
    return root, path, json.loads(path.read_text()), table


def test_the_fit_finds_the_smooth_part_and_states_its_held_out_error(fitted):
    root, path, rec, table = fitted
    assert rec["format"] == "fitlab-fit/1" and rec["target"] == "z" and rec["form"] == "rat"
    assert rec["inputs"] == ["x", "y"]  # the columns the form names, in the table's order ("label" is not one)
    assert rec["domain"] == {"x": [0.0, 1.0], "y": [0.5, 2.0]}
    for name, value in TRUE.items():
        assert rec["params"][name] == pytest.approx(value, abs=5e-3)
    user = rec["user_data"]
    assert user["file"] == "z.rat.csv" and user["rows"] == 143 and user["columns"] == ["x", "y", "z"]
    assert (path.parent / "z.rat.csv").read_bytes() == table.read_bytes()  # the table, copied beside the fit
    assert (user["holdout_every"], user["holdout_offset"], user["error"]) == (4, 2, "relative")
    x, y, z = _grid()
    assert user["scale_floor"] == pytest.approx(1e-3 * np.max(np.abs(z)), rel=1e-15)
    # the held-out rows: sorted by (x, y), every 4th from the 3rd; the record's error is theirs
    held = held_out_rows({"x": x, "y": y}, ["x", "y"], 4, 2)
    assert rec["validation"]["points"] == held.sum() == 36 and rec["training"]["points"] == 107
    f = load(path)
    err = _relative(f(x=x[held], y=y[held]), z[held], user["scale_floor"])
    assert np.max(err) == pytest.approx(rec["validation"]["max_rel"], rel=1e-9)
    assert np.sqrt(np.mean(err**2)) == pytest.approx(rec["validation"]["rms_rel"], rel=1e-9)
    assert 2e-4 < rec["validation"]["max_rel"] < 3e-3  # the perturbation's size, not the form's
    assert f.inputs == ("x", "y") and f.target == "z"
    with pytest.raises(ValueError, match="domain"):
        f(x=1.5, y=1.0)


def test_the_python_api_makes_the_same_fit(fitted):
    _, _, rec, _ = fitted
    x, y, z = _grid()
    fit = fitlab.fit_table({"x": x, "y": y}, z, FORM, target="z", name="rat", minimax_rounds=int(ROUNDS),
                           progress=False)  # fmt: skip
    assert fit.params == pytest.approx(rec["params"], rel=1e-12, abs=1e-15)
    assert fit.validation["max_rel"] == pytest.approx(rec["validation"]["max_rel"], rel=1e-12)
    assert fit.remeasure()["max_rel"] == pytest.approx(rec["validation"]["max_rel"], rel=1e-9)
    assert fit(x=0.5, y=1.0) == pytest.approx((1 + 0.15 + 0.2) / 1.25, abs=2e-3)
    assert fit.record["user_data"]["source"] == "arrays"


@needs_cc
def test_generated_c_measures_the_claimed_held_out_error(fitted, tmp_path):
    """`fitlab codegen --fit` writes C; compiled and run on the held-out rows, its error is the one the fit states."""
    root, path, rec, table = fitted
    gen = tmp_path / "c"
    assert main(["codegen", "--fit", str(path), "--lang", "c", "--out", str(gen), "--quiet"]) == 0
    files = {p.name: p.read_text() for p in gen.iterdir()}
    assert sorted(files) == ["z.c", "z.h"]
    v = rec["validation"]
    header = files["z.h"]
    assert "double z_rat(double x, double y);" in header and "float z_rat_f(float x, float y);" in header
    assert "x in [0.0, 1.0], y in [0.5, 2.0]" in header  # the fit's own domain
    assert f"max {v['max_rel']:.3e}, RMS {v['rms_rel']:.3e}" in header  # the error measured again
    fit, tab = read_user_fit(path)
    model = build(files, user_program(fit, tab), tmp_path / "build")
    x, y, z = _grid()
    held = held_out_rows({"x": x, "y": y}, ["x", "y"], 4, 2)
    floor = rec["user_data"]["scale_floor"]
    err = _relative(model("rat", x[held], y[held]), z[held], floor)
    assert np.max(err) == pytest.approx(v["max_rel"], rel=1e-9)
    assert np.sqrt(np.mean(err**2)) == pytest.approx(v["rms_rel"], rel=1e-9)
    err_f = _relative(model("rat", x[held], y[held], dtype=np.float32).astype(float), z[held], floor)
    assert abs(np.max(err_f) - v["max_rel"]) < 1e-6  # float rounding of a value near 1
    # outside the domain the inputs are clamped into it; NaN stays NaN
    assert model("rat", np.array([5.0, -1.0]), np.array([9.0, 0.0])) == pytest.approx(
        load(path)(x=np.array([1.0, 0.0]), y=np.array([2.0, 0.5])), rel=1e-15
    )
    assert np.isnan(model("rat", np.array([np.nan]), np.array([1.0]))[0])


@needs_glslang
def test_generated_glsl_is_accepted_by_glslang(fitted, tmp_path):
    _, path, rec, _ = fitted
    gen = tmp_path / "glsl"
    assert main(["codegen", "--fit", str(path), "--lang", "glsl", "--out", str(gen), "--quiet"]) == 0
    text = (gen / "z.glsl").read_text()
    for version in ("#version 330", "#version 300 es"):
        shader = tmp_path / "test.frag"
        shader.write_text(
            version + "\n" + text + "uniform vec2 p; out vec4 color;\nvoid main() { color = vec4(z_rat(p.x, p.y)); }\n"
        )
        res = subprocess.run(["glslangValidator", str(shader)], capture_output=True, text=True)
        assert res.returncode == 0, res.stdout + res.stderr


@needs_cc
def test_generated_glsl_computes_the_fit(fitted, tmp_path):
    """The GLSL compiled as C against fitlab's shim of its built-ins, in float: the fit's values."""
    _, path, rec, _ = fitted
    fit, tab = read_user_fit(path)
    files = generate_fit_file(path, "glsl")
    model = build_glsl(files, user_program(fit, tab), tmp_path)
    x, y, _ = _grid()
    assert model("rat", x, y, dtype=np.float32) == pytest.approx(fit(x=x, y=y), rel=2e-6)


def test_generated_python_and_every_language(fitted, tmp_path):
    import importlib.util

    _, path, rec, _ = fitted
    from fitlab.codegen import LANGUAGES

    for lang in LANGUAGES:
        files = generate_fit_file(path, lang)
        text = "".join(files.values())
        assert "rat" in text and "fitlab codegen --fit z.rat.json" in text, lang
    (tmp_path / "z.py").write_text(generate_fit_file(path, "python")["z.py"])
    spec = importlib.util.spec_from_file_location("z_generated", tmp_path / "z.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    x, y, _ = _grid()
    assert module.rat(x, y) == pytest.approx(load(path)(x=x, y=y), rel=1e-14)


def test_the_python_api_refuses_bad_tables_in_one_line():
    x, y, z = _grid()
    x[40], y[40] = x[3], y[3]
    with pytest.raises(UserDataError, match="row 4 and row 41 have the same inputs"):
        fitlab.fit_table({"x": x, "y": y}, z, FORM, target="z", progress=False)
    with pytest.raises(UserDataError, match="different lengths: x 143, y 142, z 143"):
        fitlab.fit_table({"x": x, "y": y[1:]}, z, FORM, target="z", progress=False)
    with pytest.raises(UserDataError, match="row 1: column z is nan"):
        fitlab.fit_table({"x": x, "y": y}, np.r_[np.nan, z[1:]], FORM, target="z", progress=False)
    with pytest.raises(UserDataError, match="returned shape"):
        fitlab.fit_function(lambda x: np.zeros(3), {"x": (0.0, 1.0)}, "a0*x", progress=False)


def test_fit_function_samples_the_edges_and_saves_its_table(tmp_path):
    def f(x, y):
        return np.exp(-x) * (1 + y)

    fit = fitlab.fit_function(f, {"x": (0.0, 2.0), "y": (-0.5, 0.5)}, "a0*exp(a1*x)*(1 + a2*y)", n=9,
                              name="exp", minimax_rounds=0, progress=False)  # fmt: skip
    assert fit.domain == {"x": (0.0, 2.0), "y": (-0.5, 0.5)}
    assert fit.params == pytest.approx({"a0": 1.0, "a1": -1.0, "a2": 1.0}, abs=1e-9)
    assert fit.record["user_data"]["source"] == "function" and fit.record["user_data"]["rows"] == 81
    paths = fit.save(tmp_path / "f.exp.json")
    assert sorted(p.name for p in paths) == ["f.exp.csv", "f.exp.json"]
    assert json.loads((tmp_path / "f.exp.json").read_text())["user_data"]["file"] == "f.exp.csv"
    assert read_csv_table(tmp_path / "f.exp.csv").column("f").size == 81
    files = generate_fit_file(tmp_path / "f.exp.json", "c")
    assert "f_exp(double x, double y)" in files["f.h"]


# -- refusals ------------------------------------------------------------------------
def _bad(tmp_path, capsys, argv, *words):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    status = main([*argv, "--out", str(out), "--quiet", "--minimax-rounds", "1"])
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    assert err.startswith("fitlab fit: error: ") and "\n" not in err and "Traceback" not in err, err
    for w in words:
        assert w in err, (w, err)
    assert not out.exists()  # nothing written, not even the folder
    assert time.perf_counter() - t0 < 30
    return err


def _table(tmp_path, **edits):
    x, y, z = _grid()
    columns = {k: [repr(float(a)) for a in v] for k, v in (("x", x), ("y", y), ("z", z))}
    for key, (row, value) in edits.items():
        columns[key][row] = value
    return str(_write_csv(tmp_path / "t.csv", columns, comment=""))


def test_a_missing_column_is_refused(tmp_path, capsys):
    _bad(tmp_path, capsys, ["fit", _table(tmp_path), "--target", "w", "--form", FORM], "no column 'w'", "x, y, z")


def test_a_non_numeric_cell_is_refused(tmp_path, capsys):
    # the header is line 1: row 5 (from 0) is line 7
    _bad(
        tmp_path,
        capsys,
        ["fit", _table(tmp_path, y=(5, "abc")), "--target", "z", "--form", FORM],
        "line 7",
        "column y",
        "'abc'",
        "not a number",
    )


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_nan_and_inf_are_refused(tmp_path, capsys, value):
    _bad(
        tmp_path,
        capsys,
        ["fit", _table(tmp_path, z=(7, value)), "--target", "z", "--form", FORM],
        "line 9",
        f"column z is {float(value)}",
        "finite",
    )


def test_fewer_rows_than_parameters_need_are_refused(tmp_path, capsys):
    x, y, z = (v[::16] for v in _grid())
    table = _write_csv(tmp_path / "t.csv", {"x": x, "y": y, "z": z})
    _bad(
        tmp_path,
        capsys,
        ["fit", str(table), "--target", "z", "--form", FORM],
        "9 rows",
        "7 to fit and 2 held out",
        "4 parameters needs at least 8 to fit and 4 held out",
    )


def test_duplicate_points_are_refused(tmp_path, capsys):
    x, y, z = _grid()
    x[40], y[40] = x[3], y[3]
    table = _write_csv(tmp_path / "t.csv", {"x": x, "y": y, "z": z}, comment="")
    _bad(
        tmp_path,
        capsys,
        ["fit", str(table), "--target", "z", "--form", FORM],
        "line 5 and line 42 have the same inputs",
        "one row per point",
    )


def test_an_expression_naming_an_unknown_input_is_refused(tmp_path, capsys):
    _bad(
        tmp_path,
        capsys,
        ["fit", _table(tmp_path), "--target", "z", "--form", "a0 + a1*x + a2*w", "--inputs", "x,y"],
        "'w'",
        "neither an input (the inputs are x, y) nor a parameter",
    )


def test_a_form_the_data_cannot_determine_is_refused(tmp_path, capsys):
    _bad(
        tmp_path,
        capsys,
        ["fit", _table(tmp_path), "--target", "z", "--form", "a0*a1*x + a2*y"],
        "cannot determine",
        "rank 2",
        "a0 - 0.5 a1",
    )


def test_a_form_with_an_input_too_few_values_cannot_determine_is_refused(tmp_path, capsys):
    """A quadratic in x on a table with two values of x: the Jacobian's rank says so."""
    x, y, z = _grid()
    keep = (x == 0.0) | (x == 1.0)
    table = _write_csv(tmp_path / "t.csv", {"x": x[keep], "y": y[keep], "z": z[keep]})
    _bad(
        tmp_path,
        capsys,
        ["fit", str(table), "--target", "z", "--form", "a0 + a1*x + a2*x**2 + a3*y"],
        "cannot determine",
        "rank 3",
    )


@pytest.mark.parametrize(
    "form, words",
    [
        ("a0*x +", ["cannot read the form", "SyntaxError"]),
        ("x*y", ["no parameters"]),
        ("__import__('os').system('touch CANARY') + a0", ["expression calls 'Attribute'"]),
        ("x.__class__ + a0", ["Attribute"]),
        ("a0 + a1*x - a1*x + a2*y", ["a1 cancels out"]),
        ("a0/(x - x) + a1", ["cannot read", "divides by zero"]),
    ],
)
def test_bad_forms_are_refused(tmp_path, capsys, form, words):
    canary = tmp_path / "CANARY"
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        err = _bad(tmp_path, capsys, ["fit", _table(tmp_path), "--target", "z", "--form", form, "--inputs", "x,y"])
    finally:
        os.chdir(cwd)
    assert any(w in err for w in words), err
    assert not canary.exists()


def test_a_form_not_finite_at_the_start_is_refused(tmp_path, capsys):
    _bad(
        tmp_path,
        capsys,
        ["fit", _table(tmp_path), "--target", "z", "--form", "a0/(x - a1) + a2*y", "--start", "a1=0"],
        "not finite at x=0, y=0.5",
        "start values (a0=1, a1=0, a2=0.333333)",
    )


@pytest.mark.parametrize(
    "what, argv_extra, words",
    [
        ("registered target", ["--target", "H0"], ["built-in target H0"]),
        ("input that is constant", ["--target", "z", "--domain", "x=0.5:0.55"], ["input x is 0.5 in every row"]),
        ("domain of no rows", ["--target", "z", "--domain", "x=3:4"], ["no row lies in the domain x=3:4"]),
        ("domain of no input", ["--target", "z", "--domain", "q=0:1"], ["'q' is not an input"]),
        ("start of no parameter", ["--target", "z", "--start", "a9=1"], ["'a9' is not a parameter"]),
        ("reserved input", ["--target", "z", "--inputs", "x,y,float"], ["no column 'float'"]),
    ],
)
def test_other_bad_requests_are_refused(tmp_path, capsys, what, argv_extra, words):
    x, y, z = _grid()
    table = _write_csv(tmp_path / "t.csv", {"x": x, "y": y, "z": z, "H0": z})
    _bad(tmp_path, capsys, ["fit", str(table), "--form", FORM, *argv_extra], *words)


def test_a_table_without_a_header_or_not_a_file_is_refused(tmp_path, capsys):
    x, y, z = _grid()
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(f"{float(a)!r},{float(b)!r},{float(c)!r}" for a, b, c in zip(x, y, z)) + "\n")
    _bad(tmp_path, capsys, ["fit", str(plain), "--target", "z", "--form", FORM], "the first row is numbers")
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)  # opened, it would wait for a writer: refused before
    _bad(tmp_path, capsys, ["fit", str(fifo), "--target", "z", "--form", FORM], "not a regular file")
    _bad(tmp_path, capsys, ["fit", str(tmp_path), "--target", "z", "--form", FORM], "a folder")
    _bad(tmp_path, capsys, ["fit", str(tmp_path / "none.csv"), "--target", "z", "--form", FORM], "no such file")
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("x,y,z\n1,2,3\n4,5\n")
    _bad(tmp_path, capsys, ["fit", str(ragged), "--target", "z", "--form", FORM], "line 3: 2 fields")


# -- codegen --fit refusals and the store's checks -------------------------------------
def _copy(fitted, tmp_path):
    """The fit and its table (beside it) copied into tmp_path/fits; the table copied as tmp_path/table.csv too."""
    root, path, rec, table = fitted
    (tmp_path / "fits").mkdir()
    shutil.copy(table, tmp_path / "table.csv")
    shutil.copy(path, tmp_path / "fits" / path.name)
    shutil.copy(path.parent / rec["user_data"]["file"], tmp_path / "fits" / rec["user_data"]["file"])
    return tmp_path / "fits" / path.name


def _codegen_refused(capsys, argv, *words):
    status = main(argv)
    err = capsys.readouterr().err.strip()
    assert status == 2 and "\n" not in err and err.startswith("fitlab codegen: error: "), err
    for w in words:
        assert w in err, (w, err)


def test_codegen_refuses_a_changed_table_and_a_fit_that_disagrees_with_it(fitted, tmp_path, capsys):
    path = _copy(fitted, tmp_path)
    out = tmp_path / "gen"
    table = path.with_name("z.rat.csv")  # the table beside the fit
    table.write_text(table.read_text().replace("\n", "\n# edited\n", 1))
    _codegen_refused(capsys, ["codegen", "--fit", str(path), "--lang", "c", "--out", str(out)], "the table changed")
    shutil.copy(fitted[3], table)
    rec = json.loads(path.read_text())
    rec["params"]["a0"] += 0.01  # the file states the old error
    path.write_text(json.dumps(rec))
    _codegen_refused(
        capsys,
        ["codegen", "--fit", str(path), "--lang", "glsl", "--out", str(out)],
        "measured again on the held-out rows",
        "the fit and its table disagree",
    )
    table.unlink()
    _codegen_refused(
        capsys, ["codegen", "--fit", str(path), "--lang", "c", "--out", str(out)], "its table", "no such file"
    )
    _codegen_refused(
        capsys,
        ["codegen", "--fit", str(path), "--lang", "c", "--fits", str(tmp_path), "--out", str(out)],
        "--fits goes with a family's program, not with --fit",
    )
    assert not out.exists()


@pytest.mark.parametrize(
    "what, edit, words",
    [
        (
            "domain",
            lambda r: r["domain"]["x"].__setitem__(1, 1e12),
            ["the domain of x [0.0, 1000000000000.0]", "table z.rat.csv gives [0.0, 1.0]"],
        ),
        (
            "narrower domain",
            lambda r: r["domain"]["y"].__setitem__(0, 0.55),
            ["the domain of y [0.55, 2.0]", "gives [0.65, 2.0]"],
        ),
        ("rows", lambda r: r["user_data"].__setitem__("rows", 5), ["user_data.rows 5", "gives 143"]),
        ("floor", lambda r: r["user_data"].__setitem__("scale_floor", 1e-300), ["user_data.scale_floor 1e-300"]),
        (
            "offset",
            lambda r: r["user_data"].__setitem__("holdout_offset", 1),
            ["user_data.holdout_offset 1", "gives 2"],
        ),
        ("points", lambda r: r["training"].__setitem__("points", 1000), ["training.points 1000", "gives 107"]),
        ("absolute path", lambda r: r["user_data"].__setitem__("file", "/etc/passwd"), ["'/etc/passwd' is a path"]),
        ("relative path", lambda r: r["user_data"].__setitem__("file", "../table.csv"), ["'../table.csv' is a path"]),
        ("huge integer", lambda r: r["params"].__setitem__("a0", 10**400), ["params/a0", "401 digits"]),
    ],
)
def test_codegen_derives_every_figure_it_prints_from_the_table(fitted, tmp_path, capsys, what, edit, words):
    """The failures replayed: a domain edited to x in [0.01, 1e12] was printed as the routine's domain (which
    returned 640.5 at a pole of the form there), the edited user_data.rows and scale_floor were printed, an
    absolute user_data.file was read and its shape echoed, an integer parameter of 10**400 ended in 'code
    generation failed: int too large'."""
    path = _copy(fitted, tmp_path)
    rec = json.loads(path.read_text())
    edit(rec)
    path.write_text(json.dumps(rec))
    out = tmp_path / "gen"
    _codegen_refused(capsys, ["codegen", "--fit", str(path), "--lang", "c", "--out", str(out)], str(path), *words)
    assert not out.exists()


def test_codegen_refuses_a_table_that_is_a_link(fitted, tmp_path, capsys):
    path = _copy(fitted, tmp_path)
    beside = path.with_name("z.rat.csv")
    beside.unlink()
    beside.symlink_to(tmp_path / "table.csv")  # the same bytes, read through a link
    _codegen_refused(
        capsys, ["codegen", "--fit", str(path), "--lang", "c", "--out", str(tmp_path / "gen")], "is a symbolic link"
    )


def test_codegen_refuses_a_routine_not_finite_between_the_rows(tmp_path, capsys):
    """A form NaN on |x - 0.55| < 0.001, between the rows x = 0.5 and 0.6: the fit and its held-out error are
    finite, the routine is not; the dense probe of the domain finds it."""
    x, y = (g.ravel() for g in np.meshgrid(np.linspace(0.0, 1.0, 11), np.linspace(0.5, 2.0, 7), indexing="ij"))
    z = 1.0 + 0.3 * x + 0.2 * y
    fit = fitlab.fit_table({"x": x, "y": y}, z, "a0 + a1*x + a2*y + a3*sqrt(Abs(x - 0.55) - 0.001)", target="z",
                           name="gap", minimax_rounds=0, progress=False)  # fmt: skip
    assert math.isfinite(fit.validation["max_rel"])
    fit.save(tmp_path / "fits" / "z.gap.json")
    out = tmp_path / "gen"
    _codegen_refused(capsys, ["codegen", "--fit", str(tmp_path / "fits" / "z.gap.json"), "--lang", "c",
                              "--out", str(out)], "z/gap: not finite at x = 0.54", "inside its domain")  # fmt: skip
    assert not out.exists()


def test_a_better_fit_already_there_is_kept_unless_forced(fitted, tmp_path, capsys):
    """The failure replayed: `fitlab fit` with an existing --name silently replaced a better fit with a worse
    one.  A fit of another table under that name is kept too, refused before the fit starts."""
    root, path, rec, table = fitted
    out = tmp_path / "fits"
    out.mkdir()
    for name in (path.name, "z.rat.csv"):
        shutil.copy(path.parent / name, out / name)
    before = (out / path.name).read_bytes()
    argv = ["fit", str(table), "--target", "z", "--form", FORM, "--name", "rat", "--out", str(out), "--quiet"]
    assert main([*argv, "--minimax-rounds", "0"]) == 1  # least squares only: worse than the 3 Lawson rounds
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "is worse than the fit in" in err and "which is kept (--force replaces it)" in err
    assert (out / path.name).read_bytes() == before
    assert main([*argv, "--minimax-rounds", "0", "--force"]) == 0
    replaced = json.loads((out / path.name).read_text())
    assert replaced["validation"]["max_rel"] > rec["validation"]["max_rel"]
    # another table (one row left out): not comparable, refused before the fit
    other = tmp_path / "other.csv"
    other.write_text("".join(table.read_text().splitlines(keepends=True)[:-1]))
    capsys.readouterr()
    import fitlab.fit.user

    def started(*args, **kwargs):
        raise AssertionError("the fit started")

    original = fitlab.fit.user.run_fit
    fitlab.fit.user.run_fit = started
    try:
        status = main(["fit", str(other), "--target", "z", "--form", FORM, "--name", "rat", "--out", str(out)])
    finally:
        fitlab.fit.user.run_fit = original
    err = capsys.readouterr().err.strip()
    assert status == 1 and "a fit of another table" in err and "nothing fitted" in err, err


def test_the_store_checks_a_user_fit_against_its_own_inputs_and_domain(fitted):
    rec = fitted[2]
    assert check_fit(json.loads(json.dumps(rec)))["target"] == "z"
    for label, mutate, words in [
        (
            "registered name",
            lambda r: r.update(target="H0", user_data={**r["user_data"], "columns": ["x", "y", "H0"]}),
            "registered target H0",
        ),
        ("domain keys", lambda r: r.update(domain={"x": [0, 1]}), "every input"),
        ("empty interval", lambda r: r["domain"].update(y=[2.0, 0.5]), "lo < hi"),
        ("columns", lambda r: r["user_data"].update(columns=["y", "x", "z"]), "the inputs then the target"),
        ("floor", lambda r: r["user_data"].update(scale_floor=0.0), "floor > 0"),
        ("code", lambda r: r.update(expression="__import__('os').getcwd()"), "calls 'Attribute'"),
        ("unknown field", lambda r: r["user_data"].update(payload=1), "user_data"),
    ]:
        bad = json.loads(json.dumps(rec))
        mutate(bad)
        with pytest.raises(FitFileError, match=words):
            check_fit(bad, label)


def test_the_report_leaves_user_fits_out(fitted, tmp_path):
    from fitlab.report.methods import fit_inventory
    from fitlab.resources import packaged_fits

    folder = tmp_path / "fits"
    shutil.copytree(packaged_fits(), folder, ignore=shutil.ignore_patterns("generated"))
    before = [e.path.name for e in fit_inventory(folder)]
    shutil.copy(fitted[1], folder / fitted[1].name)
    assert [e.path.name for e in fit_inventory(folder)] == before


def test_importing_fitlab_imports_no_jax_and_the_api_is_there():
    code = (
        "import sys, fitlab; assert 'jax' not in sys.modules and 'sympy' not in sys.modules; "
        "f = fitlab.fit_table; assert callable(f) and callable(fitlab.fit_function); "
        "assert 'jax' not in sys.modules; print('ok')"
    )
    res = subprocess.run([os.sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert res.stdout.strip() == "ok", res.stderr[-2000:]
    with pytest.raises(AttributeError):
        fitlab.not_a_function  # noqa: B018


# -- discover on a table ----------------------------------------------------------------
def test_discover_on_a_table_saves_fits_codegen_prints(fitted, tmp_path, capsys):
    pytest.importorskip("pysindy")
    _copy(fitted, tmp_path)
    out, fits = tmp_path / "front", tmp_path / "fits"
    status = main(["discover", str(tmp_path / "table.csv"), "--target", "z", "--inputs", "x,y", "--max-terms", "2",
                   "--minimax-rounds", "1", "--out", str(out), "--fits", str(fits), "--quiet"])  # fmt: skip
    text = capsys.readouterr().out
    assert status == 0
    front = json.loads((out / "z.json").read_text())
    assert front["target"] == "z" and front["front"] and front["reference"] == []
    name = front["front"][-1]
    record = next(r["record"] for r in front["refined"] if r["name"] == name)
    assert record["user_data"]["columns"] == ["x", "y", "z"] and f"| {name} (front)" in text
    status = main(
        [
            "discover",
            str(tmp_path / "table.csv"),
            "--target",
            "z",
            "--inputs",
            "x,y",
            "--max-terms",
            "2",
            "--minimax-rounds",
            "1",
            "--out",
            str(out),
            "--fits",
            str(fits),
            "--quiet",
            "--save",
            name,
        ]
    )
    assert status == 0
    saved = fits / f"z.{name}.json"
    files = generate_fit_file(saved, "c")
    assert f"z_{name}(double x, double y)" in files["z.h"]
    assert saved.with_suffix(".csv").read_bytes() == (tmp_path / "table.csv").read_bytes()  # the table beside it
    # --from-front: the same fit from the front written above, without searching again
    again = tmp_path / "again"
    t0 = time.perf_counter()
    status = main(["discover", str(tmp_path / "table.csv"), "--target", "z", "--from-front", "--save", name,
                   "--out", str(out), "--fits", str(again), "--quiet"])  # fmt: skip
    assert status == 0 and time.perf_counter() - t0 < 10
    assert (again / saved.name).read_bytes() == saved.read_bytes()
    assert (again / saved.with_suffix(".csv").name).read_bytes() == (tmp_path / "table.csv").read_bytes()
    # another table than the one searched: refused, nothing written
    other = tmp_path / "other.csv"
    other.write_text((tmp_path / "table.csv").read_text().replace("\n", "\n# another\n", 1))
    capsys.readouterr()
    status = main(["discover", str(other), "--target", "z", "--from-front", "--save", name, "--out", str(out),
                   "--fits", str(tmp_path / "third")])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "the table changed since the search" in err and not (tmp_path / "third").exists()


# -- the benchmark -------------------------------------------------------------------------
@pytest.mark.benchmark
def test_benchmark_a_3000_row_table_with_a_4_parameter_rational(capsys):
    """Wall time of fit_table on 3,000 random rows of a 2-D table with a 4-parameter rational and the default
    40 minimax rounds: a cold run (JAX compiles), then warm runs (its caches filled); printed, not asserted."""
    rng = np.random.default_rng(3000)
    x, y = rng.uniform(0.0, 1.0, 3000), rng.uniform(0.5, 2.0, 3000)
    z = (1 + 0.3 * x + 0.2 * y**2) / (1 + 0.5 * x * y) + 1e-3 * rng.normal(size=3000)
    walls = []
    for _ in range(3):
        t0 = time.perf_counter()
        fit = fitlab.fit_table({"x": x, "y": y}, z, FORM, target="z", progress=False)
        walls.append(time.perf_counter() - t0)
    assert math.isfinite(fit.validation["max_rel"]) and fit.validation["points"] == 750
    with capsys.disabled():
        print(
            f"\nfit_table, 3000 rows, 4-parameter rational, 40 minimax rounds: cold {walls[0]:.2f} s, "
            f"warm {walls[1]:.2f} s, {walls[2]:.2f} s"
        )
