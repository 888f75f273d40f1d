"""The exact tables (fitlab/data/lambert_sphere/, or DATA/lambert_sphere/ from ``fitlab tabulate``): H0, H1, H2 on a (mu, c) grid, the constants and kd.

Grid (documented in every header):
  c = 1 - s^2 with s = k/64, k = 0..64 (uniform in s = sqrt(1-c): dense near
  c = 1, both ends included);
  mu = 0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, then j/64 for j = 1..64, and inf.

Values are written with 17 significant digits, so the files are a faithful
copy of the doubles; the same machine and library versions reproduce them byte
for byte.  ``check`` recomputes a sample of rows by the independent methods
(Fock integral for H, the moment relations for the constants) and fails on
any difference beyond the stated tolerance.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab.families.lambert_sphere.exact import constants, h_function, spherical_albedo
from fitlab.families.lambert_sphere.exact.constants import CONSTANT_NAMES
from fitlab.families.lambert_sphere.exact.sampling import (MU_MIN, QUADRATURE_NODES, optimal_mixture, relative_variance,
                                                           variance_function)
from fitlab.families.lambert_sphere.table_files import (FAMILY_NAME, KD_COLUMNS, SAMPLING_COLUMNS, SAMPLING_FILES, TABLE_FILES,
                                                      read_checked)
from fitlab.store import Table
from fitlab.store import write_tables as store_write_tables

# the family's `tables` service: the layout (FAMILY_NAME, TABLE_FILES) with the writer and the checker
__all__ = ["FAMILY_NAME", "TABLE_FILES", "build_tables", "write_tables", "check_tables", "h_table", "constants_table",
           "albedo_table", "sampling_table", "SAMPLING_GRIDS", "FAST_TABLES", "C_GRID", "MU_GRID", "S_GRID"]

S_GRID = np.arange(65) / 64.0
C_GRID = 1.0 - S_GRID**2
MU_GRID = np.concatenate(([0.0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3], np.arange(1, 65) / 64.0, [np.inf]))

H_TOLERANCE = 1e-10  # relative, H-functions
CONSTANT_TOLERANCE = 1e-9  # absolute (relative for H0_inf), constants and kd

GRID_TEXT = (
    "c = 1 - s^2, s = k/64 for k = 0..64; "
    "mu = 0, 1e-12, 1e-9, 1e-6, 1e-4, 1e-3, j/64 for j = 1..64, inf"
)


def h_table(order: int, progress=None) -> Table:
    rows = []
    for s, c in zip(S_GRID, C_GRID):
        h = h_function(order, MU_GRID, c)
        rows.extend((s, c, mu, hv) for mu, hv in zip(MU_GRID, h))
        if progress is not None:
            progress.update(1)
    return Table(
        f"H{order}",
        f"Chandrasekhar twin integral equation, Nystrom on a graded Gauss rule (27 panels x 16 nodes), Newton; "
        f"H(inf) = K_{order}(0)^(-1/2)",
        f"relative {H_TOLERANCE:g}, verified against the Fock/Krein integral",
        ("s", "c", "mu", f"H{order}"),
        rows,
        GRID_TEXT,
    )


def constants_table(progress=None) -> Table:
    rows = []
    for s, c in zip(S_GRID, C_GRID):
        k = constants(c)
        rows.append((s, c, *(float(k[name]) for name in CONSTANT_NAMES)))
        if progress is not None:
            progress.update(1)
    return Table(
        "constants",
        "moment relations of H0 and H1 (docs/derivation.md); H0_inf from eq. 32",
        f"absolute {CONSTANT_TOLERANCE:g}, verified against discrete ordinates + doubling",
        ("s", "c", *CONSTANT_NAMES),
        rows,
        GRID_TEXT,
    )


def albedo_table(progress=None) -> Table:
    rows = []
    kd3 = spherical_albedo(C_GRID, phase="three_term")
    kdm = spherical_albedo(C_GRID, phase="mixed")
    for s, c, a, b in zip(S_GRID, C_GRID, kd3, kdm):
        rows.append((s, c, a, b, float(spherical_albedo(c, phase="true"))))  # a solve per c: ticked
        if progress is not None:
            progress.update(1)
    return Table(
        "spherical albedo kd",
        "kd = 2 int a(mu) mu dmu of fitlab.families.lambert_sphere.exact.brdf; kd_three_term: phase 'three_term' "
        "(the exact three-term half space); kd_mixed: phase 'mixed' (true phase function in single scattering, "
        "three-term multiple scattering; also the albedo of the runtime model with exact ingredients); kd_true: "
        "phase 'true' (the whole phase function: the material's albedo)",
        f"absolute {CONSTANT_TOLERANCE:g}",
        KD_COLUMNS,
        rows,
        GRID_TEXT,
    )


def _interleaved(denominator: int) -> np.ndarray:
    return np.concatenate(([0.0], (2 * np.arange(denominator // 2) + 1) / denominator, [1.0]))


#: the sampling tables' grids, (s axis, mu_i axis, text) by file: the validation grid's interior points
#: lie between the training grid's
SAMPLING_GRIDS = {
    SAMPLING_FILES[0]: (np.arange(17) / 16, np.concatenate(([MU_MIN, 0.01], np.arange(1, 33) / 32)),
                        "c = 1 - s^2, s = k/16 for k = 0..16; mu_i = 1e-3, 0.01, j/32 for j = 1..32"),
    SAMPLING_FILES[1]: (_interleaved(32), np.concatenate(([MU_MIN, 0.003], _interleaved(64)[1:])),
                        "c = 1 - s^2, s = 0, (2k+1)/32 for k = 0..15, 1; mu_i = 1e-3, 0.003, (2j+1)/64 for j = 0..31, 1"),
}
SAMPLING_TOLERANCE = 5e-3  # relative, of the optimal variance: the finer rule and the independent optimiser (2e-3 at mu_i = 1e-3)


def sampling_table(name: str, progress=None) -> Table:
    """The variance-optimal sampling mixture (:func:`fitlab.families.lambert_sphere.exact.sampling.optimal_mixture`)
    on the grid :data:`SAMPLING_GRIDS` [name]."""
    s_axis, mu_axis, grid = SAMPLING_GRIDS[name]
    rows = []
    for s in s_axis:
        c = 1.0 - s * s
        r = optimal_mixture(mu_axis, c)
        rows.extend(zip([s] * len(mu_axis), [c] * len(mu_axis), mu_axis, *(r[k] for k in SAMPLING_COLUMNS[3:])))
        if progress is not None:
            progress.update(1)
    return Table(
        "variance-optimal sampling mixture" + (" (validation grid)" if name != SAMPLING_FILES[0] else ""),
        "(w, n) minimising the relative variance V of the one-sample albedo estimator with the density "
        "(1 - w) mu_o/pi + w (n + 1)/(2 pi) max(0, wi.wo)^n (fitlab.families.lambert_sphere.exact.sampling; "
        f"V by Gauss-Legendre, {QUADRATURE_NODES[0]} nodes in phi and {QUADRATURE_NODES[1]} per graded panel in mu_o); "
        "relvar_cosine is V at w = 0",
        f"relative {SAMPLING_TOLERANCE:g} of relvar_optimal, verified by an independent optimiser",
        SAMPLING_COLUMNS,
        rows,
        grid,
    )


#: the fast tables and the slow ones (sampling: a variance optimisation per point, minutes)
FAST_TABLES = ("h0.csv", "h1.csv", "h2.csv", "constants.csv", "kd.csv")


def build_tables(show_progress: bool = True, names=tuple(TABLE_FILES)) -> dict[str, Table]:
    """Every table of ``names`` (default: all of :data:`TABLE_FILES`)."""
    unknown = set(names) - set(TABLE_FILES)
    if unknown:
        raise ValueError(f"unknown tables {sorted(unknown)}; the tables are {', '.join(TABLE_FILES)}")
    total = sum(len(C_GRID) if n in FAST_TABLES else len(SAMPLING_GRIDS[n][0]) for n in names)
    tables = {}
    with tqdm(total=total, desc="tabulating", unit="c", disable=not show_progress) as bar:
        for name in names:
            if name.startswith("h"):
                tables[name] = h_table(int(name[1]), bar)
            elif name == "constants.csv":
                tables[name] = constants_table(bar)
            elif name == "kd.csv":
                tables[name] = albedo_table(bar)
            else:
                tables[name] = sampling_table(name, bar)
    return tables


def write_tables(out: Path, show_progress: bool = True, names=tuple(TABLE_FILES)) -> dict[str, str]:
    """Compute the tables ``names`` (default: every one), then write them all as one unit (nothing is
    written on failure)."""
    return store_write_tables(Path(out), build_tables(show_progress, names))


def check_tables(out: Path, every: int = 8, show_progress: bool = True) -> list[str]:
    """Recompute a sample of rows by independent methods; return the failures."""
    out = Path(out)
    failures = []
    c_sample = C_GRID[::every]
    if C_GRID[-1] not in c_sample:
        c_sample = np.append(c_sample, C_GRID[-1])
    with tqdm(total=3 + 2 + len(SAMPLING_FILES), desc="checking", disable=not show_progress) as bar:
        for m in range(3):
            _, data = read_checked(f"h{m}.csv", out)  # every check, the grid's rows included
            sel = np.isin(data[:, 1], c_sample)
            c, mu, h = data[sel, 1], data[sel, 2], data[sel, 3]
            ref = h_function(m, mu, c, method="fock")
            with np.errstate(invalid="ignore"):
                rel = np.where(np.isinf(ref) & np.isinf(h), 0.0, np.abs(h / ref - 1.0))
            if not np.all(rel <= H_TOLERANCE):
                i = int(np.nanargmax(np.where(np.isnan(rel), np.inf, rel)))
                failures.append(f"h{m}.csv: c={c[i]!r} mu={mu[i]!r}: {h[i]!r} vs Fock {ref[i]!r} (rel {rel[i]:.2e})")
            bar.update(1)
        header, data = read_checked("constants.csv", out)
        sel = np.isin(data[:, 1], c_sample)
        ref = constants(data[sel, 1])
        for j, name in enumerate(header[2:], start=2):
            got = data[sel, j]
            want = ref[name]
            scale = np.maximum(1.0, np.abs(want)) if name == "H0_inf" else 1.0
            with np.errstate(invalid="ignore"):
                err = np.where(np.isinf(want) & np.isinf(got), 0.0, np.abs(got - want) / scale)
            if not np.all(err <= CONSTANT_TOLERANCE):
                failures.append(f"constants.csv: {name} differs by {np.nanmax(err):.2e}")
        bar.update(1)
        _, data = read_checked("kd.csv", out)
        sel = np.isin(data[:, 1], c_sample)
        for j, phase in enumerate(("three_term", "mixed", "true"), start=2):
            err = np.abs(data[sel, j] - spherical_albedo(data[sel, 1], phase=phase))
            if not np.all(err <= CONSTANT_TOLERANCE):
                failures.append(f"kd.csv: kd_{phase} differs by {err.max():.2e}")
        bar.update(1)
        for name in SAMPLING_FILES:
            failures += _check_sampling(out / name, name)
            bar.update(1)
    return failures


def _check_sampling(path: Path, name: str) -> list[str]:
    """A sample of rows of a sampling table (the largest c, and one near 0.75; three incidences each, the
    smallest among them): V at the tabulated (w, n) by a finer quadrature (64 nodes in phi, 12 per panel in
    mu_o) matches relvar_optimal, V at w = 0 matches relvar_cosine, and Nelder-Mead in (logit w, log n)
    started away from the table finds nothing lower."""
    from scipy.optimize import minimize

    _, data = read_checked(name, path.parent)
    s_axis, mu_axis, _ = SAMPLING_GRIDS[name]
    t = dict(zip(SAMPLING_COLUMNS, data.T))
    failures = []
    for c in (t["c"].max(), t["c"][np.argmin(np.abs(t["c"] - 0.75))]):
        rows = np.flatnonzero(t["c"] == c)[[0, len(mu_axis) // 2, -2]]  # mu_i = MU_MIN, about 0.5, below 1
        mu, w, n = t["mu_i"][rows], t["weight"][rows], t["exponent"][rows]
        fine = relative_variance(mu, c, w, n, nodes=(64, 12))
        cosine = relative_variance(mu, c, 0.0, 1.0, nodes=(64, 12))
        for k, r in enumerate(rows):
            for label, got, want in (("relvar_optimal", t["relvar_optimal"][r], fine[k]),
                                     ("relvar_cosine", t["relvar_cosine"][r], cosine[k])):
                if not abs(got - want) <= SAMPLING_TOLERANCE * abs(want) + 1e-9:
                    failures.append(f"{name}: c={float(c)!r} mu_i={float(mu[k])!r}: {label} {float(got)!r} vs {float(want)!r} by the finer rule")

            v = variance_function(mu[k], c)
            best = minimize(lambda q: v(1.0 / (1.0 + np.exp(-q[0])), np.exp(q[1])), [0.0, np.log(2.0)], method="Nelder-Mead", options={"xatol": 1e-6, "fatol": 1e-10})
            if best.fun < t["relvar_optimal"][r] - SAMPLING_TOLERANCE * abs(t["relvar_optimal"][r]) - 1e-9:
                failures.append(f"{name}: c={float(c)!r} mu_i={float(mu[k])!r}: Nelder-Mead finds V = {float(best.fun)!r} "
                                f"below the tabulated optimum {float(t['relvar_optimal'][r])!r}")
    return failures
