r"""The exact inverse of the spherical albedo: the particle albedo c whose kd is given."""

from __future__ import annotations

from fitlab.families.lambert_sphere.exact.albedo import spherical_albedo

__all__ = ["albedo_inverse", "solve_albedo"]


def solve_albedo(kd_of_c, kd: float, lo: float = 0.0, hi: float = 1.0, xtol: float = 1e-13) -> float:
    """The particle albedo c in [lo, hi] with ``kd_of_c(c) == kd`` (Brent's method; the root must be
    bracketed): the inverse of any model's spherical albedo (:func:`albedo_inverse` for the Lambert
    sphere's, :func:`fitlab.families.lambert_sphere.mitsuba.render.chandrasekhar_albedo_c` for Chandrasekhar's)."""
    from scipy.optimize import brentq  # imported here: see single_scattering_albedo

    return float(brentq(lambda c: kd_of_c(c) - kd, lo, hi, xtol=xtol))


def albedo_inverse(kd: float, phase: str | None = None, guess: float | None = None) -> float:
    """c with ``spherical_albedo(c, phase) == kd`` (phase "true", the default, "three_term" or "mixed"), to 1e-13
    in c.

    Root by Brent's method; ``guess`` (e.g. the published eq. 39 map, the c_of_kd preset)
    brackets it within 0.005, which saves most evaluations (each solves H0, or the true half space's
    order 0, at a new c).  kd <= 0 gives 0, kd at or above kd(1) gives 1.
    """
    kd = float(kd)
    if kd <= 0.0:
        return 0.0

    def kd_of_c(c):
        return float(spherical_albedo(c, phase))

    if kd >= kd_of_c(1.0):
        return 1.0

    lo, hi = (0.0, 1.0) if guess is None else (max(0.0, guess - 0.005), min(1.0, guess + 0.005))
    if kd_of_c(lo) - kd > 0.0:
        lo = 0.0
    if kd_of_c(hi) - kd < 0.0:
        hi = 1.0
    return solve_albedo(kd_of_c, kd, lo, hi, xtol=1e-13)
