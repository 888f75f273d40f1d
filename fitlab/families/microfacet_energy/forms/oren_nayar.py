r"""Forms of E(mu, alpha) for Oren-Nayar (A with 0.33; and, through :func:`.common.complement`, of 1 - E),
mu and alpha in [0, 1], sigma = (pi/2) alpha radians (the blog's convention, that of the exact engine).

The model's coefficients, exact (Oren and Nayar's qualitative model, as the blog writes it):

    A(sigma) = 1 - sigma^2 / (2 (sigma^2 + 0.33)),    B(sigma) = 0.45 sigma^2 / (sigma^2 + 0.09).

The identity the forms use: E(mu, sigma) = A(sigma) + B(sigma) g(mu) exactly, with g independent of
sigma, since A and B only scale the two terms of the BRDF and the albedo integral is linear in them:

    g(mu) = (1/pi) int max(0, cos phi) sin(theta_max) tan(theta_min) mu_i dw_i
          = (2/pi) [ s (t - s mu)/2 + s mu (1 + s + s^2) / (3 (1 + s)) ],  t = acos(mu), s = sqrt(1 - mu^2)

(:mod:`fitlab.families.microfacet_energy.exact`), g(0) = 1/2, g(1) = 0, and g ~ (2/(3 pi)) s as mu -> 1: a
square-root cusp sqrt(2 (1 - mu)) at normal incidence, which no polynomial in mu follows and s P(mu)
does.  tests/test_microfacet_energy_targets.py checks the identity numerically with the engine's
independent direction route (not its closed form).  The same g serves A's 0.57 variant (only A changes).

* ``materialx_rational``: MaterialX ``mx_oren_nayar_diffuse_dir_albedo_analytic``,
  AcademySoftwareFoundation/MaterialX libraries/pbrlib/genglsl/lib/mx_microfacet_diffuse.glsl
  (Apache-2.0; added in 0926d76f, "Merge 1.39 development", 2024-05-30), "Rational quadratic fit to
  Monte Carlo data for Oren-Nayar directional albedo": r = (1, 1) + (-0.4297, -0.6076) sigma +
  (-0.7632, -0.4993) mu sigma + (1.4385, 2.0315) sigma^2, E = r.x / r.y, sigma its ``roughness`` in
  radians; intended for sigma in [0, 1] (alpha <= 2/pi), extrapolated beyond.  Its callers clamp the
  result to [0, 1]; the function itself does not, nor does this form.
* ``abg_cubic``: E = A + B s (g0 + g1 mu + g2 mu^2 + g3 mu^3), A and B exact: only g is fitted (four
  numbers).  Starts from g = s (1 - mu)/2, which has the exact ends g(0) = 1/2, g(1) = 0.
"""

from __future__ import annotations

import sympy as sp

from fitlab.families.microfacet_energy.forms.common import alpha, mu
from fitlab.forms import Form
from fitlab.physics.oren_nayar import oren_nayar_coefficients, oren_nayar_sigma

__all__ = ["SIGMA", "A_ON", "B_ON", "MATERIALX_ON", "e_forms", "materialx_rational", "abg_cubic"]

SIGMA = oren_nayar_sigma(alpha)
#: the qualitative Oren-Nayar's A (constant 0.33) and B, exact (:func:`fitlab.physics.oren_nayar.oren_nayar_coefficients`)
A_ON, B_ON = oren_nayar_coefficients(SIGMA, sp.Rational(33, 100))

#: MaterialX mx_oren_nayar_diffuse_dir_albedo_analytic (libraries/pbrlib/genglsl/lib/mx_microfacet_diffuse.glsl,
#: Apache-2.0): the vec2 of the sigma, mu sigma and sigma^2 terms
#: (x: numerator, y: denominator)
MATERIALX_ON = {"nx_s": -0.4297, "ny_s": -0.6076, "nx_ms": -0.7632, "ny_ms": -0.4993, "nx_s2": 1.4385, "ny_s2": 2.0315}


def materialx_rational(target: str) -> Form:
    nx_s, ny_s, nx_ms, ny_ms, nx_s2, ny_s2 = sp.symbols(tuple(MATERIALX_ON), real=True)
    s = SIGMA
    return Form(
        target=target,
        name="materialx_rational",
        inputs=("mu", "alpha"),
        params=tuple(MATERIALX_ON),
        expr=(1 + nx_s * s + nx_ms * mu * s + nx_s2 * s**2) / (1 + ny_s * s + ny_ms * mu * s + ny_s2 * s**2),
        presets={"materialx": dict(MATERIALX_ON)},
        description=(
            "MaterialX mx_oren_nayar_diffuse_dir_albedo_analytic: (1 + a1 sigma + a2 mu sigma + a3 sigma^2)/(1 + b1 sigma "
            "+ b2 mu sigma + b3 sigma^2), sigma = (pi/2) alpha (fitted for sigma <= 1, unclamped)"
        ),
    )


def abg_cubic(target: str) -> Form:
    g = sp.symbols(("g0", "g1", "g2", "g3"), real=True)
    s = sp.sqrt(1 - mu**2)
    return Form(
        target=target,
        name="abg_cubic",
        inputs=("mu", "alpha"),
        params=("g0", "g1", "g2", "g3"),
        expr=A_ON + B_ON * s * (g[0] + g[1] * mu + g[2] * mu**2 + g[3] * mu**3),
        start={"g0": 0.5, "g1": -0.5, "g2": 0.0, "g3": 0.0},
        description=(
            "A(sigma) + B(sigma) sqrt(1 - mu^2) (g0 + g1 mu + g2 mu^2 + g3 mu^3), A, B the exact Oren-Nayar "
            "coefficients (0.33), sigma = (pi/2) alpha: the exact E = A + B g(mu) with g fitted"
        ),
    )


def e_forms(target: str) -> tuple[Form, ...]:
    """Every form of the Oren-Nayar E target ``target``."""
    return materialx_rational(target), abg_cubic(target)
