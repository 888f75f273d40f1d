r"""Height-field baselines the Lambert-sphere BRDF is compared with
(docs/model.md, "Neighbouring models"),
each one sympy expression in (mu_i, mu_o, cos_phi, kd), f in 1/sr.

* Lambert: kd / pi.
* Oren-Nayar, the qualitative model (RTR ch. 9), facet-slope deviation sigma (radians):
  f = kd/pi (A + B max(0, cos phi) sin(alpha) tan(beta)),
  A = 1 - sigma^2 / (2 (sigma^2 + 0.33)), B = 0.45 sigma^2 / (sigma^2 + 0.09),
  alpha = max(theta_i, theta_o), beta = min(theta_i, theta_o); tan(beta) divides by
  max(mu_i, mu_o), floored at 1e-6 so that grazing pairs stay finite.
"""

from __future__ import annotations

import sympy as sp

from fitlab.forms.symbolic import symbols
from fitlab.physics import oren_nayar as physics

__all__ = ["BASELINE_INPUTS", "LAMBERT", "oren_nayar"]

BASELINE_INPUTS = ("mu_i", "mu_o", "cos_phi", "kd")
mu_i, mu_o, cos_phi, kd = symbols(BASELINE_INPUTS)

LAMBERT = kd / sp.pi


def oren_nayar(sigma=sp.Rational(1, 2)) -> sp.Expr:
    """kd times :func:`fitlab.physics.oren_nayar.oren_nayar` of the facet-slope deviation ``sigma`` (radians)."""
    a, b = physics.oren_nayar_coefficients(sp.nsimplify(sigma), sp.Rational(33, 100))
    return kd * physics.oren_nayar(mu_o, mu_i, cos_phi, a, b, "cos_phi", floor=sp.Rational(1, 10**6))
