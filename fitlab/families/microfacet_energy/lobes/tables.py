r"""The simulated multiple-scattering lobes by order: the random walk of :mod:`..mc` on a grid of
(alpha, mu_i), tabulated (through :mod:`fitlab.store`) and read back.

What is tabulated.  For each facet kind (``diffuse``: Lambertian facets of albedo 1, the blog's case;
``conductor``: mirror facets with F = 1, Kulla-Conti's case), on GGX microsurfaces (height-correlated
Smith, isotropic alpha), for each job (alpha, mu_i) and each order S = 1, 2, 3, 4 and the tail S > 4:

* the bin averages of f_S mu_o (1/sr) over (mu_o, |phi_o|) bins: :data:`MU_EDGES` (10 bins uniform in
  mu_o, i.e. of equal solid angle) times :data:`PHI_EDGES` (8 bins of 22.5 degrees; phi_o = 0 is the
  back-scattering side, the plane of w_i; phi_o = pi holds the mirror direction), with their standard
  errors (:mod:`..mc.simulate` gives the estimator: mean S1/N over N paths, se from S2);
* the albedo of the order (every upward escape of that order, equal to the sum of the bins times their
  solid angles up to rounding), with its standard error, and the paths of the job.

Why albedo 1 is enough for diffuse facets: with every facet of albedo rho, a path that leaves after S
events carries the weight rho^S and nothing else about the walk depends on rho (the walk draws directions
without looking at the weight, and there is no Russian roulette), so order S scales as rho^S exactly.
:func:`albedo_identity` checks it by simulation (an independent seed) rather than assuming it.

Details: docs/blog_lobe_model.md, section ``fitlab.families.microfacet_energy.lobes.tables``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab.store import Table, TableError, read_table

__all__ = [
    "KINDS",
    "ORDER_LABELS",
    "MU_EDGES",
    "PHI_EDGES",
    "SEED",
    "PATHS",
    "MAX_BOUNCES",
    "ALPHA_TRAINING",
    "MU_I_TRAINING",
    "ALPHA_VALIDATION",
    "MU_I_VALIDATION",
    "SETS",
    "LobeTable",
    "lobe_file",
    "LOBE_FILES",
    "lobe_columns",
    "grid_points",
    "simulate_job",
    "lobe_table",
    "build_lobe_tables",
    "read_lobes",
    "lobes_from_rows",
    "solid_angles",
    "albedo_identity",
    "check_lobe_tables",
    "DOMAIN",
    "walk_config",
]

#: facet kinds (the walk's kinds; "diffuse" with albedo 1, "conductor" with F = 1)
KINDS = ("diffuse", "conductor")
#: the orders tabulated, by row: 1, 2, 3, 4 and every order above 4
ORDER_LABELS = ("1", "2", "3", "4", ">4")
MU_EDGES = tuple(np.linspace(0.0, 1.0, 11).tolist())
PHI_EDGES = tuple((np.pi * np.arange(9) / 8).tolist())
SEED = 20
PATHS = 1_000_000
#: alpha below which a job runs twice PATHS
SMALL_ALPHA = 0.2
MAX_BOUNCES = 1000
_SLOTS = 4096
_DIGITS, _SE_DIGITS = 4, 2

#: the domain the lobes (and every fit of them) are tabulated and claimed on
DOMAIN = {"alpha": (0.05, 1.0), "mu_i": (0.05, 1.0)}
ALPHA_TRAINING = (0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0)
MU_I_TRAINING = (0.05, 0.2, 0.4, 0.6, 0.8, 1.0)
ALPHA_VALIDATION = (0.075, 0.15, 0.275, 0.425, 0.6, 0.85)
MU_I_VALIDATION = (0.1, 0.3, 0.5, 0.7, 0.9)
_EDGE_MU_I = (0.1, 0.5, 0.9)
_EDGE_ALPHA = (0.15, 0.425, 0.85)
SETS = ("training", "validation")
_INCIDENT_BASE = {"training": 0, "validation": 1000}


def lobe_file(kind: str, which: str) -> str:
    return f"lobes_{kind}_{which}.csv"


def _bin_names(prefix: str) -> tuple[str, ...]:
    return tuple(f"{prefix}_{i}_{j}" for i in range(len(MU_EDGES) - 1) for j in range(len(PHI_EDGES) - 1))


def lobe_columns() -> tuple[str, ...]:
    """alpha, mu_i, order (1..4; 5 = above 4), paths, albedo, albedo_se, then the bins f_I_J (mu_o bin I,
    |phi_o| bin J) and their standard errors se_I_J."""
    return ("alpha", "mu_i", "order", "paths", "albedo", "albedo_se", *_bin_names("f"), *_bin_names("se"))


#: every lobe table and its columns
LOBE_FILES = {lobe_file(k, w): lobe_columns() for k in KINDS for w in SETS}


def grid_points(which: str) -> list[tuple[float, float]]:
    """The (alpha, mu_i) jobs of a set, in table order (docs/blog_lobe_model.md)."""
    if which == "training":
        return [(a, m) for a in ALPHA_TRAINING for m in MU_I_TRAINING]
    if which != "validation":
        raise ValueError(f"which must be 'training' or 'validation', got {which!r}")
    pts = [(a, m) for a in ALPHA_VALIDATION for m in MU_I_VALIDATION]
    pts += [(a, m) for a in (DOMAIN["alpha"][0], DOMAIN["alpha"][1]) for m in _EDGE_MU_I]
    pts += [(a, m) for m in (DOMAIN["mu_i"][0], DOMAIN["mu_i"][1]) for a in _EDGE_ALPHA]
    return pts


def _grid_text(which: str) -> str:
    bins = (
        "bins: mu_o edges k/10, k = 0..10 (uniform), |phi_o| edges k pi/8, k = 0..8 (phi_o = 0 back-scattering "
        "side, pi the mirror side); rows: one per job and order, jobs in the order of the grid"
    )
    if which == "training":
        return f"alpha in {ALPHA_TRAINING} x mu_i in {MU_I_TRAINING} (alpha outer); " + bins
    return (
        f"alpha in {ALPHA_VALIDATION} x mu_i in {MU_I_VALIDATION}, then alpha in {{0.05, 1}} x mu_i in "
        f"{_EDGE_MU_I}, then mu_i in {{0.05, 1}} x alpha in {_EDGE_ALPHA} (interleaved with the training grid); " + bins
    )


def walk_config(kind: str):
    """The walk's compiled configuration for a kind (GGX, F = 1 for conductors, orders 1..4 and above)."""
    from fitlab.families.microfacet_energy.mc import WalkConfig

    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    # float64: the committed tables are rewritten byte for byte (docs/blog_lobe_model.md); a float32 walk takes the same
    # paths to 1e-7 (docs/microsurface.md, "Precision"), not to the tables' last digit
    return WalkConfig(
        distribution="ggx",
        kind=kind,
        fresnel="one",
        orders=len(ORDER_LABELS) - 1,
        mu_edges=MU_EDGES,
        phi_edges=PHI_EDGES,
        slots=_SLOTS,
        precision="float64",
    )


def job_paths(alpha: float) -> int:
    return 2 * PATHS if alpha < SMALL_ALPHA else PATHS


def solid_angles() -> np.ndarray:
    """Omega of each (mu_o, |phi_o|) bin, both signs of phi: 2 dmu dphi, shape (10, 8)."""
    return 2.0 * np.outer(np.diff(MU_EDGES), np.diff(PHI_EDGES))


def simulate_job(
    kind: str,
    alpha: float,
    mu_i: float,
    paths: int,
    seed: int = SEED,
    incident: int = 0,
    albedo: float = 1.0,
    batch: int = 500_000,
) -> dict:
    """One job: {"value", "se"} (5, 10, 8) bin averages of f_S mu_o and their standard errors, {"albedo",
    "albedo_se"} (5,), "paths", "capped" (the weight of paths still inside after MAX_BOUNCES events, counted
    in the tail's albedo and in no bin)."""
    from fitlab.families.microfacet_energy.mc import MaterialParams, job_key, run_round

    cfg = walk_config(kind)
    params = MaterialParams(alpha_x=alpha, alpha_y=alpha, albedo=albedo)
    key = job_key(seed, KINDS.index(kind), incident)
    acc = None
    done = 0
    while done < paths:
        n = min(batch, paths - done)
        res = run_round(cfg, key, params, mu_i, done, n, MAX_BOUNCES)
        acc = res if acc is None else {k: acc[k] + v for k, v in res.items()}
        done += n
    n = float(acc["paths"])

    def mean_se(s1, s2):
        mean = np.asarray(s1, float) / n
        return mean, np.sqrt(np.maximum(np.asarray(s2, float) / n - mean * mean, 0.0) / (n - 1))

    omega = solid_angles()
    value, se = mean_se(acc["lobe"], acc["lobe_sq"])
    alb, alb_se = mean_se(acc["albedo"], acc["albedo_sq"])
    cap, cap_se = mean_se(acc["capped"], acc["capped_sq"])
    alb = alb.copy()
    alb[-1] += cap
    alb_se = alb_se.copy()
    alb_se[-1] = np.hypot(alb_se[-1], cap_se)
    return {
        "value": value / omega,
        "se": se / omega,
        "albedo": alb,
        "albedo_se": alb_se,
        "paths": int(n),
        "capped": float(cap),
    }


def _round(x, digits: int) -> np.ndarray:
    """``x`` rounded to ``digits`` significant digits (written short by the store's repr)."""
    x = np.asarray(x, dtype=float)
    return np.array([float(f"{v:.{digits}g}") for v in x.ravel()]).reshape(x.shape)


def lobe_table(kind: str, which: str, progress=None) -> Table:
    """Simulate every job of a set and return its :class:`fitlab.store.Table`."""
    rows = []
    capped = 0.0
    total = 0
    base = _INCIDENT_BASE[which]
    for j, (alpha, mu_i) in enumerate(grid_points(which)):
        job = simulate_job(kind, alpha, mu_i, job_paths(alpha), incident=base + j)
        capped = max(capped, job["capped"])
        total += job["paths"]
        for k in range(len(ORDER_LABELS)):
            rows.append(
                [
                    alpha,
                    mu_i,
                    k + 1,
                    job["paths"],
                    *_round(job["albedo"][k], _DIGITS).ravel(),
                    *_round(job["albedo_se"][k], _SE_DIGITS).ravel(),
                    *_round(job["value"][k], _DIGITS).ravel(),
                    *_round(job["se"][k], _SE_DIGITS).ravel(),
                ]
            )
        if progress is not None:
            progress.update(1)
    what = "Lambertian facets of albedo 1" if kind == "diffuse" else "mirror facets, F = 1"
    return Table(
        lobe_file(kind, which).removesuffix(".csv"),
        f"microsurface random walk (Heitz et al. 2016; fitlab.families.microfacet_energy.mc.walk), GGX, "
        f"height-correlated Smith, {what}; seed {SEED}, material {KINDS.index(kind)}, incident = job index + {base}; "
        f"{PATHS} paths per job ({2 * PATHS} for alpha < {SMALL_ALPHA}), {total} in all; at most {MAX_BOUNCES} "
        f"events per path (largest weight still inside: {capped:.3g} per path, counted in the order-5 albedo); "
        "values: bin averages of f_S mu_o (1/sr) and albedo by order S (order 5: every order above 4)",
        f"Monte Carlo: each value with its standard error (se columns); values rounded to {_DIGITS} significant "
        f"digits, standard errors to {_SE_DIGITS}",
        lobe_columns(),
        rows,
        _grid_text(which),
    )


def build_lobe_tables(show_progress: bool = True, kinds=KINDS, sets=SETS) -> dict[str, Table]:
    """Every lobe table ({file name: Table}): about 3 minutes on 2 cores (6.5 when other work shares them)."""
    jobs = sum(len(grid_points(w)) for w in sets) * len(kinds)
    out = {}
    with tqdm(total=jobs, desc="simulating lobes", unit="job", disable=not show_progress) as bar:
        for kind in kinds:
            for which in sets:
                out[lobe_file(kind, which)] = lobe_table(kind, which, bar)
    return out


@dataclass(frozen=True)
class LobeTable:
    """The lobes of one kind and set, as arrays.

    alpha, mu_i, paths: (J,) per job; value, se: (J, 5, 10, 8) bin averages of f_S mu_o (1/sr) by order
    (index 0..3: orders 1..4; 4: above 4), mu_o bin and |phi_o| bin; albedo, albedo_se: (J, 5)."""

    kind: str
    which: str
    alpha: np.ndarray
    mu_i: np.ndarray
    paths: np.ndarray
    value: np.ndarray
    se: np.ndarray
    albedo: np.ndarray
    albedo_se: np.ndarray

    def __len__(self) -> int:
        return self.alpha.size

    def multiple(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(value, se, albedo, albedo_se) of the multiple-scattering lobe, orders >= 2 summed (the orders are
        tallied from the same paths, each path in one order, so their covariance is minus the product of
        their means and the summed se is computed from the variances accordingly: var(sum) = sum var + 2 sum
        cov, cov_{ST} = -m_S m_T / (N - 1))."""
        n = self.paths[:, None, None]
        v, s = self.value[:, 1:], self.se[:, 1:]
        total = v.sum(axis=1)
        omega = solid_angles()
        # per-path moments in the tally's own units (the weight, not divided by Omega), then back
        m = v * omega
        var = (s * omega) ** 2
        cross = (m.sum(axis=1) ** 2 - (m**2).sum(axis=1)) / (n - 1)
        se = np.sqrt(np.maximum(var.sum(axis=1) - cross, 0.0)) / omega
        a = self.albedo[:, 1:]
        a_cross = (a.sum(axis=1) ** 2 - (a**2).sum(axis=1)) / (self.paths - 1)
        a_se = np.sqrt(np.maximum((self.albedo_se[:, 1:] ** 2).sum(axis=1) - a_cross, 0.0))
        return total, se, a.sum(axis=1), a_se


def read_lobes(folder: Path, kind: str, which: str) -> LobeTable:
    """The lobe table of ``kind`` and ``which`` in ``folder``, its header and grid checked
    (:class:`fitlab.store.TableError`)."""
    path = Path(folder) / lobe_file(kind, which)
    _, data = read_table(path, lobe_columns(), grid=_grid_text(which))  # the "# grid:" line, then the rows
    return lobes_from_rows(data, kind, which, str(path))


def lobes_from_rows(data, kind: str, which: str, where: str = "table") -> LobeTable:
    """The :class:`LobeTable` of a table's rows (an array, or the rows of :func:`lobe_table`), the grid checked."""
    data = np.asarray(data, dtype=float)
    pts = np.array(grid_points(which))
    n_orders = len(ORDER_LABELS)
    if data.shape[0] != n_orders * len(pts):
        raise TableError(f"{where}: {data.shape[0]} rows, expected {n_orders * len(pts)}; run `fitlab tabulate`")
    d = data.reshape(len(pts), n_orders, -1)
    if not (
        np.array_equal(d[:, 0, 0], pts[:, 0])
        and np.array_equal(d[:, 0, 1], pts[:, 1])
        and np.array_equal(d[0, :, 2], np.arange(1, n_orders + 1))
    ):
        raise TableError(f"{where}: the (alpha, mu_i, order) columns are not the grid {_grid_text(which)}")
    nb = (len(MU_EDGES) - 1) * (len(PHI_EDGES) - 1)
    shape = (len(pts), n_orders, len(MU_EDGES) - 1, len(PHI_EDGES) - 1)
    return LobeTable(
        kind,
        which,
        d[:, 0, 0].copy(),
        d[:, 0, 1].copy(),
        d[:, 0, 3].astype(np.int64),
        d[:, :, 6 : 6 + nb].reshape(shape),
        d[:, :, 6 + nb :].reshape(shape),
        d[:, :, 4].copy(),
        d[:, :, 5].copy(),
    )


def albedo_identity(
    rho: float = 0.6, alpha: float = 0.5, mu_i: float = 0.5, paths: int = 200_000, seed: int = SEED + 1
) -> dict:
    """The rho^S scaling of diffuse facets, by simulation: the walk at facet albedo ``rho`` and at albedo 1,
    with different seeds (independent estimates), at one (alpha, mu_i).  Returns {"ratio": albedo_rho /
    (rho^S albedo_1) by order, "z": (albedo_rho - rho^S albedo_1) / se by order} (orders 1..4; the tail
    above 4 mixes orders and scales at most like rho^5)."""
    a = simulate_job("diffuse", alpha, mu_i, paths, seed=seed, albedo=rho)
    b = simulate_job("diffuse", alpha, mu_i, paths, seed=seed + 1, albedo=1.0)
    s = np.arange(1, len(ORDER_LABELS))
    want = rho**s * b["albedo"][:-1]
    se = np.hypot(a["albedo_se"][:-1], rho**s * b["albedo_se"][:-1])
    return {"ratio": a["albedo"][:-1] / want, "z": (a["albedo"][:-1] - want) / se}


def check_lobe_tables(folder: Path, paths: int = 30_000, kinds=KINDS) -> list[str]:
    """Read every lobe table in ``folder`` and re-simulate one job of each (the middle of the training
    grid) with an independent seed and ``paths`` paths; one line per failure: a missing or malformed
    file, or an order's albedo off by more than 5 combined standard errors, or its lobe's chi-square per bin
    above 2 (on the bins the re-simulation reached at least about 16 times, where a standard error means
    something)."""
    failures = []
    for kind in kinds:
        for which in SETS:
            try:
                t = read_lobes(folder, kind, which)
            except TableError as exc:
                failures.append(str(exc))
                continue
            if which != "training":
                continue
            j = len(t) // 2
            job = simulate_job(kind, float(t.alpha[j]), float(t.mu_i[j]), paths, seed=SEED + 7, incident=j)
            z = (job["albedo"] - t.albedo[j]) / np.hypot(job["albedo_se"], t.albedo_se[j])
            if np.any(np.abs(z[np.isfinite(z)]) > 5):
                failures.append(
                    f"{lobe_file(kind, which)}: albedo by order at alpha={t.alpha[j]}, mu_i={t.mu_i[j]} "
                    f"differs from a re-simulation by z = {np.round(z, 2).tolist()}"
                )
            se = np.hypot(job["se"], t.se[j])
            # bins the re-simulation reached often enough for a standard error to mean something (16 paths)
            reached = (job["se"] > 0) & (job["se"] < 0.25 * job["value"])
            chi2 = np.mean(((job["value"] - t.value[j])[reached] / se[reached]) ** 2)
            if chi2 > 2:
                failures.append(
                    f"{lobe_file(kind, which)}: the lobe at alpha={t.alpha[j]}, mu_i={t.mu_i[j]} differs "
                    f"from a re-simulation: chi-square per bin {chi2:.2f}"
                )
    return failures
