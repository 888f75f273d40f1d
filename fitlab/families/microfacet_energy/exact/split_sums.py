r"""The split-sum DFG integrals of a microfacet BRDF under Schlick's Fresnel (Karis 2013).

With F = F0 + (F90 - F0) Fc, Fc = (1 - w_o . h)^5 (Schlick), the directional albedo of a GGX BRDF is linear
in F0 and F90:

    E_F(mu, alpha) = F0 A(mu, alpha) + F90 B(mu, alpha),
    A = int (f / F) (1 - Fc) mu_i dw_i,   B = int (f / F) Fc mu_i dw_i,

A and B each the directional albedo of :func:`directional_albedo` with the factor 1 - Fc or Fc inside the
integral, so by either of its routes; A + B = E(mu, alpha), the albedo with F = 1.  Karis's table stores
(A, B), the scale and bias of F0 with F90 = 1; Filament's multiple-scattering table stores (B, A + B) and reads
E_F = mix(B, A + B, F0) = (1 - F0) B + F0 (A + B), the same value with F90 = 1, its second channel E being what
the energy compensation 1 + F0 (1 / E - 1) needs.
"""

from __future__ import annotations

import numpy as np

from fitlab.families.microfacet_energy.exact.albedo import directional_albedo
from fitlab.physics import fresnel

__all__ = ["schlick_weight", "split_sum"]


def schlick_weight(cos):
    """Fc = (1 - cos)^5, Schlick's weight of F90 - F0, cos = w_o . h in [0, 1]
    (:func:`fitlab.physics.fresnel.schlick_weight`)."""
    return fresnel.schlick_weight(np.asarray(cos, dtype=np.float64))


def _one_minus_schlick_weight(cos):
    return 1.0 - schlick_weight(cos)


def split_sum(mu, alpha, model: str = "ggx_correlated", method: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(A, B): the scale and bias of F0 in the directional albedo of GGX ``model`` under Schlick's F with
    F90 = 1 (module docstring).  mu, alpha in [0, 1], broadcast; method: "half_vector" (default) or
    "direction", the two routes of :func:`directional_albedo`."""
    scale = directional_albedo(mu, alpha, model, method, fresnel=_one_minus_schlick_weight)
    bias = directional_albedo(mu, alpha, model, method, fresnel=schlick_weight)
    return scale, bias
