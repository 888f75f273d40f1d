r"""The Oren-Nayar diffuse BRDF as the blog article writes it, its directional albedo in closed form
and the closed form of its average albedo.

The BRDF (rho = 1, the white furnace):

    f = (1/pi) [A + B max(0, c(phi)) sin(theta_max) tan(theta_min)],
    sigma = (pi/2) alpha, A = 1 - sigma^2 / (2 (sigma^2 + a_constant)), B = 0.45 sigma^2 / (sigma^2 + 0.09),

theta_max = max(theta_i, theta_o), theta_min = min(theta_i, theta_o), alpha in [0, 1] (sigma in
[0, pi/2]).  a_constant = 0.33 is the blog's A; 0.57 is the footnote variant (1992 paper, p. 22)
that the blog's HLSL comment offers "to simulate the missing inter-reflection term".  Two forms of
the azimuthal factor c(phi):

* azimuth="cos_phi": c = cos(phi), phi the azimuth between w_i and w_o (the paper's and the blog's
  formula, cos(phi_o - phi_i));
* azimuth="gamma": c = gamma = (v - n (v.n)) . (l - n (l.n)) = s_o s_i cos(phi), the blog's HLSL
  shortcut, which skips the division by s_o s_i (its comment says so).  The HLSL's 1e-6 added to
  cos(theta_min) only guards a division by zero in float and is not modelled here.

Convention: the blog's displayed f_r(theta_o, phi_o, theta_i, phi_i) = (rho/pi) cos(theta_i) [...]
already carries the cos(theta_i) of the irradiance integrand (its HLSL returns saturate(LdotN)
(A + ...) and its caller divides by pi); the BRDF here is that expression divided by
cos(theta_i), so that E(mu_o) = int f mu_i dw_i, and sigma = 0 is Lambert's 1/pi with E = 1.

Directional albedo in closed form (the phi integral of max(0, cos phi) over [0, 2 pi] is 2; split the
theta_i integral at theta_o, where theta_min and theta_max swap; t = theta_o, s = sin t, c = cos t):

    cos_phi: E = A + (2B/pi) [ s (t - s c) / 2 + s c (1 + s + s^2) / (3 (1 + s)) ]
    gamma:   E = A + (2B/pi) [ s^2 (1 - c)^2 (2 + c) / 3 + s^2 c (1 + s^2) / 4 ]

(the second bracket terms are tan(t) (1 - s^3)/3 and tan(t) s (1 - s^4)/4 written without the
0 * inf at t = pi/2).  At grazing E(0) = A + B/2 (cos_phi) and A + 4B/(3 pi) (gamma); at normal
incidence E(1) = A.  The average albedo E_avg = 2 int_0^1 E mu dmu = A + B k integrates the
brackets exactly (by parts; tests/test_microfacet_energy_exact.py redoes it with sympy):

    cos_phi: k = 2/3 - 64 / (45 pi),    gamma: k = 44 / (105 pi).

This Oren-Nayar is not energy conserving for small roughness.  A + kappa B > 1 exactly when
sigma^2 < (0.45 kappa a_constant - 0.045) / (0.5 - 0.45 kappa), so with kappa = 1/2 (cos_phi) or
4/(3 pi) (gamma) the grazing albedo E(0) exceeds 1 for alpha < 0.208 (cos_phi, 0.33), 0.350 (cos_phi,
0.57), 0.154 (gamma, 0.33), 0.289 (gamma, 0.57), by up to 1.5 % and 4.4 % (cos_phi, 0.33 and 0.57;
0.6 % and 2.9 % with gamma); with kappa = k,
E_avg exceeds 1 for the 0.57 cos_phi variant only, for alpha < 0.0996 (by up to 0.1 %).
(tests/test_microfacet_energy_exact.py checks these thresholds against the engine.)
"""

from __future__ import annotations

import numpy as np

from fitlab.families.microfacet_energy.exact._checks import choice, real_array, working_dtype
from fitlab.physics import oren_nayar as physics
from fitlab.physics.oren_nayar import AZIMUTH

__all__ = ["AZIMUTH", "A_CONSTANTS", "oren_nayar_coefficients", "oren_nayar_brdf", "albedo_closed_form",
           "average_albedo_closed_form", "azimuthal_constant"]

A_CONSTANTS = (0.33, 0.57)


def _a_constant(a_constant) -> float:
    if isinstance(a_constant, bool) or not isinstance(a_constant, (int, float)) or float(a_constant) not in A_CONSTANTS:
        raise ValueError(f"a_constant must be 0.33 (the blog's A) or 0.57 (the 1992 footnote's), "
                         f"got {a_constant!r:.40}")
    return float(a_constant)


def oren_nayar_coefficients(alpha, a_constant: float = 0.33):
    """(A, B) for sigma = (pi/2) alpha: A = 1 - sigma^2 / (2 (sigma^2 + a_constant)),
    B = 0.45 sigma^2 / (sigma^2 + 0.09); alpha in [0, 1]; (1, 0) at alpha = 0 (Lambert)."""
    dtype = working_dtype(alpha)
    alpha = real_array(alpha, "alpha", 0.0, 1.0, dtype=dtype)
    return physics.oren_nayar_coefficients(physics.oren_nayar_sigma(alpha), _a_constant(a_constant))


def oren_nayar_brdf(mu_o, mu_i, phi, alpha, a_constant: float = 0.33, azimuth: str = "cos_phi"):
    """The Oren-Nayar BRDF f (rho = 1) of the module docstring, without the cos(theta_i) of the blog's
    displayed formula.

    mu_o, mu_i in [0, 1], phi in [0, 2 pi], alpha in [0, 1]; broadcast.  Reciprocal.  When both
    directions are grazing (mu_o = mu_i = 0) tan(theta_min) is infinite and f = inf where
    B max(0, c) > 0 (f mu_i stays bounded, by sin(theta_max) sin(theta_min) <= 1 times B/pi).  float32
    arguments evaluate in float32.
    """
    azimuth = choice(azimuth, "azimuth", AZIMUTH)
    dtype = working_dtype(mu_o, mu_i, phi, alpha)
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0, dtype=dtype)
    mu_i = real_array(mu_i, "mu_i", 0.0, 1.0, dtype=dtype)
    phi = real_array(phi, "phi", 0.0, 2 * np.pi, dtype=dtype, domain="[0, 2 pi]")
    a, b = oren_nayar_coefficients(alpha, a_constant)
    return np.asarray(physics.oren_nayar(mu_o, mu_i, np.cos(phi), a, b, azimuth), dtype=dtype)


def _brackets(mu_o, azimuth):
    """The two theta_i pieces of the closed form (without 2B/pi), stable on [0, 1]."""
    c = mu_o
    s = np.sqrt(1 - c * c)
    if azimuth == "cos_phi":
        t = np.arctan2(s, c)
        return s * (t - s * c) / 2 + s * c * (1 + s + s * s) / (3 * (1 + s))
    return s * s * (1 - c) ** 2 * (2 + c) / 3 + s * s * c * (1 + s * s) / 4


def albedo_closed_form(mu_o, alpha, a_constant: float, azimuth: str):
    """E(mu_o) = A + (2B/pi) [brackets] (module docstring); float64 arrays in, broadcast."""
    a, b = oren_nayar_coefficients(alpha, a_constant)
    return a + 2 * b / np.pi * _brackets(np.asarray(mu_o, dtype=float), azimuth)


def average_albedo_closed_form(alpha, a_constant: float, azimuth: str):
    """E_avg = 2 int_0^1 E mu dmu = A + B k (module docstring); float64 arrays in, broadcast."""
    a, b = oren_nayar_coefficients(alpha, a_constant)
    return a + b * azimuthal_constant(azimuth)


def azimuthal_constant(azimuth: str) -> float:
    """k = (4/pi) int_0^1 [brackets](mu) mu dmu: 2/3 - 64/(45 pi) (cos_phi), 44/(105 pi) (gamma)."""
    return 2 / 3 - 64 / (45 * np.pi) if azimuth == "cos_phi" else 44 / (105 * np.pi)
