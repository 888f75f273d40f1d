"""The exact tables (fitlab/data/lambert_sphere/, or DATA/lambert_sphere/ from ``fitlab tabulate``): H0, H1, H2 on a (mu, c) grid, the constants and kd.

true_orders.csv holds the true multiple scattering (the whole phase function) beside the three-term one,
Fourier orders 0 to 2, on its own grid: s = k/8, mu_i <= mu_o in 1e-9 and (j/32)^2 (what the exported tables
correct the three-term orders with; :mod:`..program.table_export`).

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

from fitlab.cache import cached_at
from fitlab.families.lambert_sphere.exact import (
    SOURCES,
    constants,
    h_function,
    multiple_scattering_modes,
    spherical_albedo,
)
from fitlab.families.lambert_sphere.exact.constants import CONSTANT_NAMES
from fitlab.families.lambert_sphere.exact.sampling import (
    QUADRATURE_NODES,
    optimal_mixture,
    relative_variance,
    variance_function,
)
from fitlab.families.lambert_sphere.exact.true_phase import multiple_scattering_orders
from fitlab.families.lambert_sphere.targets.table_files import (
    C_GRID,
    FAMILY_NAME,
    GRID_TEXT,
    KD_COLUMNS,
    MU_GRID,
    S_GRID,
    SAMPLING_COLUMNS,
    SAMPLING_FILES,
    SAMPLING_GRIDS,
    TABLE_FILES,
    TRUE_COLUMNS,
    TRUE_FILE,
    TRUE_GRID_TEXT,
    TRUE_ORDERS,
    TRUE_S_GRID,
    read_checked,
    true_grid,
)
from fitlab.store import Table
from fitlab.store import write_tables as store_write_tables

# the family's `tables` service: the layout (FAMILY_NAME, TABLE_FILES) with the writer and the checker
__all__ = [
    "FAMILY_NAME",
    "TABLE_FILES",
    "build_tables",
    "write_tables",
    "check_tables",
    "h_table",
    "constants_table",
    "albedo_table",
    "sampling_table",
    "true_orders_table",
    "check_true_orders",
    "FAST_TABLES",
    "TRUE_TOLERANCE",
]

H_TOLERANCE = 1e-10  # relative, H-functions
CONSTANT_TOLERANCE = 1e-9  # absolute (relative for H0_inf), constants and kd
TRUE_TOLERANCE = 1e-9  # relative to the largest |value| of the order at that c: the 'doubling' method agrees


def _true_rows(c: float, mu_i, mu_o, method: str = "newton") -> list[np.ndarray]:
    true = multiple_scattering_orders(mu_i, mu_o, c, method=method, orders=TRUE_ORDERS)
    three = multiple_scattering_modes(mu_i, mu_o, c, phase="three_term")[:TRUE_ORDERS]
    return [*true, *three]


def true_orders_table(progress=None) -> Table:
    """The true multiple scattering (:func:`..exact.true_phase.multiple_scattering_orders`, the whole phase
    function) and the three-term one (:func:`..exact.multiple_scattering_modes`), orders 0 to 2, on
    :func:`true_grid`; both are 0 at c = 0."""
    s_all, mi_all, mo_all = true_grid()
    rows = []
    for s in TRUE_S_GRID:
        sel = s_all == s
        c = 1.0 - s * s
        values = _true_rows(c, mi_all[sel], mo_all[sel])
        rows.extend(zip(s_all[sel], 1.0 - s_all[sel] * s_all[sel], mi_all[sel], mo_all[sel], *values))
        if progress is not None:
            progress.update(1)
    return Table(
        "true and three-term multiple scattering by Fourier order",
        "fm_m_true: the half space with the whole phase function (fitlab.families.lambert_sphere.exact.true_phase, "
        "discrete ordinates, Newton on the Riccati equation); fm_m_three_term: the three-term half space "
        "(fitlab.families.lambert_sphere.exact.multiple_scattering_modes, H-functions); fitlab's azimuth, 1/sr",
        f"relative {TRUE_TOLERANCE:g} of each order's largest value at its c, verified by doubling",
        TRUE_COLUMNS,
        rows,
        TRUE_GRID_TEXT,
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


SAMPLING_TOLERANCE = (
    5e-3  # relative, of the optimal variance: the finer rule and the independent optimiser (2e-3 at mu_i = 1e-3)
)


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
    ticks = {
        **{n: len(C_GRID) for n in FAST_TABLES},
        TRUE_FILE: len(TRUE_S_GRID),
        **{n: len(SAMPLING_GRIDS[n][0]) for n in SAMPLING_FILES},
    }
    total = sum(ticks[n] for n in names)
    tables = {}
    with tqdm(total=total, desc="tabulating", unit="c", disable=not show_progress) as bar:
        for name in names:
            if name.startswith("h"):
                tables[name] = h_table(int(name[1]), bar)
            elif name == "constants.csv":
                tables[name] = constants_table(bar)
            elif name == "kd.csv":
                tables[name] = albedo_table(bar)
            elif name == TRUE_FILE:
                tables[name] = true_orders_table(bar)
            else:
                tables[name] = sampling_table(name, bar)
    return tables


def write_tables(out: Path, show_progress: bool = True, names=tuple(TABLE_FILES)) -> dict[str, str]:
    """Compute the tables ``names`` (default: every one), then write them all as one unit (nothing is
    written on failure)."""
    return store_write_tables(Path(out), build_tables(show_progress, names))


def _reference(name: str, compute, names: tuple[str, ...], **inputs) -> dict[str, np.ndarray]:
    """The check's reference values ``compute()`` (arrays ``names``) at the rows it samples, through fitlab's
    persistent cache keyed by ``name``, those rows' inputs (``inputs``, as the table states them) and the exact
    engine's sources, as the exact values of the training sets are: a second check of tables on the same grid
    (a user's copy, the packaged ones) reads them instead of solving again, and any edit of the engine
    recomputes them.  The entry holds the inputs too (``in_NAME``): it says what it is the reference of."""
    key = {"family": "lambert_sphere", "check": name}
    return cached_at(f"lambert_sphere-check-{name}", key, inputs, compute, names, sources=SOURCES)


def check_tables(out: Path, every: int = 8, show_progress: bool = True) -> list[str]:
    """Recompute a sample of rows by independent methods; return the failures."""
    out = Path(out)
    failures = []
    c_sample = C_GRID[::every]
    if C_GRID[-1] not in c_sample:
        c_sample = np.append(c_sample, C_GRID[-1])
    with tqdm(total=3 + 3 + len(SAMPLING_FILES), desc="checking", disable=not show_progress) as bar:
        for m in range(3):
            _, data = read_checked(f"h{m}.csv", out)  # every check, the grid's rows included
            sel = np.isin(data[:, 1], c_sample)
            c, mu, h = data[sel, 1], data[sel, 2], data[sel, 3]
            ref = _reference(
                f"h{m}", lambda m=m, mu=mu, c=c: {"h": h_function(m, mu, c, method="fock")}, ("h",), c=c, mu=mu
            )["h"]
            with np.errstate(invalid="ignore"):
                rel = np.where(np.isinf(ref) & np.isinf(h), 0.0, np.abs(h / ref - 1.0))
            if not np.all(rel <= H_TOLERANCE):
                i = int(np.nanargmax(np.where(np.isnan(rel), np.inf, rel)))
                failures.append(f"h{m}.csv: c={c[i]!r} mu={mu[i]!r}: {h[i]!r} vs Fock {ref[i]!r} (rel {rel[i]:.2e})")
            bar.update(1)
        header, data = read_checked("constants.csv", out)
        sel = np.isin(data[:, 1], c_sample)
        c = data[sel, 1]
        ref = _reference("constants", lambda: constants(c), CONSTANT_NAMES, c=c)
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
        c, phases = data[sel, 1], ("three_term", "mixed", "true")
        kd = _reference("kd", lambda: {p: spherical_albedo(c, phase=p) for p in phases}, phases, c=c)
        for j, phase in enumerate(phases, start=2):
            err = np.abs(data[sel, j] - kd[phase])
            if not np.all(err <= CONSTANT_TOLERANCE):
                failures.append(f"kd.csv: kd_{phase} differs by {err.max():.2e}")
        bar.update(1)
        failures += check_true_orders(out)
        bar.update(1)
        for name in SAMPLING_FILES:
            failures += _check_sampling(out / name, name)
            bar.update(1)
    return failures


def check_true_orders(out: Path) -> list[str]:
    """Every tenth row at c = 1 and at s = 5/8: the true orders at c = 1 recomputed by the other method
    (doubling, 20 s), and the three-term orders at both against the true-phase engine given the three-term phase
    function (discrete ordinates, not H-functions)."""
    header, data = read_checked(TRUE_FILE, out)
    t = dict(zip(header, data.T))
    failures = []
    true, three_term = TRUE_COLUMNS[4 : 4 + TRUE_ORDERS], TRUE_COLUMNS[4 + TRUE_ORDERS :]
    for s in (0.0, 0.625):
        rows = np.flatnonzero(t["s"] == s)[::10]
        c, mi, mo = 1.0 - s * s, t["mu_i"][rows], t["mu_o"][rows]
        columns = three_term + (true if s == 0.0 else ())

        def compute(c=c, mi=mi, mo=mo, s=s):
            out = dict(zip(three_term, multiple_scattering_orders(mi, mo, c, phase="three_term", orders=TRUE_ORDERS)))
            if s == 0.0:
                out.update(zip(true, multiple_scattering_orders(mi, mo, c, method="doubling", orders=TRUE_ORDERS)))
            return out

        checks = _reference("true-orders", compute, columns, c=np.array([c]), mu_i=mi, mu_o=mo)
        for name in columns:
            want = checks[name]
            got = t[name][rows]
            scale = np.abs(t[name][t["s"] == s]).max()
            err = np.abs(got - want).max() / scale
            if not err <= TRUE_TOLERANCE:
                failures.append(f"{TRUE_FILE}: {name} at c={c!r} differs by {err:.2e} of its largest value")
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

        def compute(mu=mu, c=c, w=w, n=n):
            best = []
            for m in mu:
                v = variance_function(m, c)
                best.append(
                    minimize(
                        lambda q, v=v: v(1.0 / (1.0 + np.exp(-q[0])), np.exp(q[1])),
                        [0.0, np.log(2.0)],
                        method="Nelder-Mead",
                        options={"xatol": 1e-6, "fatol": 1e-10},
                    ).fun
                )
            return {
                "fine": relative_variance(mu, c, w, n, nodes=(64, 12)),
                "cosine": relative_variance(mu, c, 0.0, 1.0, nodes=(64, 12)),
                "best": np.array(best),
            }

        ref = _reference(
            f"sampling-{Path(name).stem}",
            compute,
            ("fine", "cosine", "best"),
            c=np.array([c]),
            mu_i=mu,
            weight=w,
            exponent=n,
        )
        fine, cosine = ref["fine"], ref["cosine"]
        for k, r in enumerate(rows):
            for label, got, want in (
                ("relvar_optimal", t["relvar_optimal"][r], fine[k]),
                ("relvar_cosine", t["relvar_cosine"][r], cosine[k]),
            ):
                if not abs(got - want) <= SAMPLING_TOLERANCE * abs(want) + 1e-9:
                    failures.append(
                        f"{name}: c={float(c)!r} mu_i={float(mu[k])!r}: {label} {float(got)!r} vs {float(want)!r} by the finer rule"
                    )

            best = ref["best"][k]
            if best < t["relvar_optimal"][r] - SAMPLING_TOLERANCE * abs(t["relvar_optimal"][r]) - 1e-9:
                failures.append(
                    f"{name}: c={float(c)!r} mu_i={float(mu[k])!r}: Nelder-Mead finds V = {float(best)!r} "
                    f"below the tabulated optimum {float(t['relvar_optimal'][r])!r}"
                )
    return failures
