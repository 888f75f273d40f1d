r"""The Oren-Nayar diffuse BRDF in its qualitative form, as the blog article on multiple scattering writes it.

f = (1/pi) [A + B max(0, c) sin(theta_max) tan(theta_min)] (rho = 1), sigma = (pi/2) alpha; c = cos(phi) ("cos_phi")
or gamma = s_o s_i cos(phi) (the blog's HLSL shortcut, "gamma").  Conventions and the albedo's closed form:
:mod:`fitlab.families.microfacet_energy.exact` (the blog's displayed formula carries the cos(theta_i) of the
integrand; this BRDF does not).
"""

from __future__ import annotations

from typing import Any

from fitlab.physics._namespace import namespace

__all__ = ["AZIMUTH", "oren_nayar_sigma", "oren_nayar_coefficients", "oren_nayar"]

AZIMUTH = ("cos_phi", "gamma")


def oren_nayar_sigma(alpha: Any) -> Any:
    """sigma = (pi/2) alpha radians: the roughness alpha in [0, 1] of the blog's convention as Oren and Nayar's
    standard deviation of the facet slopes."""
    xp = namespace(alpha)
    return xp.pi / 2 * alpha


def oren_nayar_coefficients(sigma: Any, a_constant: Any) -> tuple[Any, Any]:
    """(A, B) = (1 - sigma^2 / (2 (sigma^2 + a_constant)), 0.45 sigma^2 / (sigma^2 + 0.09)), sigma in radians;
    a_constant 0.33 (Oren and Nayar's, the blog's) or 0.57 (their footnote's variant)."""
    xp = namespace(sigma, a_constant)
    sigma2 = sigma**2
    return 1 - sigma2 / (2 * (sigma2 + a_constant)), xp.rational(45, 100) * sigma2 / (sigma2 + xp.rational(9, 100))


def oren_nayar(mu_o: Any, mu_i: Any, cos_phi: Any, a: Any, b: Any, azimuth: str, floor: Any = None) -> Any:
    """f (rho = 1) from cos(phi) and the coefficients (A, B); theta_max has the smaller cosine.  Where both
    directions are grazing tan(theta_min) is infinite and f = inf where B max(0, c) > 0; ``floor``: a least
    max(mu_o, mu_i), which keeps f finite there."""
    xp = namespace(mu_o, mu_i, cos_phi, a, b)
    mu_lo, mu_hi = xp.minimum(mu_o, mu_i), xp.maximum(mu_o, mu_i)
    if floor is not None:
        mu_hi = xp.maximum(mu_hi, floor)
    c = cos_phi if azimuth == "cos_phi" else cos_phi * xp.sqrt((1 - mu_o * mu_o) * (1 - mu_i * mu_i))
    lobe = b * xp.maximum(0, c)
    with xp.quiet():
        term = xp.sqrt(1 - mu_lo * mu_lo) * xp.sqrt(1 - mu_hi * mu_hi) / mu_hi
        out = a + xp.nonneg_times(lobe, term)
    return out / xp.pi
