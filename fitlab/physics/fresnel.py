r"""Fresnel reflectance: the exact dielectric and conductor, Schlick and the approximations built on it.

c is the cosine of the angle of incidence on the interface, in [0, 1]; light arrives from a medium of index 1 (or
the relative index is given).  Derivations and accuracy: docs/fresnel.md; the real form of the conductor and its
evaluation without cancellation: docs/architecture.md, "One physics".
"""

from __future__ import annotations

import math
from typing import Any

from fitlab.physics._namespace import namespace

__all__ = [
    "F82_COSINE",
    "schlick_weight",
    "fresnel_schlick",
    "schlick_average",
    "schlick_generalised",
    "lazanyi",
    "f82_tint_coefficient",
    "f82_tint",
    "fresnel_conductor",
    "fresnel_dielectric",
    "fresnel_dielectric_transmittance",
    "conductor_bend",
    "normal_reflectance",
    "gulbrandsen_index",
    "gulbrandsen_parameters",
]

#: Hoffman's F82 angle as a cosine: 1/7 (82.0 degrees)
F82_COSINE = (1, 7)


def schlick_weight(c: Any) -> Any:
    """(1 - c)^5, Schlick's weight of F90 - F0."""
    m = 1 - c
    m2 = m * m
    return m2 * m2 * m


def fresnel_schlick(c: Any, f0: Any) -> Any:
    """Schlick (RTR4 eq. 9.16): F0 + (1 - F0)(1 - c)^5."""
    return f0 + (1 - f0) * schlick_weight(c)


def schlick_average(f0: Any) -> Any:
    """Schlick's cosine-weighted average 2 int_0^1 F(c) c dc = F0 + 2 (1 - F0) B(2, 6) = (20 F0 + 1) / 21."""
    return (20 * f0 + 1) / 21


def schlick_generalised(c: Any, f0: Any, f90: Any, p: Any) -> Any:
    """The generalised Schlick (RTR4 eq. 9.18): F0 + (F90 - F0)(1 - c)^(1/p)."""
    xp = namespace(c, f0, f90, p)
    return f0 + (f90 - f0) * xp.pow_nonneg(1 - c, 1 / p)


def lazanyi(c: Any, f0: Any, a: Any, alpha: Any) -> Any:
    """Lazanyi and Szirmay-Kalos (2005), as Hoffman writes it: Schlick - a c (1 - c)^alpha."""
    xp = namespace(c, f0, a, alpha)
    return fresnel_schlick(c, f0) - a * c * xp.pow_nonneg(1 - c, alpha)


def f82_tint_coefficient(f0: Any, tint: Any) -> Any:
    """a of Hoffman's F82-tint (2019): S(c_bar) (1 - tint) / (c_bar (1 - c_bar)^6), S Schlick's F, c_bar = 1/7; so
    that F(c_bar) = tint S(c_bar)."""
    xp = namespace(f0, tint)
    c_bar = xp.rational(*F82_COSINE)
    m2 = (1 - c_bar) * (1 - c_bar)
    return fresnel_schlick(c_bar, f0) * (1 - tint) / (c_bar * (m2 * m2 * m2))


def f82_tint(c: Any, f0: Any, tint: Any) -> Any:
    """Hoffman's F82-tint (OpenPBR's and the Adobe Standard Material's metal): Schlick - a c (1 - c)^6, a of
    :func:`f82_tint_coefficient`."""
    m = 1 - c
    m2 = m * m
    return fresnel_schlick(c, f0) - f82_tint_coefficient(f0, tint) * c * (m2 * m2 * m2)


def fresnel_conductor(c: Any, eta: Any, k: Any) -> Any:
    r"""Unpolarised reflectance of a conductor of complex relative index eta + i k (eta > 0, k >= 0), from the
    amplitudes of Born and Wolf in real form.  With s2 = 1 - c^2, t0 = eta^2 - k^2 - s2 and a + i b the principal
    root of (eta + i k)^2 - s2 (a, b >= 0):

        R_s = ((c - a)^2 + b^2) / ((c + a)^2 + b^2),
        R_p = R_s ((a c - s2)^2 + (b c)^2) / ((a c + s2)^2 + (b c)^2),   F = (R_s + R_p) / 2.

    Without cancellation: t0 = ((eta - 1)(eta + 1) - k^2) + c^2; a^2 and b^2 are max(+-t0, 0) + (eta k)^2 / h,
    h = (|t0| + sqrt(t0^2 + 4 eta^2 k^2)) / 2, sums of non-negative terms; R_s, R_p ratios of sums of squares.
    k = 0 is the dielectric of :func:`fresnel_dielectric` (1 beyond the critical angle when eta < 1).  F(1) =
    ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2), F(0) = 1, and 0 for the matched eta = 1, k = 0 at every c."""
    xp = namespace(c, eta, k)
    with xp.quiet():
        s2 = (1 - c) * (1 + c)
        t0 = ((eta - 1) * (eta + 1) - k * k) + c * c
        ek = eta * k
        big = (xp.hypot(t0, 2 * ek) + xp.abs(t0)) / 2
        small = ek * xp.ratio(ek, big, 0)
        a2 = xp.positive_part(t0) + small
        b2 = xp.positive_part(-t0) + small
        a = xp.sqrt(a2)
        r_s = xp.ratio((c - a) ** 2 + b2, (c + a) ** 2 + b2, 0)  # 0: the matched interface at c = 0
        ac = a * c
        b2c2 = b2 * c * c
        # 0 only at c = 1 with a = b = 0 (eta^2 underflowing), where R_p = R_s
        r_p = r_s * xp.ratio((ac - s2) ** 2 + b2c2, (ac + s2) ** 2 + b2c2, 1)
        return (r_s + r_p) / 2


def fresnel_dielectric(c: Any, eta: Any) -> Any:
    """Unpolarised reflectance at a dielectric interface of relative index eta = n_t / n_i > 0, seen from the
    incident side: cos_t = sqrt(1 - (1 - c^2) / eta^2), r_s = (c - eta cos_t) / (c + eta cos_t), r_p = (eta c -
    cos_t) / (eta c + cos_t), F = (r_s^2 + r_p^2) / 2, and 1 beyond the critical angle (eta < 1)."""
    xp = namespace(c, eta)
    with xp.quiet():
        cos_t2 = ((eta - 1) * (eta + 1) + c * c) / (eta * eta)  # 1 - (1 - c^2) / eta^2 without cancellation
        tir = cos_t2 < 0
        cos_t = xp.sqrt(xp.where(tir, 0, cos_t2))
        # both denominators vanish only at c = 0 with eta = 1 (no interface), where F = 0
        r_s = xp.ratio(c - eta * cos_t, c + eta * cos_t, 0)
        r_p = xp.ratio(eta * c - cos_t, eta * c + cos_t, 0)
        return xp.where(tir, 1, (r_s * r_s + r_p * r_p) / 2)


def fresnel_dielectric_transmittance(cos_i: Any, cos_t: Any, eta: Any) -> Any:
    """1 - F at a dielectric interface of relative index eta for a refraction whose two cosines are known (eta sin_t
    = sin_i), as 1 - r^2 = (1 - r)(1 + r) per polarisation:

        1 - F = 2 eta cos_i cos_t (1 / (cos_i + eta cos_t)^2 + 1 / (eta cos_i + cos_t)^2),

    free of the cancellation of 1 - F near grazing and of Snell's square root near the critical angle; symmetric
    under (cos_i, cos_t, eta) -> (cos_t, cos_i, 1 / eta), as reciprocity needs; 0 where either cosine is 0."""
    xp = namespace(cos_i, cos_t, eta)
    with xp.quiet():
        den_s, den_p = cos_i + eta * cos_t, eta * cos_i + cos_t
        t = 2 * eta * cos_i * cos_t * (1 / (den_s * den_s) + 1 / (den_p * den_p))
        return xp.where((cos_i > 0) & (cos_t > 0), t, 0)


def conductor_bend(eta: float, k: float) -> tuple[float, ...]:
    """The cosine in (0, 1) where t0 = eta^2 - k^2 - (1 - c^2) = 0, if any: where :func:`fresnel_conductor` bends
    sharply (the critical angle, a square root, when k = 0 and eta < 1)."""
    m2 = 1 - (eta * eta - k * k)
    return (math.sqrt(m2),) if 0 < m2 < 1 else ()


def normal_reflectance(eta: Any, k: Any) -> Any:
    """F at normal incidence, ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2)."""
    return ((eta - 1) ** 2 + k * k) / ((eta + 1) ** 2 + k * k)


def gulbrandsen_index(r: Any, g: Any) -> tuple[Any, Any]:
    """Gulbrandsen's (2014) map from reflectivity r in [0, 1) and edge tint g in [0, 1] to (n, k): n = g n_min +
    (1 - g) n_max, n_min = (1 - r) / (1 + r), n_max = (1 + sqrt r) / (1 - sqrt r), k^2 = (r (n + 1)^2 - (n - 1)^2) /
    (1 - r) (clamped at 0), so that F(1) = r.  g = 0 is the dielectric of reflectance r."""
    xp = namespace(r, g)
    sr = xp.sqrt(r)
    n = g * (1 - r) / (1 + r) + (1 - g) * (1 + sr) / (1 - sr)
    k2 = (r * (n + 1) ** 2 - (n - 1) ** 2) / (1 - r)
    return n, xp.sqrt(xp.positive_part(k2))


def gulbrandsen_parameters(n: Any, k: Any) -> tuple[Any, Any]:
    """The inverse of :func:`gulbrandsen_index`: r = F(1) and g = (n_max - n) / (n_max - n_min) (outside [0, 1]
    where n lies outside [n_min(r), n_max(r)])."""
    xp = namespace(n, k)
    r = normal_reflectance(n, k)
    sr = xp.sqrt(r)
    n_min, n_max = (1 - r) / (1 + r), (1 + sr) / (1 - sr)
    return r, (n_max - n) / (n_max - n_min)
