import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from fitlab.cli import main
from fitlab.families.lambert_sphere.targets import table_files, tabulate
from fitlab.families.lambert_sphere.targets.table_files import C_GRID, MU_GRID
from fitlab.families.lambert_sphere.targets.tabulate import FAST_TABLES, write_tables

DATA = Path(__file__).resolve().parents[1] / "fitlab" / "data" / "lambert_sphere"


@pytest.mark.e2e
def test_committed_tables_pass_check(capsys):
    assert main(["tabulate", "--check", "--quiet"]) == 0  # the packaged tables (conftest: no user data folder)


def test_regenerated_tables_match_committed(tmp_path):
    # the fast tables (the sampling tables take minutes: the check recomputes a sample of their rows)
    write_tables(tmp_path, show_progress=False, names=FAST_TABLES)
    for name in FAST_TABLES:
        new, old = (tmp_path / name).read_text(), (DATA / name).read_text()
        assert new.splitlines()[:5] == old.splitlines()[:5]  # headers state method, tolerance, grid
        _, a = table_files.read_checked(name, tmp_path)  # every check: finite but where inf is exact, on its grid
        _, b = table_files.read_checked(name, DATA)
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)
    _, h0 = table_files.read_checked("h0.csv", tmp_path)
    assert h0.shape == (len(C_GRID) * len(MU_GRID), 4)
    assert not np.any(np.isnan(h0))


def test_the_true_orders_table_regenerates_and_its_check_catches_a_wrong_value(tmp_path):
    """true_orders.csv recomputed matches the packaged one; the check (doubling at c = 1, the three-term orders by
    discrete ordinates) passes on it and names the column of a value off by 1e-7 of its order's largest."""
    name = table_files.TRUE_FILE
    write_tables(tmp_path, show_progress=False, names=(name,))
    new, old = (tmp_path / name).read_text(), (DATA / name).read_text()
    assert new.splitlines()[:5] == old.splitlines()[:5]
    _, a = table_files.read_checked(name, tmp_path)
    _, b = table_files.read_checked(name, DATA)
    assert a.shape == (
        len(table_files.TRUE_S_GRID) * table_files.TRUE_MU_GRID.size * (table_files.TRUE_MU_GRID.size + 1) // 2,
        len(table_files.TRUE_COLUMNS),
    )
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-15)
    assert tabulate.check_true_orders(tmp_path) == []
    lines = new.splitlines()
    first = next(k for k, ln in enumerate(lines) if ln.startswith("0.0,1.0,"))  # c = 1: checked by doubling
    values = lines[first + 10].split(",")  # every tenth row is checked
    scale = np.abs(b[b[:, 0] == 0.0, 5]).max()
    values[5] = repr(float(float(values[5]) + 1e-7 * scale))
    lines[first + 10] = ",".join(values)
    (tmp_path / name).write_text("\n".join(lines) + "\n")
    failures = tabulate.check_true_orders(tmp_path)
    assert len(failures) == 1 and "fm1_true at c=1.0" in failures[0]


@pytest.mark.e2e
def test_check_fails_on_a_wrong_value(tmp_path, capsys):
    root, tmp_path = tmp_path, tmp_path / "lambert_sphere"
    tmp_path.mkdir()
    for f in DATA.glob("*.csv"):
        shutil.copy(f, tmp_path / f.name)
    lines = (tmp_path / "h1.csv").read_text().splitlines()
    # c = 1 is always in the checked sample; corrupt one of its values by 1e-8 relative
    i = next(k for k, ln in enumerate(lines) if ln.startswith("0.0,1.0,0.5,"))
    s, c, mu, h = lines[i].split(",")
    lines[i] = ",".join([s, c, mu, repr(float(h) * (1 + 1e-8))])
    (tmp_path / "h1.csv").write_text("\n".join(lines) + "\n")
    assert main(["tabulate", "--check", "--data", str(root), "--family", "lambert_sphere", "--quiet"]) == 1
    assert "h1.csv" in capsys.readouterr().err
    # the references are kept in the cache of exact values (keyed by the rows and the engine): the packaged
    # tables' check (the same rows) and this one solve once between them
    from fitlab.cache import cache_dir, enabled

    assert not enabled() or any(cache_dir().glob("lambert_sphere-check-h1-*.npz"))


@pytest.mark.parametrize("damage", ["missing", "garbage", "header"])
def test_check_reports_missing_or_corrupt_files(tmp_path, capsys, damage):
    root, tmp_path = tmp_path, tmp_path / "lambert_sphere"
    tmp_path.mkdir()
    for f in DATA.glob("*.csv"):
        shutil.copy(f, tmp_path / f.name)
    if damage == "missing":
        (tmp_path / "h0.csv").unlink()
    elif damage == "garbage":
        (tmp_path / "h0.csv").write_text("s,c,mu,H0\n0.0,1.0,abc,1\n")
    else:
        (tmp_path / "h0.csv").write_text("s,c,mu,H\n0.0,1.0,0.5,1.0\n")
    assert main(["tabulate", "--check", "--data", str(root), "--family", "lambert_sphere", "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "h0.csv" in err and "fitlab tabulate" in err


# -- every table read is checked --------------------------------------------------------------------
from test_input_files import finishes  # noqa: E402

from fitlab.resources import DATA_ENV, packaged_tables, tables_folder  # noqa: E402
from fitlab.store import TableError  # noqa: E402


@pytest.fixture(autouse=True)
def _data_folder_restored(monkeypatch):
    """``--data`` sets $FITLAB_DATA for the rest of the process: restored after each test here."""
    monkeypatch.setenv(DATA_ENV, os.environ[DATA_ENV])


def _user_tables(root):
    """A complete copy of the packaged Lambert-sphere tables in the data folder ``root``."""
    folder = root / "lambert_sphere"
    folder.mkdir(parents=True)
    for name in table_files.TABLE_FILES:
        shutil.copy(DATA / name, folder / name)
    return folder


def _replace_in_row(path, prefix, column, text) -> int:
    """Set ``column`` of the first row starting with ``prefix`` to ``text``; returns its line number (1-based)."""
    lines = path.read_text().splitlines()
    header = next(ln for ln in lines if not ln.startswith("#")).split(",")
    i = next(k for k, ln in enumerate(lines) if ln.startswith(prefix))
    fields = lines[i].split(",")
    fields[header.index(column)] = text
    lines[i] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    return i + 1


def _refit_l(root, capsys):
    """`fitlab refit --target l` on the data folder ``root``: (exit status, stderr)."""
    code = main(["refit", "--target", "l", "--data", str(root), "--out", str(root / "fits"), "--quiet"])
    return code, capsys.readouterr().err.strip()


def test_a_user_folder_missing_one_table_is_refused_naming_it(tmp_path, capsys):
    folder = _user_tables(tmp_path)
    (folder / "kd.csv").unlink()
    # before: the packaged tables were read instead, as if the folder held none of the family's tables
    n = len(table_files.TABLE_FILES)
    want = (
        f"fitlab refit: error: {folder}: kd.csv is missing (the folder holds {n - 1} of the {n} tables of "
        "lambert_sphere); run `fitlab tabulate` to write them all, or remove the folder to read the packaged "
        "tables"
    )
    assert _refit_l(tmp_path, capsys) == (2, want)
    assert not (tmp_path / "fits").exists()
    with pytest.raises(TableError, match="kd.csv is missing"):
        tables_folder("lambert_sphere", tuple(table_files.TABLE_FILES), tmp_path)


def test_a_user_folder_with_none_of_the_tables_falls_back_to_the_packaged_ones(tmp_path):
    (tmp_path / "lambert_sphere").mkdir()
    (tmp_path / "lambert_sphere" / "notes.txt").write_text("not a table\n")
    assert tables_folder("lambert_sphere", tuple(table_files.TABLE_FILES), tmp_path) == packaged_tables(
        "lambert_sphere"
    )
    assert tables_folder("lambert_sphere", tuple(table_files.TABLE_FILES), tmp_path / "absent") == packaged_tables(
        "lambert_sphere"
    )


def test_a_table_with_a_nan_row_is_refused_naming_the_table_and_row(tmp_path, capsys):
    folder = _user_tables(tmp_path)
    line = _replace_in_row(folder / "constants.csv", "0.5,0.75,", "l", "nan")
    # before: the row was left out of the fit while its record counted it (training points 65, 63 used)
    assert _refit_l(tmp_path, capsys) == (2, f"fitlab refit: error: {folder / 'constants.csv'} line {line}: l is nan, "
                                             "not a finite number; run `fitlab tabulate` to rewrite it")  # fmt: skip
    assert line == 38 and not (tmp_path / "fits").exists()


@pytest.mark.parametrize(
    "name, column, value",
    [
        ("kd.csv", "kd_true", "inf"),
        ("h0.csv", "c", "-inf"),
        ("constants.csv", "H0_inf", "-inf"),
        ("h2.csv", "H2", "NaN"),
    ],
)
def test_infinity_is_refused_where_the_table_holds_none(tmp_path, name, column, value):
    folder = _user_tables(tmp_path)
    line = _replace_in_row(folder / name, "0.5,0.75,", column, value)
    with pytest.raises(TableError) as info:
        table_files.check_tables(folder)
    assert str(info.value) == (
        f"{folder / name} line {line}: {column} is {float(value)!r}, not a finite number; "
        "run `fitlab tabulate` to rewrite it"
    )


def test_infinity_is_read_where_the_tables_hold_it():
    h0 = table_files.read_h(0, DATA)
    assert h0[70].tolist() == [0.0, 1.0, np.inf, np.inf] and np.isinf(h0[:, 2]).sum() == 65
    assert table_files.read_constants(DATA)["H0_inf"][0] == np.inf


@pytest.mark.parametrize("name", list(table_files.TABLE_FILES))
@pytest.mark.parametrize("cut", ["at a line end", "within a line"])
def test_a_truncated_table_is_refused_naming_it(tmp_path, capsys, name, cut):
    folder = _user_tables(tmp_path)
    text = (folder / name).read_text()
    half = text.index("\n", len(text) // 2) + 1
    if cut == "within a line":
        half = text.index(",", half)  # the last line holds one field
    (folder / name).write_text(text[:half])
    rows = text.count("\n") - 5
    with pytest.raises(TableError) as info:
        table_files.check_tables(folder)
    if cut == "at a line end":
        kept = text[:half].count("\n") - 5
        assert str(info.value) == (
            f"{folder / name}: {kept} rows, the grid its header states has {rows}; run `fitlab tabulate` to rewrite it"
        )
    else:
        n = len(table_files.TABLE_FILES[name])
        assert str(info.value) == (
            f"{folder / name} line {text[:half].count(chr(10)) + 1}: 1 field, the header has "
            f"{n}; run `fitlab tabulate` to rewrite it"
        )


def test_a_truncated_table_is_refused_by_refit_naming_the_table(tmp_path, capsys):
    folder = _user_tables(tmp_path)
    text = (folder / "constants.csv").read_text()
    (folder / "constants.csv").write_text(text[: text.index("\n", len(text) // 2) + 1])
    # before: the refit ran on the 32 rows left, and its record stated 32 training points
    code, err = _refit_l(tmp_path, capsys)
    assert (code, err) == (2, f"fitlab refit: error: {folder / 'constants.csv'}: 32 rows, the grid its header "
                              "states has 65; run `fitlab tabulate` to rewrite it")  # fmt: skip
    assert not (tmp_path / "fits").exists()


@pytest.mark.parametrize("edit", ["a grid value", "the header's grid", "a row moved"])
def test_a_table_off_its_grid_is_refused(tmp_path, edit):
    folder = _user_tables(tmp_path)
    path = folder / "h1.csv"
    lines = path.read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("0.5,0.75,0.5,"))
    if edit == "a grid value":
        lines[i] = lines[i].replace("0.5,0.75,0.5,", "0.5,0.75,0.5000001,")
        want = f"{path} line {i + 1}: mu is 0.5000001, the grid its header states has 0.5 there"
    elif edit == "the header's grid":
        lines[3] = "# grid: c = 1 - s^2, s = k/32 for k = 0..32"
        want = f"{path}: its header states the grid 'c = 1 - s^2, s = k/32 for k = 0..32', not {table_files.grid_text('h1.csv')!r}"
    else:
        lines[i], lines[i + 1] = lines[i + 1], lines[i]
        want = f"{path} line {i + 1}: mu is 0.515625, the grid its header states has 0.5 there"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(TableError) as info:
        table_files.check_tables(folder)
    assert str(info.value) == want + "; run `fitlab tabulate` to rewrite it"


def test_a_fifo_table_in_a_data_folder_is_refused_without_blocking(tmp_path, capsys):
    folder = _user_tables(tmp_path)
    fifo = folder / "constants.csv"
    fifo.unlink()
    os.mkfifo(fifo)
    # before: refit passed the folder over for the packaged tables; tabulate --check blocked on the FIFO
    assert finishes(lambda: _refit_l(tmp_path, capsys), [fifo]) == (
        2,
        f"fitlab refit: error: {fifo}: not a regular file (a FIFO), not a table",
    )
    code = finishes(lambda: main(["tabulate", "--check", "--data", str(tmp_path), "--family", "lambert_sphere",
                                  "--quiet"]), [fifo])  # fmt: skip
    assert (code, capsys.readouterr().err.strip()) == (
        1,
        f"fitlab tabulate --check: error: {fifo}: not a regular file (a FIFO), not a table",
    )


MICROFACET = DATA.parent / "microfacet_energy"


def test_a_truncated_lobe_parameter_table_is_refused_naming_it(tmp_path):
    from fitlab.families.microfacet_energy.lobes.params import params_file, read_params

    name = params_file("diffuse", "training")
    text = (MICROFACET / name).read_text()
    (tmp_path / name).write_text(text[: text.index("\n", len(text) // 2) + 1])
    kept = text[: text.index("\n", len(text) // 2) + 1].count("\n") - 5
    # before: read, with the jobs of the half left
    with pytest.raises(TableError) as info:
        read_params(tmp_path, "diffuse", "training")
    assert str(info.value) == (
        f"{tmp_path / name}: {kept} rows, the grid its header states has 168; run `fitlab tabulate` to rewrite it"
    )
    assert len(read_params(MICROFACET, "diffuse", "training")["alpha"]) == 168


def test_a_nan_in_a_microfacet_table_is_refused_naming_the_row(tmp_path):
    from fitlab.families.microfacet_energy.targets import tabulate as microfacet

    spec = next(t for t in microfacet.TABLES if t.stem == "oren_nayar" and t.kind == "centres")
    shutil.copy(MICROFACET / spec.file, tmp_path / spec.file)
    column = spec.columns[2]
    line = _replace_in_row(tmp_path / spec.file, "0.03125,0.03125,", column, "nan")
    with pytest.raises(TableError) as info:
        microfacet.read_albedo_table(tmp_path / spec.file, spec)
    assert str(info.value) == (
        f"{tmp_path / spec.file} line {line}: {column} is nan, not a finite number; run `fitlab tabulate` to rewrite it"
    )
    assert line == 6


def test_a_microfacet_table_whose_header_states_another_grid_is_refused(tmp_path):
    from fitlab.families.microfacet_energy.targets import tabulate as microfacet

    spec = next(t for t in microfacet.TABLES if t.stem == "oren_nayar" and t.kind == "centres")
    text = (MICROFACET / spec.file).read_text()
    stated = "texel centres: mu = (j + 1/2)/16, alpha = (k + 1/2)/16, j, k = 0..15; mu varies fastest"
    (tmp_path / spec.file).write_text(text.replace(stated, stated.replace("mu varies fastest", "alpha varies fastest")))
    with pytest.raises(TableError) as info:
        microfacet.read_albedo_table(tmp_path / spec.file, spec)
    assert str(info.value) == (
        f"{tmp_path / spec.file}: its header states the grid "
        f"{stated.replace('mu varies', 'alpha varies')!r}, not {stated!r}; "
        "run `fitlab tabulate` to rewrite it"
    )
