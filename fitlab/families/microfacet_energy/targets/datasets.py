r"""Training and validation sets of the microfacet_energy targets, from the exact tables and engine.

Every set holds exact values of one model (:data:`fitlab.families.microfacet_energy.exact.MODELS`):
E(mu, alpha), 1 - E, or E_avg(alpha).  The committed tables (fitlab/data/microfacet_energy, or the
user's data folder when ``fitlab tabulate`` wrote them there: :func:`tables_dir`) give the bulk of the
points; the exact engine adds the domain's edges and the grazing layer, through fitlab's persistent
cache (:func:`fitlab.cache.cached_arrays`), so only the first run pays for them.

The grazing layer (GGX).  For small alpha, E changes on the scale mu ~ alpha next to grazing: with
t = mu/alpha fixed and alpha -> 0, 1 - E tends to a function of t alone that rises from 1 - E(0) (0.064
separable, 0 height-correlated) to about 0.12 near t = 1 and decays like 1/t^2.  A table with step
1/64 in alpha does not resolve it for alpha < 1/64, so both sets add lines at small alpha with
mu = t alpha.

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.targets.datasets``."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fitlab.cache import cached_arrays
from fitlab.core import Dataset
from fitlab.families.microfacet_energy import exact
from fitlab.families.microfacet_energy.exact import average_albedo, directional_albedo
from fitlab.families.microfacet_energy.targets import tabulate
from fitlab.families.microfacet_energy.targets.tabulate import FAMILY_NAME
from fitlab.resources import tables_folder

__all__ = [
    "FAMILY_NAME",
    "tables_dir",
    "albedo_training",
    "albedo_validation",
    "average_training",
    "average_validation",
    "albedo_grid",
    "average_grid",
    "TRAINING_SMALL_ALPHA",
    "VALIDATION_SMALL_ALPHA",
    "TRAINING_LAYER_T",
    "VALIDATION_LAYER_T",
    "TRAINING_SMALL_MU",
    "VALIDATION_SMALL_MU",
]


#: small alphas of the grazing-layer lines: training and validation take different ones
TRAINING_SMALL_ALPHA = (1e-4, 1e-3, 4e-3)
VALIDATION_SMALL_ALPHA = (1e-6, 1e-5, 5e-4, 2e-3)
#: t = mu/alpha on those lines: powers of 2 for training; for validation 3/16 times powers of 2, 1/16, and every
#: 2^(j/4) from 1/16 to 64 (the error of a fit peaks on this layer, at t ~ 1 to 20: a step of 2^(1/4) in t finds
#: the peak, where the old steps of 2 missed it by 5 %; the training lines are at other alphas)
TRAINING_LAYER_T = tuple(2.0**k for k in range(-3, 5))
VALIDATION_LAYER_T = tuple(sorted({1 / 16, *(3 * 2.0**k / 16 for k in range(0, 7)),
                                   *(2.0 ** (j / 4) for j in range(-16, 25))}))  # fmt: skip
#: mu on the small-mu lines, at every alpha of the set (table alphas and small alphas): 1 - E of height-correlated
#: Smith falls to 0 at mu = 0 like -mu log(mu), so the relative error of a fit of it peaks where 1 - E crosses
#: the floor 1e-3 of its scale, at mu from 1e-5 to 1e-3 depending on alpha, below the tables' first mu (1/256).
#: Training: 10^(k/2), 1e-7 to 10^-2.5; validation: 10^(k/8) over the same range, none a training mu.
TRAINING_SMALL_MU = tuple(10.0 ** (k / 2) for k in range(-14, -4))
VALIDATION_SMALL_MU = tuple(10.0 ** (k / 8) for k in range(-56, -19) if k % 4)

_GGX_NODES = next(t for t in tabulate.TABLES if t.stem == "ggx" and t.kind == "nodes")
_GGX_CENTRES = next(t for t in tabulate.TABLES if t.stem == "ggx" and t.kind == "centres" and t.size == 128)
_ON_NODES = next(t for t in tabulate.TABLES if t.stem == "oren_nayar" and t.kind == "nodes")
_AVERAGE_STEP = 4  # training takes every 4th row of the E_avg table (alpha = k/64)


def tables_dir(data_dir: Path | str | None = None) -> Path:
    """The folder the tables are read from: ``data_dir`` itself when given; else the user's data folder's
    ``microfacet_energy/`` when it holds every table (:func:`fitlab.resources.tables_folder`), else the
    packaged tables."""
    return Path(data_dir) if data_dir is not None else tables_folder(FAMILY_NAME, tuple(tabulate.TABLE_FILES))


def _cached(name: str, grid: str, compute, inputs: tuple[str, ...], **axes) -> Dataset:
    """``compute()`` (a Dataset with ``inputs``) through fitlab's persistent cache of exact values, keyed by
    the set's name, its grid (text and ``axes`` arrays) and the exact engine's source."""

    def arrays():
        ds = compute()
        return {**{f"in_{k}": ds.inputs[k] for k in inputs}, "y": ds.y}

    names = (*(f"in_{k}" for k in inputs), "y")
    parts = {
        "family": FAMILY_NAME,
        "set": name,
        "grid": grid,
        **{k: np.asarray(v, dtype=float) for k, v in axes.items()},
    }
    a = cached_arrays(f"{FAMILY_NAME}-{name}", parts, arrays, names, sources=exact.SOURCES)
    return Dataset({k: a[f"in_{k}"] for k in inputs}, a["y"], grid)


def _concat(grid: str, *sets: Dataset) -> Dataset:
    """One dataset of ``sets`` (same inputs), duplicate points removed (the first copy kept)."""
    names = tuple(sets[0].inputs)
    cols = {k: np.concatenate([s.inputs[k] for s in sets]) for k in names}
    y = np.concatenate([s.y for s in sets])
    _, first = np.unique(np.column_stack([cols[k] for k in names]), axis=0, return_index=True)
    keep = np.sort(first)
    return Dataset({k: v[keep] for k, v in cols.items()}, y[keep], grid)


def _engine_points(model: str, mu: np.ndarray, alpha: np.ndarray, name: str, grid: str) -> Dataset:
    """E of ``model`` at the points (mu, alpha) by the exact engine, cached."""
    mu, alpha = (np.asarray(x, dtype=float).ravel() for x in np.broadcast_arrays(mu, alpha))
    return _cached(f"{model}-{name}", grid, lambda: Dataset({"mu": mu, "alpha": alpha},
                                                             directional_albedo(mu, alpha, model), grid),
                   ("mu", "alpha"), mu=mu, alpha=alpha)  # fmt: skip


def _layer_points(alphas, ts, mu_extra=()) -> tuple[np.ndarray, np.ndarray]:
    """(mu, alpha) on the grazing-layer lines: at each alpha, mu = 0, mu = t alpha and ``mu_extra``."""
    mu, alpha = [], []
    for a in alphas:
        line = np.unique(np.concatenate(([0.0], a * np.asarray(ts), np.asarray(mu_extra, dtype=float))))
        line = line[line <= 1.0]
        mu.append(line)
        alpha.append(np.full(line.shape, a))
    return np.concatenate(mu), np.concatenate(alpha)


def _mesh(mu_axis, alpha_axis) -> tuple[np.ndarray, np.ndarray]:
    alpha, mu = np.meshgrid(alpha_axis, mu_axis, indexing="ij")
    return mu.ravel(), alpha.ravel()


def _odd(denominator: int) -> np.ndarray:
    """Odd multiples of 1/denominator in (0, 1)."""
    return (2 * np.arange(denominator // 2) + 1) / denominator


# -- E(mu, alpha) ------------------------------------------------------------------------------------
def albedo_training(model: str, data_dir: Path | None = None) -> Dataset:
    """E of ``model`` on its training grid (docs/microfacet_energy_derivation.md); ``data_dir``: the tables' folder (None:
    :func:`tables_dir`)."""
    return _albedo_training(model, tables_dir(data_dir))


@cache
def _albedo_training(model: str, folder: Path) -> Dataset:
    if model.startswith("ggx"):
        mu_axis, alpha_axis, table = tabulate.read_albedo_table(folder / _GGX_NODES.file, _GGX_NODES)
        mu, alpha = _mesh(mu_axis, alpha_axis)
        bulk = Dataset({"mu": mu, "alpha": alpha}, table[model].ravel(), "")
        layer_mu, layer_alpha = _layer_points(TRAINING_SMALL_ALPHA, TRAINING_LAYER_T)
        layer = _engine_points(model, layer_mu, layer_alpha, "training-layer", "grazing layer, training")
        small_mu, small_alpha = _mesh(TRAINING_SMALL_MU, np.concatenate((TRAINING_SMALL_ALPHA, alpha_axis[1:])))
        small = _engine_points(model, small_mu, small_alpha, "training-small-mu", "small mu, training")
        grid = (
            f"table {_GGX_NODES.file}: mu, alpha = k/64, k = 0..64; engine: alpha in {TRAINING_SMALL_ALPHA} "
            f"at mu = 0 and mu = t alpha, t = 2^k, k = -3..4; mu = 10^(k/2), k = -14..-5, at every alpha > 0"
        )
        return _concat(grid, bulk, layer, small)
    mu_axis, alpha_axis, table = tabulate.read_albedo_table(folder / _ON_NODES.file, _ON_NODES)
    mu, alpha = _mesh(mu_axis, alpha_axis)
    return Dataset(
        {"mu": mu, "alpha": alpha}, table[model].ravel(), f"table {_ON_NODES.file}: mu, alpha = k/64, k = 0..64"
    )


def albedo_validation(model: str, data_dir: Path | None = None) -> Dataset:
    """E of ``model`` on its validation grid (docs/microfacet_energy_derivation.md)."""
    return _albedo_validation(model, tables_dir(data_dir))


@cache
def _albedo_validation(model: str, folder: Path) -> Dataset:
    ends = np.array([0.0, 1.0])
    if model.startswith("ggx"):
        mu_axis, alpha_axis, table = tabulate.read_albedo_table(folder / _GGX_CENTRES.file, _GGX_CENTRES)
        mu, alpha = _mesh(mu_axis, alpha_axis)
        bulk = Dataset({"mu": mu, "alpha": alpha}, table[model].ravel(), "")
        full_mu = np.concatenate((ends, mu_axis))
        edge_mu = np.concatenate((_mesh(ends, np.concatenate((ends, alpha_axis)))[0], _mesh(full_mu, ends)[0]))
        edge_alpha = np.concatenate((_mesh(ends, np.concatenate((ends, alpha_axis)))[1], _mesh(full_mu, ends)[1]))
        edges = _engine_points(model, edge_mu, edge_alpha, "validation-edges", "edges mu, alpha in {0, 1}")
        layer_mu, layer_alpha = _layer_points(VALIDATION_SMALL_ALPHA, VALIDATION_LAYER_T, full_mu)
        layer = _engine_points(model, layer_mu, layer_alpha, "validation-layer-dense", "grazing layer, validation")
        small_mu, small_alpha = _mesh(VALIDATION_SMALL_MU, np.concatenate((VALIDATION_SMALL_ALPHA, alpha_axis, [1.0])))
        small = _engine_points(model, small_mu, small_alpha, "validation-small-mu", "small mu, validation")
        grid = (
            f"table {_GGX_CENTRES.file}: mu, alpha = (2k+1)/256; engine: mu, alpha in {{0, 1}} on those lines; "
            f"alpha in {VALIDATION_SMALL_ALPHA} at mu = 0, 1, (2k+1)/256 and t alpha, t = 1/16, 3 2^k/16 "
            f"(k = 0..6) and 2^(j/4) (j = -16..24); mu = 10^(k/8), k = -55..-21 not a multiple of 4, at every "
            f"alpha > 0"
        )
        return _concat(grid, bulk, edges, layer, small)
    axis = np.concatenate((ends, _odd(256)))
    mu, alpha = _mesh(axis, axis)
    grid = "closed form: mu, alpha = (2k+1)/256 and 0, 1"
    return _engine_points(model, mu, alpha, "validation", grid)


# -- E_avg(alpha) ------------------------------------------------------------------------------------
@cache
def _average_table(folder: Path) -> tuple[np.ndarray, dict]:
    return tabulate.read_average_table(folder / tabulate.AVERAGE_FILE)


def _average_engine(model: str, alphas, name: str) -> Dataset:
    alpha = np.asarray(alphas, dtype=float)
    grid = f"engine: alpha in {tuple(alphas)}"
    return _cached(
        f"{model}-average-{name}",
        grid,
        lambda: Dataset({"alpha": alpha}, average_albedo(alpha, model), grid),
        ("alpha",),
        alpha=alpha,
    )


def average_training(model: str, data_dir: Path | None = None) -> Dataset:
    """E_avg of ``model`` on its training grid (docs/microfacet_energy_derivation.md)."""
    return _average_set(model, tables_dir(data_dir), True)


def average_validation(model: str, data_dir: Path | None = None) -> Dataset:
    """E_avg of ``model`` on its validation grid (docs/microfacet_energy_derivation.md)."""
    return _average_set(model, tables_dir(data_dir), False)


@cache
def _average_set(model: str, folder: Path, training: bool) -> Dataset:
    alpha, columns = _average_table(folder)
    k = np.arange(alpha.size)
    rows = (k % _AVERAGE_STEP == 0) if training else ((k % _AVERAGE_STEP != 0) | (k == 0) | (k == k[-1]))
    table = Dataset({"alpha": alpha[rows]}, columns[model][rows], "")
    what = f"rows k = 0 mod {_AVERAGE_STEP}" if training else f"rows k != 0 mod {_AVERAGE_STEP}, and k = 0, 256"
    grid = f"table {tabulate.AVERAGE_FILE} (alpha = k/256), {what}"
    if not model.startswith("ggx"):
        return Dataset(table.inputs, table.y, grid)
    small = TRAINING_SMALL_ALPHA if training else VALIDATION_SMALL_ALPHA
    grid += f"; engine: alpha in {small}"
    return _concat(grid, table, _average_engine(model, small, "training" if training else "validation"))


# -- exact values on tensor grids (residual maps) ------------------------------------------------------
def albedo_grid(model: str):
    """``exact_grid`` of E: axes mu and alpha -> (inputs on the grid, E, {})."""

    def grid(axes):
        mu, alpha = np.meshgrid(np.asarray(axes["mu"], dtype=float), np.asarray(axes["alpha"], dtype=float),
                                indexing="ij")  # fmt: skip
        return {"mu": mu, "alpha": alpha}, directional_albedo(mu, alpha, model), {}

    return grid


def average_grid(model: str):
    """``exact_grid`` of E_avg: axis alpha -> (inputs, E_avg, {})."""

    def grid(axes):
        alpha = np.asarray(axes["alpha"], dtype=float)
        return {"alpha": alpha.copy()}, average_albedo(alpha, model), {}

    return grid
