r"""The Lambert-sphere phase function and its three-term truncation.

p(u) = 2 (sqrt(1 - u^2) - u acos u) / (3 pi^2)   (paper eq. 1), u the cosine of
the scattering angle, normalised to 1 over the sphere, mean cosine -4/9.
Legendre form p(u) = (1/4pi) sum_k A_k P_k(u) with A = 1, -4/3, 5/16, 0, 1/64, ...
(eq. 4).  The three-term model keeps A_0..A_2: c p ~ (w0 + w1 P1 + w2 P2)/(4pi),
w = c (1, -4/3, 5/16) (eq. 8).

Azimuthal decomposition used throughout (phi = 0 is back-scattering; docs/model.md, "Conventions"):
for u = -(mu_i mu_o + S cos phi), S = sqrt((1-mu_i^2)(1-mu_o^2)),

    P_l(u) = sum_m (2 - delta_m0) (l-m)!/(l+m)! (-1)^l P_l^m(mu_i) P_l^m(mu_o) cos(m phi)

(P_l^m without the Condon-Shortley phase).
"""

from __future__ import annotations

from math import factorial

import numpy as np

from fitlab.physics import lambert_sphere as physics
from fitlab.physics.lambert_sphere import LEGENDRE_A

__all__ = [
    "LEGENDRE_A",
    "THREE_TERM",
    "phase_function",
    "three_term_phase_function",
    "legendre_weights",
    "associated_legendre_reduced",
]

THREE_TERM = LEGENDRE_A[:3]
MAX_DEGREE = 2


def phase_function(u):
    """p(u) of a Lambertian sphere (paper eq. 1; :func:`fitlab.physics.lambert_sphere.phase_function`), u in
    [-1, 1]; 1/sr."""
    return physics.phase_function(np.clip(np.asarray(u, dtype=float), -1.0, 1.0))


def three_term_phase_function(u):
    """(1/4pi)(1 - (4/3) u + (5/16) P_2(u)): the truncation the BRDF derivation uses."""
    return physics.three_term_phase_function(np.asarray(u, dtype=float))


def legendre_weights(m: int, c) -> dict:
    """varpi_l^m = c A_l (l-m)!/(l+m)! for l = m..2 (index l)."""
    return {
        ell: np.asarray(c) * THREE_TERM[ell] * factorial(ell - m) / factorial(ell + m)
        for ell in range(m, MAX_DEGREE + 1)
    }


# P_l^m(mu) = (1 - mu^2)^(m/2) * reduced_l^m(mu); coefficients low -> high.
_REDUCED = {
    (0, 0): (1.0,),
    (1, 0): (0.0, 1.0),
    (2, 0): (-0.5, 0.0, 1.5),
    (1, 1): (1.0,),
    (2, 1): (0.0, 3.0),
    (2, 2): (3.0,),
}


def associated_legendre_reduced(ell: int, m: int) -> np.ndarray:
    """Polynomial coefficients of P_l^m(mu) / (1 - mu^2)^(m/2), low to high."""
    return np.array(_REDUCED[(ell, m)])
