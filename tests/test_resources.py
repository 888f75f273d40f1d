"""Where fitlab reads its files (fitlab.resources): the packaged tables, fits and scenes, and the user's data
folder that ``fitlab tabulate`` writes and every command then reads."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from fitlab.cli import main
from fitlab.families.lambert_sphere.targets.datasets import h_training
from fitlab.families.lambert_sphere.targets.table_files import TABLE_FILES, tables_dir
from fitlab.resources import DATA_ENV, data_root, find_scene, packaged_fits, packaged_tables, tables_folder
from fitlab.store import TableError


def _copy_tables(root):
    folder = root / "lambert_sphere"
    folder.mkdir(parents=True)
    for name in TABLE_FILES:
        shutil.copy(packaged_tables("lambert_sphere") / name, folder / name)
    return folder


def test_packaged_files_are_inside_the_package():
    from pathlib import Path

    import fitlab

    package = Path(fitlab.__file__).parent
    assert packaged_fits() == package / "fits" and (packaged_fits() / "H0.json").is_file()
    for name in TABLE_FILES:
        assert (packaged_tables("lambert_sphere") / name).is_file()


def test_data_root_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    assert data_root() == tmp_path
    monkeypatch.delenv(DATA_ENV)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert data_root() == tmp_path / "xdg" / "fitlab"


def test_the_user_tables_are_preferred_only_when_complete(monkeypatch, tmp_path):
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    assert tables_dir() == packaged_tables("lambert_sphere")  # nothing there yet: the packaged tables
    folder = _copy_tables(tmp_path)
    assert tables_dir() == folder
    (
        folder / "kd.csv"
    ).unlink()  # an incomplete set is refused, naming the table it lacks: no mixing of two tabulations
    n = len(TABLE_FILES)
    want = rf"lambert_sphere: kd\.csv is missing \(the folder holds {n - 1} of the {n} tables"
    with pytest.raises(TableError, match=want):
        tables_dir()
    assert tables_folder("lambert_sphere", ("h0.csv",), tmp_path) == folder
    for name in TABLE_FILES:  # a folder with none of the family's tables: the packaged ones
        (folder / name).unlink(missing_ok=True)
    assert tables_dir() == packaged_tables("lambert_sphere")


def test_refit_reads_the_tables_tabulate_wrote(monkeypatch, tmp_path):
    """The training set comes from the user's folder when it holds the tables (a marked copy shows it)."""
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    folder = _copy_tables(tmp_path)
    lines = (folder / "h0.csv").read_text().splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith("0.0,1.0,0.5,"))
    s, c, mu, h = lines[i].split(",")
    lines[i] = ",".join([s, c, mu, repr(2 * float(h))])
    (folder / "h0.csv").write_text("\n".join(lines) + "\n")
    user, packaged = h_training(0), h_training(0, packaged_tables("lambert_sphere"))
    changed = np.flatnonzero(user.y != packaged.y)
    assert changed.size == 1 and user.y[changed[0]] == 2 * packaged.y[changed[0]]


def test_data_flag_must_name_a_folder(tmp_path, capsys):
    assert main(["refit", "--target", "l", "--data", str(tmp_path / "missing"), "--out", str(tmp_path)]) == 2
    assert "--data" in capsys.readouterr().err


def test_scenes_are_found_by_name_or_path(tmp_path):
    packaged = find_scene("order1_normalisation", ["lambert_sphere"])
    assert packaged is not None and packaged.name == "order1_normalisation.toml"
    assert find_scene("order1_normalisation.toml", ["lambert_sphere"]) == packaged
    own = tmp_path / "mine.toml"
    own.write_text("")
    assert find_scene(own, ["lambert_sphere"]) == own
    assert find_scene("no_such_scene", ["lambert_sphere"]) is None
    assert find_scene(tmp_path / "order1_normalisation", ["lambert_sphere"]) is None  # a path is not a name
