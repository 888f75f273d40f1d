r"""The one BRDF validation set of the report, over (mu_i, mu_o, phi) and the family's materials.

The exact values come from the family's report (``exact_brdf``, ``exact_kd``:
for the Lambert sphere :func:`fitlab.families.lambert_sphere.exact.brdf` and kd_true).

The materials are the family's (its report's ``validation_materials`` and ``fresh_materials``; for the
Lambert sphere the albedos c of :mod:`fitlab.families.lambert_sphere.program.report.materials`, with kd = kd_true(c),
the report's ``exact_kd``).  For each material the same 2^m scrambled Sobol points (seeded) give
(mu_i, mu_o, phi/pi) in (0, 1)^3; mu is uniform, so the grazing pole mu_i = mu_o = 0 is approached only as far
as the points go (min mu_i + mu_o is about 2^(-m/2)).

Because uniform points never come near the pole, a second, small set looks there
on purpose (the second set of :func:`validation_sets`): mu_i, mu_o in {1e-6, 1e-4, 1e-2} (all nine
pairs) x phi in {0, pi/2, pi} x the same materials.  At phi = pi with mu_i = mu_o
-> 0 single scattering vanishes and the exact BRDF grows like log(1/mu) through
its multiple-scattering orders, so an approximation's (H_i H_o - 1)/(mu_i + mu_o)
is tested where 1/mu magnifies the error of H - 1 (docs/fitting.md, "Grazing").

The exact values cost the engine about a second per c, so the set is cached
(:mod:`fitlab.cache`: ``$FITLAB_CACHE_DIR``, else ``$XDG_CACHE_HOME/fitlab``, else
``~/.cache/fitlab``) under a key that hashes the points, the materials and the
sources of :mod:`fitlab.families.lambert_sphere.exact`; a changed engine never reads a stale cache.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from fitlab.cache import cache_dir, cached_arrays
from fitlab.core import Dataset
from fitlab.report.methods import brdf_report
from fitlab.report.settings import Settings, family_settings

__all__ = ["sobol_points", "validation_sets", "fresh_set", "cache_dir", "exact_values", "GRAZING_MU", "GRAZING_PHI"]

#: the grazing set's cosines and azimuths
GRAZING_MU = (1e-6, 1e-4, 1e-2)
GRAZING_PHI = (0.0, 0.5 * np.pi, np.pi)


def sobol_points(log2_points: int, seed: int) -> np.ndarray:
    """2^log2_points scrambled Sobol points in (0, 1)^3 (rows: mu_i, mu_o, phi/pi)."""
    from scipy.stats import qmc

    return qmc.Sobol(3, scramble=True, seed=seed).random_base2(log2_points)


def exact_values(point_sets: Mapping[str, np.ndarray], c: np.ndarray, use_cache: bool = True, tick=None) -> tuple:
    """({kind: y}, kd): y[k, j] = the exact BRDF at point_sets[kind][j] (mu_i, mu_o, phi/pi) and c[k], and
    kd[k] = kd_true(c[k]), through :func:`fitlab.cache.cached_arrays` (one entry per kind, report-KIND-KEY.npz,
    keyed by its points, the materials and the family's exact sources; a damaged entry is a miss).  The sets are
    computed together, every set at one albedo before the next (an exact engine may keep the solution of only
    one albedo: a set after set loop would solve each albedo once per set).  ``tick()`` once per albedo."""
    hook = brdf_report()
    sources = sorted(Path(hook.EXACT_SOURCES).glob("*.py"))
    c = np.asarray(c, dtype=float)
    kinds = list(point_sets)
    computed: dict = {}

    def compute(kind: str):
        if kind not in computed:  # this set and those after it: the ones before were read from the cache
            todo = kinds[kinds.index(kind) :]
            ys = {k: np.empty((c.size, point_sets[k].shape[0])) for k in todo}
            for i, cv in enumerate(c):
                for k in todo:
                    p = point_sets[k]
                    ys[k][i] = hook.exact_brdf(p[:, 0], p[:, 1], np.pi * p[:, 2], cv)
                if tick:
                    tick()
            kd = hook.exact_kd(c)
            computed.update({k: {"y": ys[k], "kd": kd} for k in todo})
        return computed[kind]

    out = {}
    for kind in kinds:
        out[kind] = cached_arrays(f"report-{kind}", {"points": np.asarray(point_sets[kind], dtype=float), "c": c},
                                  lambda kind=kind: compute(kind), ("y", "kd"), sources, use_cache)  # fmt: skip
    if not computed:
        for _ in c:
            if tick:
                tick()
    return {kind: v["y"] for kind, v in out.items()}, out[kinds[0]]["kd"]


def _inputs(mu_i, mu_o, phi, c, kd) -> dict:
    """The BRDF's inputs by the report's names (``BRDF_INPUTS``: the two cosines, the azimuth, the material
    and its second parameter, in that order)."""
    return dict(zip(brdf_report().BRDF_INPUTS, (mu_i, mu_o, phi, c, kd), strict=True))


def _dataset(points: np.ndarray, c: np.ndarray, y: np.ndarray, kd: np.ndarray, grid: str) -> Dataset:
    n = points.shape[0]
    mu_i, mu_o, phi = (np.tile(points[:, k], c.size) for k in range(3))
    inputs = _inputs(mu_i, mu_o, np.pi * phi, np.repeat(c, n), np.repeat(kd, n))
    return Dataset(inputs, y.ravel(), grid)


def _grazing_points() -> np.ndarray:
    mi, mo, ph = np.meshgrid(GRAZING_MU, GRAZING_MU, np.asarray(GRAZING_PHI) / np.pi, indexing="ij")
    return np.stack([mi.ravel(), mo.ravel(), ph.ravel()], axis=1)


def validation_sets(settings: Settings, use_cache: bool = True, tick=None) -> tuple[Dataset, Dataset]:
    """(the validation set, the grazing set), :class:`fitlab.core.Dataset` objects with the BRDF's inputs (for
    the Lambert sphere mu_i, mu_o, phi, c, kd), computed together (:func:`exact_values`).

    The validation set: the family's materials x 2^``log2_points`` scrambled Sobol points in (mu_i, mu_o, phi/pi).
    The grazing set: mu_i, mu_o in :data:`GRAZING_MU`, phi in :data:`GRAZING_PHI`, the same materials.
    ``tick()`` is called once per albedo computed (a progress bar); a cache hit calls it for all.
    """
    points = {"brdf": sobol_points(settings.log2_points, settings.seed), "grazing": _grazing_points()}
    hook = brdf_report()
    c, materials = hook.validation_materials(family_settings(settings, hook))
    ys, kd = exact_values(points, c, use_cache, tick)
    grids = {
        "brdf": (materials + f", x 2^{settings.log2_points} scrambled Sobol points (seed {settings.seed})"
                 " in (mu_i, mu_o, phi/pi)"),
        "grazing": (materials + " x mu_i, mu_o in {" + ", ".join(f"{m:g}" for m in GRAZING_MU)
                    + "} x phi in {0, pi/2, pi}"),
    }  # fmt: skip
    return (
        _dataset(points["brdf"], c, ys["brdf"], kd, grids["brdf"]),
        _dataset(points["grazing"], c, ys["grazing"], kd, grids["grazing"]),
    )


def fresh_set(settings: Settings, use_cache: bool = True, tick=None) -> Dataset:
    """The independent set: the family's materials for it (``fresh_materials``, the first draws of the set's
    generator), each with its own points (mu_i, mu_o, phi) uniform in (0, 1)^2 x (0, pi), ``fresh_points`` in
    all, all drawn from numpy's PCG64 seeded with ``fresh_seed`` (nothing of fitlab is fitted or selected on
    it; another generator and seed than the Sobol set's).  ``tick()`` once per material."""
    hook = brdf_report()
    rng = np.random.default_rng(settings.fresh_seed)
    c, materials = hook.fresh_materials(rng, family_settings(settings, hook))  # the generator's first draws
    per_c = -(-settings.fresh_points // c.size)
    points = rng.uniform(0.0, 1.0, (c.size, per_c, 3))
    computed = []

    def compute():
        computed.append(True)
        y = np.empty((c.size, per_c))
        for k, cv in enumerate(c):
            p = points[k]
            y[k] = hook.exact_brdf(p[:, 0], p[:, 1], np.pi * p[:, 2], cv)
            if tick:
                tick()
        return {"y": y, "kd": hook.exact_kd(c)}

    sources = sorted(Path(hook.EXACT_SOURCES).glob("*.py"))
    out = cached_arrays("report-fresh", {"points": points, "c": c}, compute, ("y", "kd"), sources, use_cache)
    if not computed:
        for _ in c:
            if tick:
                tick()
    inputs = _inputs(points[:, :, 0].ravel(), points[:, :, 1].ravel(), np.pi * points[:, :, 2].ravel(),
                     np.repeat(c, per_c), np.repeat(out["kd"], per_c))  # fmt: skip
    grid = f"{materials}, {per_c} points each, (mu_i, mu_o, phi) uniform, numpy PCG64 seed {settings.fresh_seed}"
    return Dataset(inputs, out["y"].ravel(), grid)
