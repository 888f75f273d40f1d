r"""The layout of the family's exact tables: file names, columns and grids, written once, and where they are read.

:mod:`.tabulate` writes these files (through :func:`fitlab.store.write_tables`);
everything that reads them (training sets, the report's interpolation) reads
them here, through :func:`read_checked`: :func:`fitlab.store.read_table` checks the header, that every
value is finite (inf only where the exact value is infinite: :data:`INFINITE`), and that the rows are
exactly the grid the header states (:func:`grid_text`, :func:`grid_points`).
The packaged tables are ``fitlab/data/lambert_sphere/``; :func:`tables_dir`
prefers the user's data folder when ``fitlab tabulate`` has written them there
(:mod:`fitlab.resources`).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fitlab.families.lambert_sphere.exact import CONSTANT_NAMES
from fitlab.families.lambert_sphere.exact.sampling import MU_MIN
from fitlab.resources import tables_folder
from fitlab.store import read_table

__all__ = [
    "FAMILY_NAME",
    "tables_dir",
    "h_columns",
    "h_file",
    "CONSTANTS_FILE",
    "CONSTANT_COLUMNS",
    "KD_FILE",
    "KD_COLUMNS",
    "TRUE_FILE",
    "TRUE_COLUMNS",
    "TRUE_ORDERS",
    "TABLE_FILES",
    "SAMPLING_FILES",
    "SAMPLING_COLUMNS",
    "INFINITE",
    "S_GRID",
    "C_GRID",
    "MU_GRID",
    "GRID_TEXT",
    "TRUE_S_GRID",
    "TRUE_MU_GRID",
    "TRUE_GRID_TEXT",
    "true_grid",
    "SAMPLING_GRIDS",
    "grid_text",
    "grid_points",
    "read_checked",
    "read_sampling",
    "read_h",
    "read_constants",
    "read_kd",
    "read_true_orders",
    "check_tables",
]

#: the family's name: its tables live in ``fitlab/data/FAMILY_NAME/`` and ``DATA/FAMILY_NAME/``
FAMILY_NAME = "lambert_sphere"
CONSTANTS_FILE = "constants.csv"
CONSTANT_COLUMNS = ("s", "c", *CONSTANT_NAMES)
KD_FILE = "kd.csv"
KD_COLUMNS = ("s", "c", "kd_three_term", "kd_mixed", "kd_true")
#: the Fourier orders of multiple scattering kept in the true-phase table
TRUE_ORDERS = 3
#: the true multiple scattering beside the three-term one, orders 0 to TRUE_ORDERS - 1, on (s, mu_i <= mu_o)
TRUE_FILE = "true_orders.csv"
TRUE_COLUMNS = (
    "s",
    "c",
    "mu_i",
    "mu_o",
    *(f"fm{m}_true" for m in range(TRUE_ORDERS)),
    *(f"fm{m}_three_term" for m in range(TRUE_ORDERS)),
)
#: the variance-optimal sampling mixture (:mod:`..exact.sampling`) on the training and the validation grid
SAMPLING_FILES = ("sampling.csv", "sampling_validation.csv")
SAMPLING_COLUMNS = ("s", "c", "mu_i", "weight", "exponent", "relvar_optimal", "relvar_cosine")


def h_file(order: int) -> str:
    return f"h{order}.csv"


def h_columns(order: int) -> tuple[str, ...]:
    return ("s", "c", "mu", f"H{order}")


#: every table file and its columns
TABLE_FILES = {
    **{h_file(m): h_columns(m) for m in range(3)},
    CONSTANTS_FILE: CONSTANT_COLUMNS,
    KD_FILE: KD_COLUMNS,
    TRUE_FILE: TRUE_COLUMNS,
    **{name: SAMPLING_COLUMNS for name in SAMPLING_FILES},
}


#: the H tables', constants.csv's and kd.csv's grid: c = 1 - s^2 (dense near c = 1), mu with its small values and inf
S_GRID = np.arange(65) / 64.0
C_GRID = 1.0 - S_GRID**2
MU_GRID = np.concatenate(([0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3], np.arange(1, 65) / 64.0, [np.inf]))

#: the H tables', constants.csv's and kd.csv's grid, as their "# grid:" header line states it
GRID_TEXT = "c = 1 - s^2, s = k/64 for k = 0..64; mu = 0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, j/64 for j = 1..64, inf"


#: the true-phase table's grid: s = k/8, and mu = 1e-9 (where the exported tables read mu -> 0: the orders are
#: +-inf at mu_i = mu_o = 0) then (j/32)^2, uniform in sqrt(mu), the coordinate the exported tables read it in
TRUE_S_GRID = np.arange(9) / 8.0
TRUE_MU_GRID = np.concatenate(([1e-9], (np.arange(1, 33) / 32.0) ** 2))
TRUE_GRID_TEXT = "c = 1 - s^2, s = k/8 for k = 0..8; mu_i <= mu_o in 1e-9, (j/32)^2 for j = 1..32 (mu_i outer)"


def true_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s, mu_i, mu_o) of the true-phase table's rows: s outer, then mu_i, then mu_o >= mu_i."""
    i, j = np.triu_indices(TRUE_MU_GRID.size)
    n = i.size
    k = TRUE_S_GRID.size
    return np.repeat(TRUE_S_GRID, n), np.tile(TRUE_MU_GRID[i], k), np.tile(TRUE_MU_GRID[j], k)


def _interleaved(denominator: int) -> np.ndarray:
    return np.concatenate(([0.0], (2 * np.arange(denominator // 2) + 1) / denominator, [1.0]))


#: the sampling tables' grids, (s axis, mu_i axis, text) by file: the validation grid's interior points
#: lie between the training grid's
SAMPLING_GRIDS = {
    SAMPLING_FILES[0]: (
        np.arange(17) / 16,
        np.concatenate(([MU_MIN, 0.01], np.arange(1, 33) / 32)),
        "c = 1 - s^2, s = k/16 for k = 0..16; mu_i = 1e-3, 0.01, j/32 for j = 1..32",
    ),
    SAMPLING_FILES[1]: (
        _interleaved(32),
        np.concatenate(([MU_MIN, 0.003], _interleaved(64)[1:])),
        "c = 1 - s^2, s = 0, (2k+1)/32 for k = 0..15, 1; mu_i = 1e-3, 0.003, (2j+1)/64 for j = 0..31, 1",
    ),
}


#: the columns that may hold +inf, by table: H at mu = inf (infinite at c = 1), and H0_inf at c = 1
INFINITE = {**{h_file(m): ("mu", f"H{m}") for m in range(3)}, CONSTANTS_FILE: ("H0_inf",)}


def tables_dir(data_dir: Path | str | None = None) -> Path:
    """The folder the tables are read from: ``data_dir`` itself when given; else the user's data folder's
    ``lambert_sphere/`` when it holds every table, the packaged tables when it holds none, and a
    :class:`fitlab.store.TableError` naming the first one missing otherwise (:func:`fitlab.resources.tables_folder`)."""
    return Path(data_dir) if data_dir is not None else tables_folder(FAMILY_NAME, tuple(TABLE_FILES))


def grid_text(name: str) -> str:
    """What the "# grid:" header line of the table ``name`` states (:mod:`.tabulate` writes it)."""
    if name == TRUE_FILE:
        return TRUE_GRID_TEXT
    return SAMPLING_GRIDS[name][2] if name in SAMPLING_FILES else GRID_TEXT


def grid_points(name: str) -> dict[str, np.ndarray]:
    """The grid columns of the table ``name``, row by row, as :mod:`.tabulate` writes them: (s, c, mu) of an
    H table (s outer), (s, c) of constants.csv and kd.csv, (s, c, mu_i) of a sampling table (s outer), (s, c, mu_i,
    mu_o) of the true-phase table (s outer, then mu_i, then mu_o >= mu_i)."""
    if name == TRUE_FILE:
        s, mu_i, mu_o = true_grid()
        return {"s": s, "c": 1.0 - s * s, "mu_i": mu_i, "mu_o": mu_o}
    if name in SAMPLING_FILES:
        s_axis, mu_axis, _ = SAMPLING_GRIDS[name]
        return {
            "s": np.repeat(s_axis, len(mu_axis)),
            "c": np.repeat(1.0 - s_axis * s_axis, len(mu_axis)),
            "mu_i": np.tile(mu_axis, len(s_axis)),
        }
    if name in (CONSTANTS_FILE, KD_FILE):
        return {"s": S_GRID, "c": C_GRID}
    n = len(MU_GRID)
    return {"s": np.repeat(S_GRID, n), "c": np.repeat(C_GRID, n), "mu": np.tile(MU_GRID, len(S_GRID))}


def read_checked(name: str, data_dir: Path) -> tuple[list[str], np.ndarray]:
    """(header, rows) of the table ``name`` in ``data_dir``, read afresh with every check: its columns, finite
    values (inf only in :data:`INFINITE`), its "# grid:" line and its rows exactly that grid
    (:func:`fitlab.store.read_table`; each refusal one :class:`fitlab.store.TableError` line naming it)."""
    return read_table(Path(data_dir) / name, TABLE_FILES[name], grid=grid_text(name), points=grid_points(name),
                      infinite=INFINITE.get(name, ()))  # fmt: skip


@cache
def read_h(order: int, data_dir: Path) -> np.ndarray:
    """Rows (s, c, mu, H) of h{order}.csv in ``data_dir``."""
    return read_checked(h_file(order), data_dir)[1]


@cache
def read_constants(data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of constants.csv in ``data_dir`` (s, c, then every constant)."""
    header, t = read_checked(CONSTANTS_FILE, data_dir)
    return {name: t[:, j] for j, name in enumerate(header)}


@cache
def read_kd(data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of kd.csv in ``data_dir`` (s, c, kd_three_term, kd_mixed, kd_true)."""
    header, t = read_checked(KD_FILE, data_dir)
    return {name: t[:, j] for j, name in enumerate(header)}


@cache
def read_true_orders(data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of true_orders.csv in ``data_dir`` (:data:`TRUE_COLUMNS`)."""
    header, t = read_checked(TRUE_FILE, data_dir)
    return {name: t[:, j] for j, name in enumerate(header)}


@cache
def read_sampling(name: str, data_dir: Path) -> dict[str, np.ndarray]:
    """Column name -> values of the sampling table ``name`` (one of :data:`SAMPLING_FILES`) in ``data_dir``."""
    header, t = read_checked(name, data_dir)
    return {column: t[:, j] for j, column in enumerate(header)}


def check_tables(data_dir: Path) -> None:
    """Read every table with every check (:func:`read_checked`; a :class:`fitlab.store.TableError` names the first
    missing or malformed one)."""
    for name in TABLE_FILES:
        read_checked(name, data_dir)
