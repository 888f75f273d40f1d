r"""Microfacet distributions and Smith masking-shadowing: GGX (Trowbridge-Reitz) and Beckmann.

Conventions (Walter et al. 2007, Heitz 2014): mu = cos(theta) to the macro normal, alpha the roughness of D itself
(a2 = alpha^2; anisotropic surfaces see the roughness of the azimuth, :func:`lambda_roughness2` and
:func:`ndf_roughness2`).  A normal or half vector m enters D through x = m_x^2 + m_y^2 and z = m_z^2 (any length of
m: D depends on x / z = tan^2(theta_m) and |m|^2 = x + z only), which keeps the mirror direction free of
cancellation.  The closed forms below are finite at grazing where they can be; derivations: docs/architecture.md,
"One physics".
"""

from __future__ import annotations

from typing import Any

from fitlab.physics._namespace import namespace

__all__ = [
    "DISTRIBUTIONS",
    "ggx_ndf",
    "beckmann_ndf",
    "ndf",
    "ndf_roughness2",
    "lambda_roughness2",
    "ggx_root_term",
    "ggx_lambda",
    "beckmann_lambda",
    "smith_lambda",
    "ggx_g1",
    "ggx_g2",
    "ggx_visibility",
    "smith_g2_correlated",
    "smith_g2_transmission",
    "beckmann_g1_rational",
]

DISTRIBUTIONS = ("ggx", "beckmann")


def ggx_ndf(x: Any, z: Any, a2: Any) -> Any:
    """GGX D = a2 (x + z)^2 / (pi (a2 z + x)^2) of a normal m with x = m_x^2 + m_y^2, z = m_z^2 (int D mu_m dw_m =
    1 over the hemisphere); a2 = alpha^2 > 0."""
    xp = namespace(x, z, a2)
    return a2 * (x + z) ** 2 / (xp.pi * (a2 * z + x) ** 2)


def beckmann_ndf(x: Any, z: Any, a2: Any) -> Any:
    """Beckmann D = exp(-x / (a2 z)) (x + z)^2 / (pi a2 z^2) (x, z as :func:`ggx_ndf`; z > 0)."""
    xp = namespace(x, z, a2)
    return xp.exp(-x / (a2 * z)) * (x + z) ** 2 / (xp.pi * a2 * z * z)


def ndf_roughness2(mx: Any, my: Any, alpha_x: Any, alpha_y: Any) -> Any:
    """The alpha^2 that D sees along the azimuth of m, (m_x^2 + m_y^2) / ((m_x / alpha_x)^2 + (m_y / alpha_y)^2)
    (alpha_x alpha_y along the normal, where it does not matter)."""
    xp = namespace(mx, my, alpha_x, alpha_y)
    x = mx * mx + my * my
    return xp.ratio(x, (mx / alpha_x) ** 2 + (my / alpha_y) ** 2, alpha_x * alpha_y)


def lambda_roughness2(x: Any, y: Any, alpha_x: Any, alpha_y: Any) -> Any:
    """The alpha^2 that Lambda sees along the azimuth of w = (x, y, .), ((alpha_x x)^2 + (alpha_y y)^2) / (x^2 +
    y^2) (alpha_x alpha_y along the normal, where it does not matter)."""
    xp = namespace(x, y, alpha_x, alpha_y)
    return xp.ratio((alpha_x * x) ** 2 + (alpha_y * y) ** 2, x * x + y * y, alpha_x * alpha_y)


def ndf(mx: Any, my: Any, mz: Any, alpha_x: Any, alpha_y: Any, distribution: str) -> Any:
    """D(m) of the anisotropic ``distribution`` ("ggx" or "beckmann") for m_z > 0, normalised by int D m_z dw = 1:
    the isotropic D at the roughness of m's azimuth, times that alpha^2 / (alpha_x alpha_y)."""
    a2 = ndf_roughness2(mx, my, alpha_x, alpha_y)
    d = ggx_ndf if distribution == "ggx" else beckmann_ndf
    return d(mx * mx + my * my, mz * mz, a2) * (a2 / (alpha_x * alpha_y))


def ggx_root_term(mu: Any, a2: Any) -> Any:
    """S(mu) = sqrt(a2 + (1 - a2) mu^2) = mu sqrt(1 + a2 tan^2(theta)), the root of GGX's Lambda."""
    xp = namespace(mu, a2)
    return xp.sqrt(a2 + (1 - a2) * mu * mu)


def ggx_lambda(mu: Any, a2: Any, sin2: Any = None) -> Any:
    """Smith's Lambda of GGX for an upward direction, (S - mu) / (2 mu) written a2 sin^2 / (2 mu (S + mu)); sin2 =
    1 - mu^2 unless given (a walk's x^2 + y^2).  0 where a2 sin^2 = 0 (a mirror, the normal), +inf at mu = 0."""
    xp = namespace(mu, a2, sin2)
    if sin2 is None:
        sin2 = 1 - mu * mu
    num = a2 * sin2
    den = 2 * mu * (ggx_root_term(mu, a2) + mu)
    with xp.quiet():
        return xp.where(num == 0, 0, num / den)


def beckmann_lambda(mu: Any, a2: Any, sin2: Any = None) -> Any:
    """Smith's Lambda of Beckmann for an upward direction, (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2, a = mu /
    sqrt(a2 sin^2) (kept >= 0 against its cancellation at large a); sin2 as :func:`ggx_lambda`."""
    xp = namespace(mu, a2, sin2)
    if sin2 is None:
        sin2 = 1 - mu * mu
    num = a2 * sin2
    with xp.quiet():
        a = mu / xp.sqrt(xp.where(num > 0, num, 1))
        lam = (xp.exp(-a * a) / (a * xp.sqrt_pi) - xp.erfc(a)) / 2
        return xp.where(num > 0, xp.maximum(lam, 0), 0)


def smith_lambda(x: Any, y: Any, z: Any, alpha_x: Any, alpha_y: Any, distribution: str) -> Any:
    """Lambda of an upward unit direction w = (x, y, z), z > 0, of the anisotropic ``distribution``."""
    lam = ggx_lambda if distribution == "ggx" else beckmann_lambda
    return lam(z, lambda_roughness2(x, y, alpha_x, alpha_y), x * x + y * y)


def ggx_g1(mu: Any, a2: Any) -> Any:
    """Smith masking G1 = 1 / (1 + Lambda) = 2 mu / (mu + S(mu)); 1 where mu + S = 0 (a mirror at grazing)."""
    xp = namespace(mu, a2)
    return xp.ratio(2 * mu, mu + ggx_root_term(mu, a2), 1)


def ggx_g2(mu_o: Any, mu_i: Any, a2: Any, smith: str) -> Any:
    """Smith masking-shadowing G2 of GGX: "separable" G1(mu_i) G1(mu_o); "correlated" (height-correlated, RTR4 eq.
    9.31) 1 / (1 + Lambda_i + Lambda_o) = 2 mu_i mu_o / (mu_o S(mu_i) + mu_i S(mu_o)), 0 where both are grazing,
    1 for a2 = 0."""
    xp = namespace(mu_o, mu_i, a2)
    if smith == "separable":
        return ggx_g1(mu_o, a2) * ggx_g1(mu_i, a2)
    den = mu_o * ggx_root_term(mu_i, a2) + mu_i * ggx_root_term(mu_o, a2)
    return xp.where(a2 == 0, 1, xp.ratio(2 * mu_i * mu_o, den, 0))


def ggx_visibility(mu_o: Any, mu_i: Any, a2: Any, smith: str, times_mu_i: bool = False) -> Any:
    """V = G2 / (4 mu_i mu_o) of GGX (f = D V): separable 1 / ((mu_i + S_i)(mu_o + S_o)), correlated 1 / (2 (mu_o S_i
    + mu_i S_o)).  ``times_mu_i``: mu_i V, finite on [0, 1]^2 for a2 > 0 (correlated at mu_i = mu_o = 0: its limit
    along mu_o = 0, 1 / (2 S_o))."""
    xp = namespace(mu_o, mu_i, a2)
    s_o, s_i = ggx_root_term(mu_o, a2), ggx_root_term(mu_i, a2)
    num = mu_i if times_mu_i else 1
    if smith == "separable":
        return num / ((mu_o + s_o) * (mu_i + s_i))
    den = 2 * (mu_o * s_i + mu_i * s_o)
    if times_mu_i:
        with xp.quiet():
            return xp.ratio(mu_i, den, 1 / (2 * s_o))
    return 1 / den


def smith_g2_correlated(lambda_i: Any, lambda_o: Any) -> Any:
    """Height-correlated masking-shadowing of a reflection, 1 / (1 + Lambda_i + Lambda_o)."""
    return 1 / (1 + lambda_i + lambda_o)


def smith_g2_transmission(lambda_i: Any, lambda_o: Any) -> Any:
    """Height-correlated masking-shadowing of a refraction, B(1 + Lambda_i, 1 + Lambda_o) (Heitz 2014, section 6; B
    the Beta function; Lambda_o of the upward direction -w_o); 0 where either is infinite."""
    xp = namespace(lambda_i, lambda_o)
    return xp.beta(1 + lambda_i, 1 + lambda_o)


def beckmann_g1_rational(t: Any) -> Any:
    """Walter et al.'s (2007) rational approximation of Beckmann's G1 in t = alpha tan(theta) (the reciprocal of
    their a): (3.535 t + 2.181) / (t^2 + 2.276 t + 2.577) for t > 0.625, else 1 (within 0.35 %)."""
    xp = namespace(t)
    ratio = (3.535 * t + 2.181) / (t**2 + 2.276 * t + 2.577)
    return xp.where(t > 0.625, ratio, 1)
