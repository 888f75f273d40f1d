r"""The layout of the family's exact tables: file names and columns, written once, and where they are read.

:mod:`.tabulate` writes these files (through :func:`fitlab.store.write_tables`);
everything that reads them (training sets, the report's interpolation) reads
them here, through :func:`fitlab.store.read_table`, which checks the header.
The packaged tables are ``fitlab/data/lambert_sphere/``; :func:`tables_dir`
prefers the user's data folder when ``fitlab tabulate`` has written them there
(:mod:`fitlab.resources`).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from fitlab.families.lambert_sphere.exact import CONSTANT_NAMES
from fitlab.resources import tables_folder
from fitlab.store import read_table

__all__ = ["FAMILY_NAME", "tables_dir", "h_columns", "h_file", "CONSTANTS_FILE", "CONSTANT_COLUMNS", "KD_FILE", "KD_COLUMNS", "TABLE_FILES",
           "SAMPLING_FILES", "SAMPLING_COLUMNS", "read_sampling",
           "read_h", "read_constants", "read_kd", "check_tables"]

#: the family's name: its tables live in ``fitlab/data/FAMILY_NAME/`` and ``DATA/FAMILY_NAME/``
FAMILY_NAME = "lambert_sphere"
CONSTANTS_FILE = "constants.csv"
CONSTANT_COLUMNS = ("s", "c", *CONSTANT_NAMES)
KD_FILE = "kd.csv"
KD_COLUMNS = ("s", "c", "kd_three_term", "kd_true")
#: the variance-optimal sampling mixture (:mod:`.exact.sampling`) on the training and the validation grid
SAMPLING_FILES = ("sampling.csv", "sampling_validation.csv")
SAMPLING_COLUMNS = ("s", "c", "mu_i", "weight", "exponent", "relvar_optimal", "relvar_cosine")


def h_file(order: int) -> str:
    return f"h{order}.csv"


def h_columns(order: int) -> tuple[str, ...]:
    return ("s", "c", "mu", f"H{order}")


#: every table file and its columns
TABLE_FILES = {**{h_file(m): h_columns(m) for m in range(3)}, CONSTANTS_FILE: CONSTANT_COLUMNS, KD_FILE: KD_COLUMNS,
               **{name: SAMPLING_COLUMNS for name in SAMPLING_FILES}}


def tables_dir(data_dir: Path | str | None = None) -> Path:
    """The folder the tables are read from: ``data_dir`` itself when given; else the user's data folder's
    ``lambert_sphere/`` when it holds every table (:func:`fitlab.resources.tables_folder`), else the
    packaged tables."""
    return Path(data_dir) if data_dir is not None else tables_folder(FAMILY_NAME, tuple(TABLE_FILES))


@lru_cache(maxsize=None)
def read_h(order: int, data_dir: Path) -> np.ndarray:
    """Rows (s, c, mu, H) of h{order}.csv in ``data_dir``."""
    return read_table(Path(data_dir) / h_file(order), h_columns(order))[1]


@lru_cache(maxsize=None)
def read_constants(data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of constants.csv in ``data_dir`` (s, c, then every constant)."""
    header, t = read_table(Path(data_dir) / CONSTANTS_FILE, CONSTANT_COLUMNS)
    return {name: t[:, j] for j, name in enumerate(header)}


@lru_cache(maxsize=None)
def read_kd(data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of kd.csv in ``data_dir`` (s, c, kd_three_term, kd_true)."""
    header, t = read_table(Path(data_dir) / KD_FILE, KD_COLUMNS)
    return {name: t[:, j] for j, name in enumerate(header)}


@lru_cache(maxsize=None)
def read_sampling(name: str, data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of the sampling table ``name`` (one of :data:`SAMPLING_FILES`) in ``data_dir``."""
    header, t = read_table(Path(data_dir) / name, SAMPLING_COLUMNS)
    return {column: t[:, j] for j, column in enumerate(header)}


def check_tables(data_dir: Path) -> None:
    """Read every table (a :class:`fitlab.store.TableError` names the first missing or malformed one)."""
    for name, columns in TABLE_FILES.items():
        read_table(Path(data_dir) / name, columns)
