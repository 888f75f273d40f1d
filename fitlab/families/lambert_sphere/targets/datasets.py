r"""Training and validation sets drawn from the exact tables and engine.

Training sets come from the family's exact tables (:mod:`.table_files`: the
packaged ones, or those ``fitlab tabulate`` wrote to the user's data folder; their grid is s = k/64,
mu = k/64 plus the tiny-mu points) or, for BRDF-level targets, from the exact
engine on a sub-grid of the same lattice.  Validation sets are denser and
interleaved: their interior points sit between training points (odd multiples
of a finer step), so no interior point was seen by the fit.  The domain edges
(mu = 0, mu = 1, c = 0, c = 1) are in both, because the error there must be
measured and the fit must respect them.  The pole mu_i = mu_o = 0 of the BRDF
terms is left out of every set (the exact values are infinite there).
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fitlab.cache import cached_arrays
from fitlab.core import Dataset
from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.exact import (
    brdf,
    brdf_modes,
    constants,
    h_function,
    multiple_scattering_modes,
    spherical_albedo,
)
from fitlab.families.lambert_sphere.exact.constants import CONSTANT_NAMES
from fitlab.families.lambert_sphere.targets.table_files import (
    SAMPLING_FILES,
    read_constants,
    read_h,
    read_kd,
    read_sampling,
    tables_dir,
)


def _cached(name: str, grid: str, compute, inputs: tuple[str, ...], aux: tuple[str, ...] = (), **axes) -> Dataset:
    """``compute()`` (a Dataset with ``inputs`` and ``aux``) through fitlab's persistent cache of exact
    values, keyed by the set's name, its grid (text and ``axes`` arrays) and the exact engine's source."""

    def arrays():
        ds = compute()
        return {**{f"in_{k}": ds.inputs[k] for k in inputs}, "y": ds.y, **{f"aux_{k}": ds.aux[k] for k in aux}}

    names = (*(f"in_{k}" for k in inputs), "y", *(f"aux_{k}" for k in aux))
    a = cached_arrays(f"lambert_sphere-{name}", {"family": "lambert_sphere", "set": name, "grid": grid, **{k: np.asarray(v, dtype=float) for k, v in axes.items()}}, arrays,
                      names, sources=exact.SOURCES)  # fmt: skip
    return Dataset({k: a[f"in_{k}"] for k in inputs}, a["y"], grid, {k: a[f"aux_{k}"] for k in aux} or None)


def _interleaved(step_denominator: int, extra=()) -> np.ndarray:
    """Odd multiples of 1/step_denominator in (0, 1), plus 0, 1 and ``extra``."""
    odd = (2 * np.arange(step_denominator // 2) + 1) / step_denominator
    return np.unique(np.concatenate(([0.0, 1.0], odd, np.asarray(extra, dtype=float))))


# -- H-functions --------------------------------------------------------------
def h_training(order: int, data_dir: Path | None = None) -> Dataset:
    """H_order on the grid of the tables (``data_dir``: the tables' folder; None: :func:`.table_files.tables_dir`)."""
    return _h_training(order, tables_dir(data_dir))


@cache
def _h_training(order: int, folder: Path) -> Dataset:
    t = read_h(order, folder)
    t = t[t[:, 2] <= 1.0]
    return Dataset(
        {"mu": t[:, 2], "c": t[:, 1]}, t[:, 3], f"table h{order}.csv, mu <= 1: s = k/64, mu = k/64 and 1e-12..1e-3"
    )


@cache
def h_validation(order: int) -> Dataset:
    grid = "s, mu = (2k+1)/256, plus 0, 1 and mu = 1e-10, 1e-7, 1e-5"

    def compute():
        s = _interleaved(256)
        mu = _interleaved(256, extra=(1e-10, 1e-7, 1e-5))
        c = 1.0 - s**2
        values = np.stack([h_function(order, mu, cv) for cv in c])
        cc, mm = np.meshgrid(c, mu, indexing="ij")
        return Dataset({"mu": mm.ravel(), "c": cc.ravel()}, values.ravel(), grid)

    return _cached(f"H{order}-validation", grid, compute, ("mu", "c"), s=_interleaved(256),
                   mu=_interleaved(256, extra=(1e-10, 1e-7, 1e-5)))  # fmt: skip


# -- constants and kd (functions of c) ----------------------------------------
_S_1D = _interleaved(256)


@cache
def _constants_validation():
    c = 1.0 - _S_1D**2

    def compute():
        k = constants(c)
        return Dataset({"c": c}, np.zeros(c.size), "", {n: np.asarray(k[n], dtype=float) for n in CONSTANT_NAMES})

    ds = _cached("constants-validation", "s = (2k+1)/256, plus 0 and 1", compute, ("c",), CONSTANT_NAMES, c=c)
    return ds.aux


def constant_training(name: str, data_dir: Path | None = None) -> Dataset:
    table = read_constants(tables_dir(data_dir))
    if name not in table or name in ("s", "c"):
        raise KeyError(f"table constants.csv has no constant {name!r}")
    return Dataset({"c": table["c"]}, table[name], "table constants.csv: s = k/64")


def constant_validation(name: str) -> Dataset:
    return Dataset(
        {"c": 1.0 - _S_1D**2}, np.asarray(_constants_validation()[name], dtype=float), "s = (2k+1)/256, plus 0 and 1"
    )


def _kd_training(data_dir: Path | None = None):
    t = read_kd(tables_dir(data_dir))
    return t["c"], t["kd_true"]


def kd_true(c) -> np.ndarray:
    """kd_true(c), the spherical albedo of the whole phase function (:func:`spherical_albedo`, phase "true"),
    at the albedos ``c`` (any shape), through fitlab's persistent cache keyed by the distinct albedos, sorted,
    and the exact engine's sources: about 0.4 s per albedo computed, shared by the validation sets and the
    residual grids whatever their order."""
    c = np.asarray(c, dtype=float)
    distinct, where = np.unique(c, return_inverse=True)
    key = {"family": "lambert_sphere", "set": "kd_true", "c": distinct}
    kd = cached_arrays("lambert_sphere-kd-true", key, lambda: {"kd": spherical_albedo(distinct, phase="true")},
                       ("kd",), sources=exact.SOURCES)["kd"]  # fmt: skip
    return kd[where].reshape(c.shape)


@cache
def _kd_validation():
    c = 1.0 - _S_1D**2
    return c, kd_true(c)


def kd_of_c_training(data_dir: Path | None = None) -> Dataset:
    c, kd = _kd_training(data_dir)
    return Dataset({"c": c}, kd, "table kd.csv (kd_true): s = k/64")


def kd_of_c_validation() -> Dataset:
    c, kd = _kd_validation()
    return Dataset({"c": c}, kd, "s = (2k+1)/256, plus 0 and 1")


def _inverse(c, kd, grid):
    # kd_true(1) = 1 to about 1e-14: a point rounded above 1 lies outside the map's domain
    keep = kd <= 1.0
    return Dataset({"kd": kd[keep]}, c[keep], grid)


def c_of_kd_training(data_dir: Path | None = None) -> Dataset:
    return _inverse(*_kd_training(data_dir), "table kd.csv (kd_true, kd <= 1): s = k/64")


def c_of_kd_validation() -> Dataset:
    return _inverse(*_kd_validation(), "kd_true at s = (2k+1)/256 plus 0 and 1, kd <= 1")


# -- BRDF level ----------------------------------------------------------------
def _pairs(mu):
    mi, mo = np.meshgrid(mu, mu, indexing="ij")
    keep = (mi + mo) > 0.0
    return mi[keep], mo[keep]


@cache
def fm1_training() -> Dataset:
    return _fm1(
        np.arange(17) / 16,
        np.concatenate(([0.0, 1e-6, 1e-3], np.arange(1, 17) / 16)),
        "s = k/16; mu = k/16 and 1e-6, 1e-3",
    )


@cache
def fm1_validation() -> Dataset:
    return _fm1(
        _interleaved(64), _interleaved(64, extra=(1e-9, 1e-5)), "s, mu = (2k+1)/64, plus 0, 1 and mu = 1e-9, 1e-5"
    )


def _fm1(s, mu, grid) -> Dataset:
    grid = grid + "; mu_i = mu_o = 0 left out"
    return _cached(
        f"fm1-{len(s)}x{len(mu)}", grid, lambda: _fm1_exact(s, mu, grid), ("mu_i", "mu_o", "c"), ("f0",), s=s, mu=mu
    )


def _fm1_exact(s, mu, grid) -> Dataset:
    mi, mo = _pairs(mu)
    cols = {"mu_i": [], "mu_o": [], "c": []}
    ys, f0 = [], []
    for cv in 1.0 - s**2:
        ys.append(multiple_scattering_modes(mi, mo, cv, phase="three_term")[1])
        f0.append(brdf_modes(mi, mo, cv)[0])
        for k, v in (("mu_i", mi), ("mu_o", mo), ("c", np.full(mi.shape, cv))):
            cols[k].append(v)
    return Dataset(
        {k: np.concatenate(v) for k, v in cols.items()},
        np.concatenate(ys),
        grid,
        {"f0": np.concatenate(f0)},
    )


@cache
def brdf_training() -> Dataset:
    return _brdf(
        np.arange(17) / 16,
        np.concatenate(([0.0, 1e-4], np.arange(1, 17) / 16)),
        np.arange(9) * np.pi / 8,
        "s = k/16 and c = 0.005, 0.02, 0.05, 0.09 (s = k/16 leaves c in (0, 0.12) empty); mu = k/16 and 1e-4; "
        "phi = k pi/8",
        extra_c=(0.005, 0.02, 0.05, 0.09),
    )


@cache
def brdf_validation(phase: str = "true") -> Dataset:
    """The BRDF validation lattice: exact.brdf with ``phase`` ("true", the material's BRDF: the reference of
    fast_brdf and of every BRDF-level figure; "mixed": the reference the runtime parts were fitted to, for
    the audit's rows against it), kd its spherical albedo; with phase "true" also the multiple scattering's
    Fourier orders 0 to 2 (aux fm0, fm1, fm2)."""
    return _brdf(*_validation_lattice(), phase=phase)


def _validation_lattice():
    """(s, mu, phi, grid) of the BRDF validation sets, mixed and true."""
    return (
        _interleaved(32),
        _interleaved(32, extra=(1e-6,)),
        np.pi * _interleaved(32),
        "s, mu, phi/pi = (2k+1)/32, plus 0, 1 and mu = 1e-6",
    )


def _brdf(s, mu, phi, grid, extra_c=(), phase="true") -> Dataset:
    """The BRDF on a lattice; ``phase`` as in :func:`exact.brdf <fitlab.families.lambert_sphere.exact.brdf>`,
    and kd the spherical albedo of the same physics (phase "true": kd_true)."""
    grid = grid + f"; mu_i = mu_o = 0 left out; exact.brdf(phase={phase!r}), kd its spherical albedo"
    name = f"brdf-{phase}-{len(s)}x{len(mu)}x{len(phi)}+{len(extra_c)}"
    aux = ("fm0", "fm1", "fm2") if phase == "true" else ()
    return _cached(
        name,
        grid,
        lambda: _brdf_exact(s, mu, phi, grid, extra_c, phase),
        ("mu_i", "mu_o", "phi", "c", "kd"),
        aux,
        s=s,
        mu=mu,
        phi=phi,
        extra_c=np.asarray(extra_c, dtype=float),
    )


def _brdf_exact(s, mu, phi, grid, extra_c=(), phase="true") -> Dataset:
    c = np.concatenate((1.0 - s**2, extra_c))
    mi, mo = _pairs(mu)
    n = mi.size
    cols = {"mu_i": [], "mu_o": [], "phi": [], "c": [], "kd": []}
    ys = []
    aux = {"fm0": [], "fm1": [], "fm2": []}
    # one c at a time: the true-phase engine caches the solutions of about one c
    for cv in c:
        kv = float(spherical_albedo(cv, phase=phase))
        if phase == "true":  # the multiple scattering's Fourier orders 0 to 2 (the runtime structure's terms)
            orders = multiple_scattering_modes(mi, mo, cv, phase=phase)
            for m in (0, 1, 2):  # c = 0 has one order, of zeros
                aux[f"fm{m}"] += [orders[m] if m < len(orders) else np.zeros(n)] * len(phi)
        # every phi in one call: the true-phase engine then solves its Nystrom rows once per c, not per phi
        ys.append(brdf(mi[None, :], mo[None, :], np.asarray(phi, dtype=float)[:, None], cv, phase=phase).ravel())
        for p in phi:
            for k, v in (
                ("mu_i", mi),
                ("mu_o", mo),
                ("phi", np.full(n, p)),
                ("c", np.full(n, cv)),
                ("kd", np.full(n, kv)),
            ):
                cols[k].append(v)
    return Dataset(
        {k: np.concatenate(v) for k, v in cols.items()},
        np.concatenate(ys),
        grid,
        {k: np.concatenate(v) for k, v in aux.items()} if phase == "true" else None,
    )


# -- the sampler's mixture (functions of mu_i and c) ---------------------------
#: target -> the column of the sampling tables that holds its exact values
SAMPLING_COLUMN = {"sample_weight": "weight", "sample_exponent": "exponent"}


def _sampling(target: str, name: str, data_dir: Path | None) -> Dataset:
    from fitlab.families.lambert_sphere.targets.table_files import SAMPLING_GRIDS

    t = read_sampling(name, tables_dir(data_dir))
    return Dataset(
        {"mu_i": t["mu_i"], "c": t["c"]}, t[SAMPLING_COLUMN[target]], f"table {name}: {SAMPLING_GRIDS[name][2]}"
    )


def sampling_training(target: str, data_dir: Path | None = None) -> Dataset:
    """The variance-optimal mixture's ``target`` on the training grid (table sampling.csv)."""
    return _sampling(target, SAMPLING_FILES[0], data_dir)


def sampling_validation(target: str, data_dir: Path | None = None) -> Dataset:
    """The same on the interleaved validation grid (table sampling_validation.csv)."""
    return _sampling(target, SAMPLING_FILES[1], data_dir)


# -- the true BRDF's Fourier orders, for the runtime parts fitted to it -------------------------------
#: the lattice of :func:`true_orders_training`: s = sqrt(1 - c) (s = 1, c = 0, left out: every order is 0 there),
#: more albedos where s = k/16 is sparse in c, and the cosines
TRUE_TRAINING_S = np.arange(16) / 16
TRUE_TRAINING_EXTRA_C = (1e-3, 3e-3, 1e-2, 2e-2, 4e-2, 7e-2)
TRUE_TRAINING_MU = np.unique(np.concatenate((np.arange(17) / 16, (1e-5, 1e-3, 4e-3, 1e-2, 2e-2))))


@cache
def true_orders_training() -> Dataset:
    """The true BRDF's multiple scattering by Fourier order, fm0, fm1, fm2 (exact.multiple_scattering_modes,
    phase="true"), on a lattice apart from the validation sets' (:func:`_validation_lattice`): s = k/16 and
    c = 1e-3, 3e-3, 1e-2, 2e-2, 4e-2, 7e-2 (small c, where s = k/16 is sparse in c); mu = k/16 and 1e-5, 1e-3,
    4e-3, 1e-2, 2e-2 (mu_i = mu_o = 0 left out).  y is fm0; aux
    holds fm0, fm1, fm2 and "scale", the true BRDF's minimum over 33 phi in [0, pi] at each (mu_i, mu_o, c)
    (the denominator of the relative error a part's error makes in f_r)."""
    s, extra_c, mu = TRUE_TRAINING_S, TRUE_TRAINING_EXTRA_C, TRUE_TRAINING_MU
    grid = "s = k/16 (k < 16) and c = 1e-3, 3e-3, 1e-2, 2e-2, 4e-2, 7e-2; mu = k/16 and 1e-5, 1e-3, 4e-3, 1e-2, 2e-2; mu_i = mu_o = 0 left out"
    phi = np.linspace(0.0, np.pi, 33)
    return _cached(
        "true-orders",
        grid,
        lambda: _true_orders(s, mu, phi, extra_c, grid),
        ("mu_i", "mu_o", "c"),
        ("fm0", "fm1", "fm2", "scale"),
        s=s,
        mu=mu,
        phi=phi,
        extra_c=np.asarray(extra_c, dtype=float),
    )


def _true_orders(s, mu, phi, extra_c, grid) -> Dataset:
    mi, mo = _pairs(mu)
    cols = {k: [] for k in ("mu_i", "mu_o", "c", "fm0", "fm1", "fm2", "scale")}
    for cv in np.concatenate((1.0 - s**2, extra_c)):
        orders = multiple_scattering_modes(mi, mo, cv, phase="true")
        f = brdf(mi[None, :], mo[None, :], phi[:, None], cv, phase="true")
        for k, v in (
            ("mu_i", mi),
            ("mu_o", mo),
            ("c", np.full(mi.size, cv)),
            ("fm0", orders[0]),
            ("fm1", orders[1]),
            ("fm2", orders[2]),
            ("scale", np.min(f, axis=0)),
        ):
            cols[k].append(v)
    cols = {k: np.concatenate(v) for k, v in cols.items()}
    return Dataset(
        {k: cols[k] for k in ("mu_i", "mu_o", "c")},
        cols["fm0"],
        grid,
        {k: cols[k] for k in ("fm0", "fm1", "fm2", "scale")},
    )


#: the edge block of :func:`brdf_true_independent`: grazing cosines from the accuracy goal's edge mu = 0.01 up,
#: at small albedos (where the runtime model's grazing forward-scattering error peaks) and the random ones; the
#: albedos are none of :func:`true_orders_training`'s, so no point of the block is a training point
EDGE_MU = (0.01, 0.0125, 0.015, 0.02, 0.03, 0.05)
EDGE_PHI = (0.0, 0.5, 0.9, 1.0)  # x pi
EDGE_C = (0.005, 0.0125, 0.0175, 0.0225, 0.03, 0.05)


def true_independent_points(seed: int = 33, n_c: int = 10, per_c: int = 400) -> tuple[list, str]:
    """The points of :func:`brdf_true_independent`, without values: [(c, array (n, 3) of (mu_i, mu_o, phi)), ...]
    one block per albedo, and the set's description:

    * random: ``n_c`` albedos uniform in (0, 1) and c = 1, each with ``per_c`` points (mu_i, mu_o, phi)
      uniform in [0, 1]^2 x [0, pi] (seeded);
    * the edge: mu_i, mu_o in :data:`EDGE_MU`, phi/pi in :data:`EDGE_PHI`, at c in :data:`EDGE_C` and the
      random albedos (not at c = 1, an albedo of :func:`true_orders_training`)."""
    rng = np.random.default_rng(seed)
    c = np.concatenate((rng.uniform(0.0, 1.0, n_c), (1.0,)))
    points = rng.uniform(0.0, 1.0, (c.size, per_c, 3))
    points[..., 2] *= np.pi
    edge = np.stack([a.ravel() for a in np.meshgrid(EDGE_MU, EDGE_MU, np.pi * np.asarray(EDGE_PHI), indexing="ij")], 1)
    blocks = [(float(cv), p) for cv, p in zip(c, points)] + [(float(cv), edge) for cv in (*EDGE_C, *c[:-1])]
    grid = (
        f"seed {seed}: {n_c} albedos uniform in (0, 1) and c = 1, {per_c} points each uniform in mu_i, mu_o, "
        f"phi/pi; and mu_i, mu_o in {{{', '.join(map(str, EDGE_MU))}}} x phi/pi in "
        f"{{{', '.join(map(str, EDGE_PHI))}}} at c = {', '.join(map(str, EDGE_C))} and the random albedos"
    )
    return blocks, grid


@cache
def brdf_true_independent(seed: int = 33, n_c: int = 10, per_c: int = 400) -> Dataset:
    """The true BRDF (exact.brdf(phase="true")) at points no fit saw (:func:`true_independent_points`), kd 0
    (not computed: the audit's runtime rows do not read it)."""
    blocks, grid = true_independent_points(seed, n_c, per_c)

    def compute():
        # every block of one albedo before the next (a random albedo has two): the true-phase engine keeps the
        # solutions of about one albedo
        ys = [np.empty(0)] * len(blocks)
        for cv in dict.fromkeys(cv for cv, _ in blocks):
            for k, (cb, p) in enumerate(blocks):
                if cb == cv:
                    ys[k] = brdf(p[:, 0], p[:, 1], p[:, 2], cv, phase="true")
        n = [len(p) for _, p in blocks]
        return Dataset(
            {
                "mu_i": np.concatenate([p[:, 0] for _, p in blocks]),
                "mu_o": np.concatenate([p[:, 1] for _, p in blocks]),
                "phi": np.concatenate([p[:, 2] for _, p in blocks]),
                "c": np.repeat([cv for cv, _ in blocks], n),
                "kd": np.zeros(sum(n)),
            },
            np.concatenate(ys),
            grid,
        )

    random_c = np.array([cv for cv, _ in blocks[: n_c + 1]])  # the random blocks come first
    return _cached(
        f"brdf-true-independent-{seed}-{n_c}x{per_c}+edge2",
        grid,
        compute,
        ("mu_i", "mu_o", "phi", "c", "kd"),
        c=random_c,
        edge_mu=np.asarray(EDGE_MU),
        edge_phi=np.asarray(EDGE_PHI),
        edge_c=np.asarray(EDGE_C),
    )
