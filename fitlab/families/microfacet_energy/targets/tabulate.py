r"""Exact tables of the microfacet_energy family, written as CSV through :mod:`fitlab.store` (the
commented header of :func:`fitlab.store.format_table`: method, tolerance, grid; then the columns) into
a folder the caller names.  The committed copies live in fitlab/data/microfacet_energy/.

Grids (every header states its own):

* ``centres N``: mu_j = (j + 1/2)/N and alpha_k = (k + 1/2)/N, j, k = 0..N-1: the texel centres of an
  N x N texture, which is what a bilinear texture lookup samples.  The blog's GGX table is 128 x 128
  ("32 x 32 is more than enough", after Kulla and Conti) and its Oren-Nayar table 16 x 16; the blog
  lists (mu, alpha, E) triples but does not say whether its mu and alpha are texel centres or texel
  edges (nor does its image), so these tables take the centres and say so.
* ``nodes N``: mu_j = j/N, alpha_k = k/N, j, k = 0..N, both ends included: mu = 0 (grazing) and alpha = 0
  (the mirror, E = 1 by definition) are rows of the table.

Rows run over mu fastest (one block of rows per alpha, as a texture's rows run over u), columns
``mu, alpha`` then one E column per model (:data:`fitlab.families.microfacet_energy.exact.MODEL_NAMES`).
E_avg(alpha) (Kulla-Conti's 2 int E mu dmu; the blog's is pi times it) is tabulated once on
alpha = k/256, k = 0..256, which holds every alpha of the E tables above.

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.targets.tabulate``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab.families.microfacet_energy.exact import (
    GGX_MODELS,
    MODEL_NAMES,
    OREN_NAYAR_MODELS,
    average_albedo,
    directional_albedo,
)
from fitlab.families.microfacet_energy.lobes import params as lobe_params
from fitlab.families.microfacet_energy.lobes import tables as lobe_tables
from fitlab.store import Table, TableError, read_table
from fitlab.store import write_tables as store_write_tables

__all__ = [
    "FAMILY_NAME",
    "AlbedoTable",
    "TABLES",
    "FINE_TABLES",
    "TABLE_FILES",
    "AVERAGE_FILE",
    "AVERAGE_COLUMNS",
    "TOLERANCE",
    "DECIMALS",
    "grid",
    "albedo_table",
    "average_table",
    "build_tables",
    "write_tables",
    "check_tables",
    "read_albedo_table",
    "read_average_table",
]

TOLERANCE = 1e-9  # absolute, E and E_avg
DECIMALS = 12  # values are written rounded to this many decimals
AVERAGE_SIZE = 256  # E_avg on alpha = k/256, k = 0..256
AVERAGE_FILE = "E_avg_nodes_256.csv"
AVERAGE_COLUMNS = ("alpha", *(f"E_avg_{m}" for m in MODEL_NAMES))


@dataclass(frozen=True)
class AlbedoTable:
    """One E(mu, alpha) table: its models, grid kind ("centres" or "nodes") and size N."""

    stem: str
    models: tuple[str, ...]
    kind: str
    size: int

    @property
    def file(self) -> str:
        return f"{self.stem}_E_{self.kind}_{self.size}.csv"

    @property
    def columns(self) -> tuple[str, ...]:
        return ("mu", "alpha", *(f"E_{m}" for m in self.models))


TABLES = (
    AlbedoTable("ggx", GGX_MODELS, "centres", 32),
    AlbedoTable("ggx", GGX_MODELS, "centres", 128),
    AlbedoTable("ggx", GGX_MODELS, "nodes", 64),
    AlbedoTable("oren_nayar", OREN_NAYAR_MODELS, "centres", 16),
    AlbedoTable("oren_nayar", OREN_NAYAR_MODELS, "nodes", 64),
)
FINE_TABLES = (AlbedoTable("ggx", GGX_MODELS, "centres", 256),)

#: every committed table file and its columns (the E tables, E_avg, the simulated lobes and their per-lobe fits)
TABLE_FILES = {
    **{t.file: t.columns for t in TABLES},
    AVERAGE_FILE: AVERAGE_COLUMNS,
    **lobe_tables.LOBE_FILES,
    **lobe_params.PARAM_FILES,
}
#: the family's name: its tables live in fitlab/data/FAMILY_NAME/ and DATA/FAMILY_NAME/
FAMILY_NAME = "microfacet_energy"


def grid(kind: str, size: int) -> np.ndarray:
    """The 1-D grid of a table: texel centres (k + 1/2)/N, k < N, or nodes k/N, k <= N."""
    if kind == "centres":
        return (np.arange(size) + 0.5) / size
    if kind == "nodes":
        return np.arange(size + 1) / size
    raise ValueError(f"kind must be 'centres' or 'nodes', got {kind!r}")


def _grid_text(kind: str, size: int) -> str:
    if kind == "centres":
        return (
            f"texel centres: mu = (j + 1/2)/{size}, alpha = (k + 1/2)/{size}, j, k = 0..{size - 1}; mu varies fastest"
        )
    return f"nodes: mu = j/{size}, alpha = k/{size}, j, k = 0..{size} (ends included); mu varies fastest"


def _method_text(models) -> str:
    if set(models) <= set(GGX_MODELS):
        return (
            "E(mu, alpha) = int f mu_i dw_i, F = 1, GGX with separable and height-correlated Smith; "
            "half-vector quadrature in log tan(theta_m) (fitlab.families.microfacet_energy.exact, "
            "route half_vector); alpha = 0: the mirror, E = 1"
        )
    return (
        "E(mu, alpha) = int f mu_i dw_i of the blog's Oren-Nayar (sigma = pi alpha / 2; A with 0.33 or "
        "0.57; cos(phi) or the HLSL's gamma), rho = 1, closed form (fitlab.families.microfacet_energy.exact)"
    )


def _rounded(values) -> np.ndarray:
    return np.round(np.asarray(values, dtype=float), DECIMALS)


def albedo_table(spec: AlbedoTable) -> Table:
    """Compute one E table."""
    axis = grid(spec.kind, spec.size)
    alpha, mu = np.meshgrid(axis, axis, indexing="ij")  # rows: alpha outer, mu inner
    columns = [mu.ravel(), alpha.ravel()]
    columns += [_rounded(directional_albedo(mu, alpha, model).ravel()) for model in spec.models]
    return Table(
        spec.file.removesuffix(".csv"),
        _method_text(spec.models),
        f"absolute {TOLERANCE:g} (the independent direction route agrees: check_tables); "
        f"values rounded to {DECIMALS} decimals",
        spec.columns,
        np.column_stack(columns).tolist(),
        _grid_text(spec.kind, spec.size),
    )


_AVERAGE_GRID_TEXT = f"nodes: alpha = k/{AVERAGE_SIZE}, k = 0..{AVERAGE_SIZE} (every alpha of the E tables)"


def average_table() -> Table:
    """Compute the E_avg table (every model) on alpha = k/256."""
    alpha = grid("nodes", AVERAGE_SIZE)
    columns = [alpha] + [_rounded(average_albedo(alpha, model)) for model in MODEL_NAMES]
    return Table(
        AVERAGE_FILE.removesuffix(".csv"),
        "E_avg(alpha) = 2 int_0^1 E(mu) mu dmu (Kulla-Conti; the blog's E_avg is pi times this), F = 1: "
        "Gauss-Legendre graded towards mu = 0 and 1 of the exact E (GGX); closed form A + B k (Oren-Nayar)",
        f"absolute {TOLERANCE:g}; values rounded to {DECIMALS} decimals",
        AVERAGE_COLUMNS,
        np.column_stack(columns).tolist(),
        _AVERAGE_GRID_TEXT,
    )


def build_tables(show_progress: bool = True, fine: bool = False, specs=None) -> dict[str, Table]:
    """Every table ({file name: Table}); ``specs`` (AlbedoTable) replaces the committed set of E tables,
    and then neither the E_avg table nor the lobe tables are built (for small test grids)."""
    chosen = tuple(specs) if specs is not None else TABLES + (FINE_TABLES if fine else ())
    tables = {}
    with tqdm(total=len(chosen) + (specs is None), desc="tabulating", unit="table", disable=not show_progress) as bar:
        for spec in chosen:
            tables[spec.file] = albedo_table(spec)
            bar.update(1)
        if specs is None:
            tables[AVERAGE_FILE] = average_table()
            bar.update(1)
    if specs is None:
        lobes = lobe_tables.build_lobe_tables(show_progress)
        tables.update(lobes)
        simulated = {(k, w): lobe_tables.lobes_from_rows(lobes[lobe_tables.lobe_file(k, w)].rows, k, w)
                     for k in lobe_tables.KINDS for w in lobe_tables.SETS}  # fmt: skip
        tables.update(lobe_params.build_params_tables(simulated, show_progress))
    return tables


def write_tables(out: Path, show_progress: bool = True, fine: bool = False) -> dict[str, str]:
    """Compute every table, then write them all into ``out`` as one unit (nothing is written on failure);
    returns file name -> sha256 prefix (:func:`fitlab.store.write_tables`)."""
    return store_write_tables(Path(out), build_tables(show_progress, fine))


def read_albedo_table(path: Path, spec: AlbedoTable) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """(mu axis, alpha axis, {model: E of shape (len(alpha), len(mu))}) of an E table written here; the
    header (its "# grid:" line too) and the grid columns are checked (:class:`fitlab.store.TableError`)."""
    path = Path(path)
    _, data = read_table(path, spec.columns, grid=_grid_text(spec.kind, spec.size))
    axis = grid(spec.kind, spec.size)
    n = axis.size
    if data.shape[0] != n * n:
        raise TableError(f"{path}: {data.shape[0]} rows, expected {n * n}; run `fitlab tabulate` to rewrite it")
    alpha, mu = np.meshgrid(axis, axis, indexing="ij")
    if not (np.array_equal(data[:, 0], mu.ravel()) and np.array_equal(data[:, 1], alpha.ravel())):
        raise TableError(f"{path}: the (mu, alpha) columns are not the grid {_grid_text(spec.kind, spec.size)}")
    return axis, axis, {m: data[:, 2 + j].reshape(n, n) for j, m in enumerate(spec.models)}


def read_average_table(path: Path) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(alpha, {model: E_avg}) of the E_avg table, header (its "# grid:" line too) and grid checked."""
    path = Path(path)
    _, data = read_table(path, AVERAGE_COLUMNS, grid=_AVERAGE_GRID_TEXT)
    alpha = grid("nodes", AVERAGE_SIZE)
    if data.shape[0] != alpha.size or not np.array_equal(data[:, 0], alpha):
        raise TableError(f"{path}: the alpha column is not k/{AVERAGE_SIZE}, k = 0..{AVERAGE_SIZE}")
    return alpha, {m: data[:, 1 + j] for j, m in enumerate(MODEL_NAMES)}


def _sample(n: int, every: int) -> np.ndarray:
    """Every ``every``-th index of 0..n-1, and the last one (the grid's edges are always checked)."""
    return np.unique(np.append(np.arange(0, n, every), n - 1))


def check_tables(folder: Path, show_progress: bool = True, every: int = 8, specs=None) -> list[str]:
    """Read every table in ``folder`` and recompute a sample of its rows (every ``every``-th mu and alpha,
    and the last) by the other route of the exact engine (direction quadrature); return one line per
    failure (a missing or malformed file, or a value off by more than TOLERANCE + the rounding)."""
    folder = Path(folder)
    chosen = tuple(specs) if specs is not None else TABLES
    failures = []
    limit = TOLERANCE + 0.5 * 10.0**-DECIMALS
    with tqdm(total=len(chosen) + (specs is None), desc="checking", disable=not show_progress) as bar:
        for spec in chosen:
            try:
                mu, alpha, values = read_albedo_table(folder / spec.file, spec)
            except TableError as exc:
                failures.append(str(exc))
                bar.update(1)
                continue
            j, k = _sample(mu.size, every), _sample(alpha.size, every)
            a, m = np.meshgrid(alpha[k], mu[j], indexing="ij")
            for model, table in values.items():
                want = directional_albedo(m, a, model, method="direction")
                err = np.abs(table[np.ix_(k, j)] - want)
                if not np.all(err <= limit):
                    idx = np.unravel_index(int(np.argmax(err)), err.shape)
                    failures.append(
                        f"{spec.file}: E_{model} at mu={m[idx]!r} alpha={a[idx]!r} differs from the "
                        f"direction route by {err[idx]:.2e}"
                    )
            bar.update(1)
        if specs is None:
            try:
                alpha, values = read_average_table(folder / AVERAGE_FILE)
            except TableError as exc:
                failures.append(str(exc))
            else:
                k = _sample(alpha.size, 8 * every)
                for model, column in values.items():
                    err = np.abs(column[k] - average_albedo(alpha[k], model, method="direction"))
                    if not np.all(err <= limit):
                        failures.append(
                            f"{AVERAGE_FILE}: E_avg_{model} differs from the direction route by {err.max():.2e}"
                        )
            bar.update(1)
    if specs is None:
        failures += lobe_tables.check_lobe_tables(folder)
        failures += lobe_params.check_params_tables(folder)
    return failures
