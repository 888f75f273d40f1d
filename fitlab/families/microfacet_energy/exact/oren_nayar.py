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

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.exact.oren_nayar``."""

from __future__ import annotations

import numpy as np

from fitlab.families.microfacet_energy.exact._checks import choice, real_array, working_dtype
from fitlab.physics import oren_nayar as physics
from fitlab.physics.oren_nayar import AZIMUTH

__all__ = [
    "AZIMUTH",
    "A_CONSTANTS",
    "oren_nayar_coefficients",
    "oren_nayar_brdf",
    "albedo_closed_form",
    "average_albedo_closed_form",
    "azimuthal_constant",
]

A_CONSTANTS = (0.33, 0.57)


def _a_constant(a_constant) -> float:
    if isinstance(a_constant, bool) or not isinstance(a_constant, (int, float)) or float(a_constant) not in A_CONSTANTS:
        raise ValueError(
            f"a_constant must be 0.33 (the blog's A) or 0.57 (the 1992 footnote's), got {a_constant!r:.40}"
        )
    return float(a_constant)


def oren_nayar_coefficients(alpha, a_constant: float = 0.33):
    """(A, B) for sigma = (pi/2) alpha: A = 1 - sigma^2 / (2 (sigma^2 + a_constant)),
    B = 0.45 sigma^2 / (sigma^2 + 0.09); alpha in [0, 1]; (1, 0) at alpha = 0 (Lambert)."""
    dtype = working_dtype(alpha)
    alpha = real_array(alpha, "alpha", 0.0, 1.0, dtype=dtype)
    return physics.oren_nayar_coefficients(physics.oren_nayar_sigma(alpha), _a_constant(a_constant))


def oren_nayar_brdf(mu_o, mu_i, phi, alpha, a_constant: float = 0.33, azimuth: str = "cos_phi"):
    """The Oren-Nayar BRDF f (rho = 1) of docs/microfacet_energy_derivation.md, without the cos(theta_i) of the blog's
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
    """E(mu_o) = A + (2B/pi) [brackets] (docs/microfacet_energy_derivation.md); float64 arrays in, broadcast."""
    a, b = oren_nayar_coefficients(alpha, a_constant)
    return a + 2 * b / np.pi * _brackets(np.asarray(mu_o, dtype=float), azimuth)


def average_albedo_closed_form(alpha, a_constant: float, azimuth: str):
    """E_avg = 2 int_0^1 E mu dmu = A + B k (docs/microfacet_energy_derivation.md); float64 arrays in, broadcast."""
    a, b = oren_nayar_coefficients(alpha, a_constant)
    return a + b * azimuthal_constant(azimuth)


def azimuthal_constant(azimuth: str) -> float:
    """k = (4/pi) int_0^1 [brackets](mu) mu dmu: 2/3 - 64/(45 pi) (cos_phi), 44/(105 pi) (gamma)."""
    return 2 / 3 - 64 / (45 * np.pi) if azimuth == "cos_phi" else 44 / (105 * np.pi)
