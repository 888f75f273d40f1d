r"""GGX (Trowbridge-Reitz) microfacet reflection with Smith masking-shadowing, F = 1 unless a
Fresnel factor is applied by the caller.

Conventions (those of the blog article, and of Walter et al. 2007 / Heitz 2014):

* mu = cos(theta) to the macro normal n; alpha is the GGX roughness *parameter itself*, the
  alpha of D below (the blog writes alpha^2 in D and in the masking term and calls alpha "the
  roughness"; it does not square a perceptual roughness, so no alpha = roughness^2 remapping
  is applied here).  alpha in (0, 1]; alpha = 0 is the mirror, handled by the albedo functions.
* phi is the azimuth between w_i and w_o, so that w_i . w_o = mu_i mu_o + s_i s_o cos(phi),
  s = sqrt(1 - mu^2): phi = pi is the mirror configuration.
* D(m) = alpha^2 / (pi ((alpha^2 - 1) mu_m^2 + 1)^2), with int D(m) mu_m dw_m = 1.
* Lambda(mu) = (-1 + sqrt(1 + alpha^2 tan^2 theta)) / 2 = (S(mu) - mu) / (2 mu),
  S(mu) = sqrt(alpha^2 + (1 - alpha^2) mu^2); G1 = 1 / (1 + Lambda) = 2 mu / (mu + S).
* separable Smith: G2 = G1(mu_i) G1(mu_o) (the blog's GGX);
  height-correlated Smith (RTR4 eq. 9.31): G2 = 1 / (1 + Lambda(mu_i) + Lambda(mu_o))
  = 2 mu_i mu_o / (mu_o S(mu_i) + mu_i S(mu_o)).
* f = D(h) G2 / (4 mu_i mu_o) = D(h) V, with the visibility V = G2 / (4 mu_i mu_o):
  separable V = 1 / ((mu_i + S(mu_i)) (mu_o + S(mu_o))), exactly the blog's two bracketed
  factors; correlated V = 1 / (2 (mu_o S(mu_i) + mu_i S(mu_o))).

The half vector h = (w_i + w_o)/|w_i + w_o| enters D only through tan^2(theta_h) = X / Z with
X = |w_i,t + w_o,t|^2 = (s_o - s_i)^2 + 4 s_o s_i cos^2(phi/2) (tangential parts) and
Z = (mu_i + mu_o)^2, so that D = alpha^2 (X + Z)^2 / (pi (alpha^2 Z + X)^2).  This form has no
cancellation near the mirror direction (the blog's mu_h = (mu_o + mu_i) / sqrt(2 (1 + mu_o mu_i
+ s_o s_i cos phi)) subtracts nearly equal numbers there) and evaluates in float32 to float32
accuracy.  (The blog prints the product (1 - mu_o^2)(1 - mu_i^2) under its mu_h without the
square root; s_o s_i is meant.)
"""

from __future__ import annotations

import numpy as np

from fitlab.families.microfacet_energy.exact._checks import choice, real_array, working_dtype
from fitlab.physics import microfacet

__all__ = ["SMITH", "ggx_ndf", "smith_lambda", "smith_g1", "smith_g2", "ggx_brdf"]

SMITH = ("separable", "correlated")


def _cosines(values, names, dtype):
    return [real_array(v, n, 0.0, 1.0, dtype=dtype) for v, n in zip(values, names)]


def _alpha(alpha, dtype, open_lo=True):
    return real_array(
        alpha,
        "alpha",
        0.0,
        1.0,
        open_lo=open_lo,
        dtype=dtype,
        domain="(0, 1] (GGX roughness; alpha = 0 is the mirror)" if open_lo else None,
    )


def ggx_ndf(mu_m, alpha):
    """GGX normal distribution D(m) = alpha^2 / (pi ((alpha^2 - 1) mu_m^2 + 1)^2), mu_m in [0, 1],
    alpha in (0, 1]; normalised by int D(m) mu_m dw_m = 1 over the hemisphere (:func:`fitlab.physics.microfacet.ggx_ndf`
    of x = 1 - mu_m^2, z = mu_m^2)."""
    dtype = working_dtype(mu_m, alpha)
    (mu_m,) = _cosines((mu_m,), ("mu_m",), dtype)
    alpha = _alpha(alpha, dtype)
    mu2 = mu_m * mu_m
    return np.asarray(microfacet.ggx_ndf((1 - mu_m) * (1 + mu_m), mu2, alpha * alpha), dtype=dtype)


def smith_lambda(mu, alpha):
    """Smith's Lambda for GGX, (S(mu) - mu) / (2 mu) = alpha^2 (1 - mu^2) / (2 mu (S(mu) + mu)).

    mu in [0, 1], alpha in [0, 1]: Lambda(0) = inf for alpha > 0; Lambda = 0 for alpha = 0
    (a mirror masks nothing; also at mu = 0, the limit alpha -> 0 at fixed mu > 0).
    """
    dtype = working_dtype(mu, alpha)
    (mu,) = _cosines((mu,), ("mu",), dtype)
    alpha = _alpha(alpha, dtype, open_lo=False)
    return np.asarray(microfacet.ggx_lambda(mu, alpha * alpha), dtype=dtype)


def smith_g1(mu, alpha):
    """Smith masking G1 = 1 / (1 + Lambda) = 2 mu / (mu + S(mu)); mu, alpha in [0, 1].
    G1(0) = 0 for alpha > 0; G1 = 1 for alpha = 0 (at mu = 0 too, as for Lambda)."""
    dtype = working_dtype(mu, alpha)
    (mu,) = _cosines((mu,), ("mu",), dtype)
    alpha = _alpha(alpha, dtype, open_lo=False)
    return np.asarray(microfacet.ggx_g1(mu, alpha * alpha), dtype=dtype)


def smith_g2(mu_o, mu_i, alpha, smith: str = "separable"):
    """Smith masking-shadowing G2 for the visible half of the half-vector hemisphere.

    smith="separable": G1(mu_i) G1(mu_o); "correlated": 1 / (1 + Lambda_i + Lambda_o)
    = 2 mu_i mu_o / (mu_o S(mu_i) + mu_i S(mu_o)).  mu_o, mu_i, alpha in [0, 1]; G2 = 1 at
    alpha = 0, G2 = 0 when either direction is grazing and alpha > 0.
    """
    smith = choice(smith, "smith", SMITH)
    dtype = working_dtype(mu_o, mu_i, alpha)
    mu_o, mu_i = _cosines((mu_o, mu_i), ("mu_o", "mu_i"), dtype)
    alpha = _alpha(alpha, dtype, open_lo=False)
    return np.asarray(microfacet.ggx_g2(mu_o, mu_i, alpha * alpha, smith), dtype=dtype)


def ggx_brdf(mu_o, mu_i, phi, alpha, smith: str = "separable"):
    """The GGX BRDF f = D(h) G2 / (4 mu_i mu_o) with F = 1 (see the module for the conventions).

    mu_o, mu_i in [0, 1], phi in [0, 2 pi] (phi = pi: mirror), alpha in (0, 1]; broadcast.
    Reciprocal: f(mu_o, mu_i) = f(mu_i, mu_o).  When every argument is a numpy float32 value the
    evaluation is in float32 (as a shader would), otherwise in float64.  Both directions grazing:
    h is horizontal, D = alpha^2 / pi, for every phi (at w_i = -w_o, phi = pi, where h does not exist,
    this limit along the horizon is returned); there the correlated V = 1 / (2 (mu_o S_i + mu_i S_o))
    and f are infinite, the separable ones finite.  For the blog's separable form this is exactly its
    product of three brackets (with mu_h from the half vector).
    """
    smith = choice(smith, "smith", SMITH)
    dtype = working_dtype(mu_o, mu_i, phi, alpha)
    mu_o, mu_i = _cosines((mu_o, mu_i), ("mu_o", "mu_i"), dtype)
    phi = real_array(phi, "phi", 0.0, 2 * np.pi, dtype=dtype, domain="[0, 2 pi]")
    alpha = _alpha(alpha, dtype)
    s_o, s_i = np.sqrt(1 - mu_o * mu_o), np.sqrt(1 - mu_i * mu_i)
    with np.errstate(divide="ignore", invalid="ignore"):
        # s_o - s_i without cancellation: (mu_i^2 - mu_o^2) / (s_o + s_i)
        diff = np.where(s_o + s_i > 0, (mu_i - mu_o) * (mu_i + mu_o) / (s_o + s_i), 0)
        x = diff * diff + 4 * s_o * s_i * np.cos(phi / 2) ** 2
        z = (mu_o + mu_i) ** 2
        a2 = alpha * alpha
        d = microfacet.ggx_ndf(x, z, a2)
        v = microfacet.ggx_visibility(mu_o, mu_i, a2, smith)
    return np.asarray(d * v, dtype=dtype)
