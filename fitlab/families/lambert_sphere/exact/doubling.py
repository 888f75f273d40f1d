r"""Second, independent route to the three-term half space: discrete ordinates
with doubling.  No H-function, no invariance principle, no moment relation.

For Fourier order m the radiative transfer equation on a graded Gauss rule
{mu_i, w_i} reads d/dtau [I+; I-] = [[a, -b], [b, -a]] [I+; I-], with
a = M^-1 (1 - P+), b = M^-1 P-, P+-_ij = (1/2) Phi^m(mu_i, +-mu_j) w_j and
Phi^m(mu, mu') = sum_l varpi_l^m P_l^m(mu) P_l^m(mu').  A layer of thickness
tau_0 = 2^-60 is solved by single scattering with exact exponentials; doubling
(R' = R + T R (1 - R R)^-1 T, T' = T (1 - R R)^-1 T) then builds slabs of
thickness tau_0 2^k, the direct beam exp(-tau/mu) kept apart from the diffuse
transmission so that no digit is lost, until R stops changing (tau up to 2^55, far beyond the
diffusion length even at c = 1 - 1e-12; at c = 1 the reflection deficit of a
slab falls like 1/tau).  The BRDF at node pairs is

    f^m(mu_i, mu_j) = (2 - delta_m0) (-1)^m R_ij / (2 pi mu_j w_j)

((-1)^m turns Chandrasekhar's azimuth into fitlab's, phi = 0 backward;
docs/model.md, "Conventions").  This is the reflection of the discretised
problem: it converges to the exact BRDF as the rule is refined.  On the default
rule it agrees with the H-function route at node pairs mu >= 1e-3 to 4.0e-14
(c = 0.5), 7.2e-14 (c = 0.99), 1.6e-9 (c = 1 - 1e-12) and 9.5e-8 (c = 1); the loss
near c = 1 is doubling's own (its plane albedo at c = 1 is 1 - 8.2e-8).  The
tests bound it by 1e-11, and 3e-7 at c = 1.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from fitlab.families.lambert_sphere.exact._quadrature import graded_gauss
from fitlab.families.lambert_sphere.exact.phase import associated_legendre_reduced, legendre_weights

__all__ = ["doubling_reflection", "doubling_step", "DoublingResult"]


@dataclass(frozen=True)
class DoublingResult:
    order: int
    c: float
    nodes: np.ndarray
    weights: np.ndarray
    brdf: np.ndarray  # f^m at (nodes[i], nodes[j]), fitlab's azimuth convention (phi = 0 backward)
    thickness: float
    doublings: int


def _assoc(ell, m, mu):
    return (1.0 - mu * mu) ** (m / 2.0) * np.polynomial.polynomial.polyval(mu, associated_legendre_reduced(ell, m))


def doubling_step(r: np.ndarray, td: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One doubling of a symmetric slab: its reflection R and diffuse transmission T_d from those of
    the half slab (d: the half slab's direct transmission exp(-tau/mu_j), kept apart so that no digit is
    lost): with G = (1 - R R)^-1 and T = T_d + diag(d), R' = R + T R G T and
    T_d' = d R R G d + T_d G d + d G T_d + T_d G T_d (the direct beam's part d d leaves T_d')."""
    eye = np.eye(r.shape[0])
    g = np.linalg.solve(eye - r @ r, eye)
    t = td + np.diag(d)
    r_new = r + t @ (r @ g) @ t
    rrg = r @ r @ g
    td_new = d[:, None] * rrg * d[None, :] + (td @ g) * d[None, :] + d[:, None] * (g @ td) + td @ g @ td
    return r_new, td_new


@lru_cache(maxsize=256)
def doubling_reflection(order: int, c: float, nodes_per_panel: int = 12, smallest: float = 1e-7) -> DoublingResult:
    """Half-space reflection of Fourier order m by discrete ordinates + doubling."""
    m = int(order)
    c = float(c)
    mu, w = graded_gauss(nodes_per_panel, 0.25, smallest)
    wl = legendre_weights(m, c)
    phi_pp = sum(wl[ell] * np.outer(_assoc(ell, m, mu), _assoc(ell, m, mu)) for ell in wl)
    phi_pm = sum(wl[ell] * (-1.0) ** (ell + m) * np.outer(_assoc(ell, m, mu), _assoc(ell, m, mu)) for ell in wl)
    # Thin starting layer: single scattering with exact exponentials; the
    # neglected double scattering is O(tau sum_k w_k/mu_k) ~ 1e-16 relative.
    tau = 2.0**-60
    inv = 1.0 / mu
    r = 0.5 * phi_pm * (w * mu)[None, :] / (mu[:, None] + mu[None, :]) * -np.expm1(-tau * (inv[:, None] + inv[None, :]))
    x = tau * (inv[:, None] - inv[None, :])
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(x == 0.0, 1.0, np.expm1(x) / x)
    td = 0.5 * phi_pp * w[None, :] * (tau * inv)[:, None] * np.exp(-tau * inv)[:, None] * rel
    d = np.exp(-tau * inv)  # direct transmission, kept apart from the diffuse part
    k = 0
    while True:
        k += 1
        r_new, td = doubling_step(r, td, d)
        tau *= 2.0
        d = np.exp(-tau * inv)  # not d*d: exp(-2^-60/mu) rounds to 1
        change = np.max(np.abs(r_new - r))
        r = r_new
        if (change <= 1e-17 * np.max(np.abs(r)) and tau > 1e3) or tau > 2.0**55:
            break
    f = (1.0 if m == 0 else 2.0) * (-1.0) ** m * r / (2.0 * np.pi * (mu * w)[None, :])
    return DoublingResult(m, c, mu, w, f, tau, k)
