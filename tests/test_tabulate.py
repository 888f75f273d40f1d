import shutil
from pathlib import Path

import numpy as np
import pytest

from fitlab.cli import main
from fitlab.families.lambert_sphere.tabulate import C_GRID, FAST_TABLES, MU_GRID, write_tables
from fitlab.store import read_table

DATA = Path(__file__).resolve().parents[1] / "fitlab" / "data" / "lambert_sphere"


def test_committed_tables_pass_check(capsys):
    assert main(["tabulate", "--check", "--quiet"]) == 0  # the packaged tables (conftest: no user data folder)


def test_regenerated_tables_match_committed(tmp_path):
    # the fast tables (the sampling tables take minutes: the check recomputes a sample of their rows)
    write_tables(tmp_path, show_progress=False, names=FAST_TABLES)
    for name in FAST_TABLES:
        new, old = (tmp_path / name).read_text(), (DATA / name).read_text()
        assert new.splitlines()[:5] == old.splitlines()[:5]  # headers state method, tolerance, grid
        _, a = read_table(tmp_path / name)
        _, b = read_table(DATA / name)
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-15)
    _, h0 = read_table(tmp_path / "h0.csv")
    assert h0.shape == (len(C_GRID) * len(MU_GRID), 4)
    assert not np.any(np.isnan(h0))


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
