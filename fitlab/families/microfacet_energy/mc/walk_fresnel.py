r"""Fresnel factors of one microfacet reflection, in ``jax.numpy`` (the walk's own; the exact engine's
numpy versions, :func:`fitlab.families.microfacet_energy.exact.fresnel_conductor` and
:func:`~fitlab.families.microfacet_energy.exact.fresnel_schlick`, are what the tests compare with).

c = cos of the angle between the direction and the facet normal, in [0, 1].

* ``"one"``: F = 1 (the white furnace).
* ``"schlick"``: F = F0 + (1 - F0) (1 - c)^5, F0 in [0, 1].
* ``"conductor"``: the exact unpolarised reflectance of a conductor of complex relative index
  eta + i k (Born and Wolf; PBRT's FrConductor): with s^2 = 1 - c^2, t0 = eta^2 - k^2 - s^2,
  A = sqrt(t0^2 + 4 eta^2 k^2) (= a^2 + b^2), a = sqrt((A + t0) / 2),
  R_s = (A + c^2 - 2 a c) / (A + c^2 + 2 a c),
  R_p = R_s (c^2 A + s^4 - 2 a c s^2) / (c^2 A + s^4 + 2 a c s^2), F = (R_s + R_p) / 2.
  eta > 0, k >= 0; F(0) = 1 and F(1) = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2).
* ``dielectric`` (the facets of a dielectric, not a choice of FRESNEL): the exact unpolarised reflectance
  at an interface of relative index eta = n_t / n_i seen from the incident side, c_t^2 = 1 - (1 - c^2) /
  eta^2, R_s = (c - eta c_t) / (c + eta c_t), R_p = (eta c - c_t) / (eta c + c_t), F = (R_s^2 + R_p^2) / 2,
  and F = 1 where c_t^2 < 0 (total internal reflection, eta < 1).  eta > 0; F(1) = ((eta - 1) / (eta +
  1))^2, F(0) = 1.
"""

from __future__ import annotations

import jax.numpy as jnp

__all__ = ["FRESNEL", "fresnel_factor", "schlick", "conductor", "dielectric"]

FRESNEL = ("one", "schlick", "conductor")


def schlick(c, f0):
    """F0 + (1 - F0) (1 - c)^5."""
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def conductor(c, eta, k):
    """Exact conductor reflectance (module docstring) for eta + i k."""
    c = jnp.clip(c, 0.0, 1.0)
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = jnp.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = jnp.sqrt(jnp.maximum(0.0, 0.5 * (a2b2 + t0)))
    r_s = (a2b2 + c2 - 2.0 * a * c) / (a2b2 + c2 + 2.0 * a * c)
    num_p = c2 * a2b2 + s2 * s2 - 2.0 * a * c * s2
    den_p = c2 * a2b2 + s2 * s2 + 2.0 * a * c * s2
    r_p = r_s * jnp.where(den_p > 0.0, num_p / jnp.where(den_p > 0.0, den_p, 1.0), 1.0)
    return 0.5 * (r_s + r_p)


def dielectric(c, eta):
    """Exact dielectric reflectance (module docstring) for relative index eta, 1 beyond the critical angle."""
    c = jnp.clip(c, 0.0, 1.0)
    cos_t2 = ((eta - 1.0) * (eta + 1.0) + c * c) / (eta * eta)  # 1 - (1 - c^2) / eta^2 without cancellation
    tir = cos_t2 < 0.0
    cos_t = jnp.sqrt(jnp.where(tir, 0.0, cos_t2))
    den_s, den_p = c + eta * cos_t, eta * c + cos_t
    # both denominators vanish only at c = 0 with eta = 1 (no interface): F = 0 there, as the exact engine has it
    r_s = jnp.where(den_s > 0.0, (c - eta * cos_t) / jnp.where(den_s > 0.0, den_s, 1.0), 0.0)
    r_p = jnp.where(den_p > 0.0, (eta * c - cos_t) / jnp.where(den_p > 0.0, den_p, 1.0), 0.0)
    return jnp.where(tir, 1.0, 0.5 * (r_s * r_s + r_p * r_p))


def fresnel_factor(kind: str, c, f0, eta, k):
    """F(c) of ``kind`` in FRESNEL; unused parameters are ignored."""
    if kind == "one":
        return jnp.ones_like(c)
    if kind == "schlick":
        return schlick(c, f0)
    return conductor(c, eta, k)
