r"""The Fresnel factor of one microfacet reflection in the walk: :mod:`fitlab.physics.fresnel` in ``jax.numpy``.

c = cos of the angle between the direction and the facet normal, in [0, 1] (clipped: rounding of w . m).

* ``"one"``: F = 1 (the white furnace).
* ``"schlick"``: F = F0 + (1 - F0) (1 - c)^5, F0 in [0, 1].
* ``"conductor"``: the exact unpolarised reflectance of a conductor of complex relative index eta + i k;
  eta > 0, k >= 0; F(0) = 1 and F(1) = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2).

The facets of a dielectric (not a choice of FRESNEL) reflect with the exact dielectric F,
:func:`fitlab.physics.fresnel.fresnel_dielectric` (1 beyond the critical angle).
"""

from __future__ import annotations

import jax.numpy as jnp

from fitlab.physics import fresnel

__all__ = ["FRESNEL", "fresnel_factor", "dielectric"]

FRESNEL = ("one", "schlick", "conductor")


def dielectric(c, eta):
    """The exact dielectric reflectance for relative index eta, 1 beyond the critical angle; c clipped to [0, 1]."""
    return fresnel.fresnel_dielectric(jnp.clip(c, 0.0, 1.0), eta)


def fresnel_factor(kind: str, c, f0, eta, k):
    """F(c) of ``kind`` in FRESNEL; unused parameters are ignored."""
    if kind == "one":
        return jnp.ones_like(c)
    c = jnp.clip(c, 0.0, 1.0)
    if kind == "schlick":
        return fresnel.fresnel_schlick(c, f0)
    return fresnel.fresnel_conductor(c, eta, k)
