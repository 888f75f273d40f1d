r"""The one BRDF validation set of the report, over (mu_i, mu_o, phi, c).

Albedos c = 1 - s^2 with s = (k + g)/n, k = 0..n-1, g = (sqrt 5 - 1)/2, plus
c = 1: an irrational offset keeps every s off the tables' grid s = k/64 (a
table method would otherwise be exact in c at every point) and off the fits'
training and validation grids (dyadic in s).  c = 0 is left out: the BRDF is
0 there and a relative error means nothing.  For each c the same 2^m scrambled
Sobol points (seeded) give (mu_i, mu_o, phi/pi) in (0, 1)^3; mu is uniform, so
the grazing pole mu_i = mu_o = 0 is approached only as far as the points go
(min mu_i + mu_o is about 2^(-m/2)).  kd = kd_true(c), the spherical albedo of
:func:`fitlab.families.lambert_sphere.exact.brdf` (the input of the fast variant and the baselines).
y = :func:`fitlab.families.lambert_sphere.exact.brdf`.

Because uniform points never come near the pole, a second, small set looks there
on purpose (:func:`grazing_set`): mu_i, mu_o in {1e-6, 1e-4, 1e-2} (all nine
pairs) x phi in {0, pi/2, pi} x the same albedos.  At phi = pi with mu_i = mu_o
-> 0 single scattering vanishes and the exact BRDF grows like log(1/mu) through
its multiple-scattering orders, so an approximation's (H_i H_o - 1)/(mu_i + mu_o)
is tested where 1/mu magnifies the error of H - 1 (docs/fitting.md, "Grazing").

The exact values cost the engine about a second per c, so the set is cached
(``$FITLAB_CACHE_DIR``, else ``$XDG_CACHE_HOME/fitlab``, else
``~/.cache/fitlab``) under a key that hashes the points, the albedos and the
sources of :mod:`fitlab.families.lambert_sphere.exact`; a changed engine never reads a stale cache.
"""

from __future__ import annotations

import hashlib
import io
import os
from pathlib import Path

import numpy as np

from fitlab import __version__
from fitlab._io import atomic_write_bytes
from fitlab.families.lambert_sphere.exact import brdf, spherical_albedo
from fitlab.core import Dataset
from fitlab.report.settings import Settings

__all__ = ["albedos", "sobol_points", "brdf_set", "grazing_set", "cache_dir", "GOLDEN", "GRAZING_MU", "GRAZING_PHI"]

GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0
EXACT_DIR = Path(__file__).resolve().parents[1] / "families" / "lambert_sphere" / "exact"
#: the grazing set's cosines and azimuths
GRAZING_MU = (1e-6, 1e-4, 1e-2)
GRAZING_PHI = (0.0, 0.5 * np.pi, np.pi)


def albedos(n: int, with_c1: bool) -> np.ndarray:
    """c = 1 - s^2, s = (k + g)/n for k = 0..n-1 (g the golden ratio's fraction), then c = 1 if asked."""
    s = (np.arange(n) + GOLDEN) / n
    c = 1.0 - s**2
    return np.concatenate((c, [1.0])) if with_c1 else c


def sobol_points(log2_points: int, seed: int) -> np.ndarray:
    """2^log2_points scrambled Sobol points in (0, 1)^3 (rows: mu_i, mu_o, phi/pi)."""
    from scipy.stats import qmc

    return qmc.Sobol(3, scramble=True, seed=seed).random_base2(log2_points)


def cache_dir() -> Path:
    if os.environ.get("FITLAB_CACHE_DIR"):
        return Path(os.environ["FITLAB_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "fitlab"


def _key(points: np.ndarray, c: np.ndarray) -> str:
    h = hashlib.sha256(__version__.encode())
    h.update(np.ascontiguousarray(points, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(c, dtype="<f8").tobytes())
    for src in sorted(EXACT_DIR.glob("*.py")):
        h.update(src.name.encode())
        h.update(src.read_bytes())
    return h.hexdigest()[:24]


def _load(path: Path, shape) -> tuple | None:
    try:
        with np.load(path) as z:
            y, kd = z["y"], z["kd"]
    except Exception:  # noqa: BLE001 - missing, truncated or damaged (EOFError, BadZipFile, ...): a cache miss
        return None
    return (y, kd) if y.shape == shape and kd.shape == shape[:1] else None


def _exact_values(points: np.ndarray, c: np.ndarray, kind: str, use_cache: bool, tick) -> tuple:
    """y[k, j] = brdf(points[j], c[k]) and kd[k] = kd_true(c[k]), through the cache."""
    mu_i, mu_o, phi = points[:, 0], points[:, 1], np.pi * points[:, 2]
    path = cache_dir() / f"report-{kind}-{_key(points, c)}.npz"
    cached = _load(path, (c.size, points.shape[0])) if use_cache else None
    if cached is not None:
        for _ in c:
            tick and tick()
        return cached
    y = np.empty((c.size, points.shape[0]))
    for k, cv in enumerate(c):
        y[k] = brdf(mu_i, mu_o, phi, cv)
        tick and tick()
    kd = np.asarray(spherical_albedo(c, model="true"), dtype=float)
    if use_cache:
        buf = io.BytesIO()
        np.savez(buf, y=y, kd=kd)
        try:
            atomic_write_bytes(path, buf.getvalue())
        except OSError:
            pass  # a cache that cannot be written only costs time
    return y, kd


def _dataset(points: np.ndarray, c: np.ndarray, y: np.ndarray, kd: np.ndarray, grid: str) -> Dataset:
    n = points.shape[0]
    inputs = {
        "mu_i": np.tile(points[:, 0], c.size), "mu_o": np.tile(points[:, 1], c.size),
        "phi": np.tile(np.pi * points[:, 2], c.size), "c": np.repeat(c, n), "kd": np.repeat(kd, n),
    }  # fmt: skip
    return Dataset(inputs, y.ravel(), grid)


def _albedo_grid(settings: Settings) -> str:
    return (f"{settings.n_c + settings.with_c1} albedos c = 1 - s^2, s = (k + 0.618...)/{settings.n_c}"
            + (" and c = 1" if settings.with_c1 else ""))  # fmt: skip


def brdf_set(settings: Settings, use_cache: bool = True, tick=None) -> Dataset:
    """The validation set (a :class:`fitlab.core.Dataset` with inputs mu_i, mu_o, phi, c, kd).

    ``tick()`` is called once per albedo computed (a progress bar); a cache hit calls it for all.
    """
    points = sobol_points(settings.log2_points, settings.seed)
    c = albedos(settings.n_c, settings.with_c1)
    y, kd = _exact_values(points, c, "brdf", use_cache, tick)
    grid = (_albedo_grid(settings)
            + f", x 2^{settings.log2_points} scrambled Sobol points (seed {settings.seed}) in (mu_i, mu_o, phi/pi)")
    return _dataset(points, c, y, kd, grid)


def grazing_set(settings: Settings, use_cache: bool = True, tick=None) -> Dataset:
    """The grazing set: mu_i, mu_o in :data:`GRAZING_MU`, phi in :data:`GRAZING_PHI`, the report's albedos."""
    mi, mo, ph = np.meshgrid(GRAZING_MU, GRAZING_MU, np.asarray(GRAZING_PHI) / np.pi, indexing="ij")
    points = np.stack([mi.ravel(), mo.ravel(), ph.ravel()], axis=1)
    c = albedos(settings.n_c, settings.with_c1)
    y, kd = _exact_values(points, c, "grazing", use_cache, tick)
    grid = (_albedo_grid(settings) + " x mu_i, mu_o in {" + ", ".join(f"{m:g}" for m in GRAZING_MU)
            + "} x phi in {0, pi/2, pi}")  # fmt: skip
    return _dataset(points, c, y, kd, grid)
