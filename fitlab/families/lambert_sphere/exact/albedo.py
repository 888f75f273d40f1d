r"""Directional and spherical albedos of the exact BRDFs.

Three BRDFs (``phase=``, as :func:`fitlab.families.lambert_sphere.exact.brdf`; which albedo kd refers to:
docs/model.md, "Albedo maps"):

* ``phase="three_term"``: the exact half space with the three-term phase
  function, all orders.  a(mu_i) = 2 pi int_0^1 f0(mu_i, mu_o) mu_o dmu_o;
  only order 0 survives the azimuthal integral.  a = 1 at c = 1 (conservation).
* ``phase="mixed"``: exact single scattering
  with the true phase function plus the three-term multiple scattering:
  a_mixed = a_three_term + c (a1(mu_i) - a1_3(mu_i)), with a1, a1_3 the
  single-scattering albedos per unit c of the true and three-term phase
  functions.  The paper's runtime model (f_1 + fm0 + fm1 cos phi, clamped at 0)
  with exact ingredients has the same albedo as "mixed": fm1 cos phi and the
  dropped fm2 cos 2 phi integrate to zero over phi, and the clamp never acts
  (tests/test_brdf.py checks f_1 + fm0 + fm1 cos phi > 0 on a grid).
* ``phase="true"`` (the default): the whole phase function in every collision, below.

Details: docs/derivation.md, section ``fitlab.families.lambert_sphere.exact.albedo``."""

from __future__ import annotations

import warnings
from functools import cache

import numpy as np

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact._quadrature import graded_gauss
from fitlab.families.lambert_sphere.exact.brdf import PHASES, check_cosines, check_phase, single_scattering_modes
from fitlab.families.lambert_sphere.exact.characteristic import check_albedo, lambert_sphere_characteristic
from fitlab.families.lambert_sphere.exact.constants import mode_polynomials
from fitlab.families.lambert_sphere.exact.hfunction import solve_h
from fitlab.physics.lambert_sphere import phase_function_of_angle, three_term_phase_function

__all__ = [
    "albedo",
    "spherical_albedo",
    "single_scattering_albedo",
    "single_albedo_nodes",
    "three_term_single_albedo",
    "SINGLE_PHASES",
]

#: the phase functions of a single collision: the true one and the paper's three-term approximation
SINGLE_PHASES = ("true", "three_term")


def _arc_integral(mu_i: float, theta: float) -> float:
    """int over the visible part of the cone (angle theta about w_i) of mu_o/(mu_i + mu_o) dpsi."""
    sin_i = np.sqrt(max(0.0, 1.0 - mu_i * mu_i))
    a = mu_i * np.cos(theta)
    b = np.sin(theta) * sin_i
    alpha = mu_i + a
    if b <= 0.0:
        return 2.0 * np.pi * a / alpha if a > 0.0 else 0.0
    if a >= b:
        return 2.0 * np.pi - 2.0 * np.pi * mu_i / np.sqrt((alpha - b) * (alpha + b))
    if a <= -b:
        return 0.0
    psi0 = np.arccos(-a / b)
    if mu_i == 0.0:
        return 2.0 * psi0
    x = np.sqrt((b + a) / (b - a))  # tan(psi0 / 2)
    z = (alpha - b) / (alpha + b) * x * x
    if abs(z) < 1e-4:
        f = 1.0 - z / 3.0 + z * z / 5.0 - z**3 / 7.0
    elif z > 0.0:
        f = np.arctan(np.sqrt(z)) / np.sqrt(z)
    else:
        y = np.sqrt(-z)
        one_minus_y2 = 2.0 * b * mu_i / ((b + alpha) * (b - a))  # 1 - y^2 without cancellation
        f = 0.5 * np.log((1.0 + y) ** 2 / one_minus_y2) / y
    return 2.0 * psi0 - mu_i * 4.0 * x / (alpha + b) * f


def _three_term_of_angle(theta):
    """p3 at u = -cos(theta) (:func:`fitlab.physics.lambert_sphere.three_term_phase_function`)."""
    return three_term_phase_function(-np.cos(theta))


def single_scattering_albedo(mu_i: float, phase: str = "true") -> float:
    """a1(mu_i): directional albedo of single scattering per unit c."""
    mu_i = _checks.real_scalar(mu_i, "mu_i", 0.0, 1.0)
    phase = _checks.choice(phase, "phase", SINGLE_PHASES)
    # scipy is imported where it is used: the engine's import stays light for the commands that only read the
    # cached exact values (fitlab refit: about a third of a second)
    from scipy import integrate

    p = phase_function_of_angle if phase == "true" else _three_term_of_angle
    theta_i = np.arccos(mu_i)
    edges = sorted({0.0, max(0.0, np.pi / 2 - theta_i), min(np.pi, np.pi / 2 + theta_i)})
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        if hi > lo:
            with warnings.catch_warnings():
                # 1e-14 is below what quad can certify; its estimate is still ~1e-15.
                warnings.simplefilter("ignore", integrate.IntegrationWarning)
                val, _ = integrate.quad(
                    lambda t: p(t) * _arc_integral(mu_i, t) * np.sin(t), lo, hi, epsabs=1e-15, epsrel=1e-14, limit=200
                )
            total += val
    return total


@cache
def single_albedo_nodes(phase: str):
    """a1 at the graded nodes (c-independent, computed once)."""
    phase = _checks.choice(phase, "phase", SINGLE_PHASES)
    v, _ = graded_gauss(8, 0.25, 1e-14)
    return np.array([single_scattering_albedo(float(x), phase) for x in v])


def _three_term_albedo(mu_i, c):
    sol = solve_h(lambert_sphere_characteristic(0, c))
    v, w, hv = sol.nodes, sol.weights, sol.h_nodes
    mat = mode_polynomials(0, c).matrix
    vi = np.stack([mu_i**j for j in range(3)], axis=-1)
    vo = np.stack([v**j for j in range(3)], axis=-1)
    q = vi @ mat @ vo.T  # (n_mu, n_nodes), includes 1/(2 pi) of f0
    integral = (q * (w * hv * v)[None, :] / (mu_i[:, None] + v[None, :])) @ np.ones_like(v)
    return 2.0 * np.pi * sol(mu_i) * integral


def three_term_single_albedo(mu_i):
    """a1_3(mu_i) per unit c, from the order-0 single-scattering mode."""
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    if mu_i.ndim != 1:
        raise ValueError(f"mu_i must be a 1-D array of cosines in [0, 1], got shape {mu_i.shape}")
    v, w = graded_gauss(16, 0.25, 1e-17)
    f0 = single_scattering_modes(mu_i[:, None], v[None, :], 1.0)[0]
    return 2.0 * np.pi * (f0 * (w * v)[None, :]).sum(axis=1)


def albedo(mu_i, c, phase: str | None = None):
    """Directional albedo a(mu_i) = int f(w_i, w_o) mu_o dw_o of an exact BRDF.

    phase (default :data:`DEFAULT_PHASE`, "true": the whole phase function in every collision), "mixed"
    (true phase function in single scattering, three-term multiple scattering), "three_term"
    (the exact three-term half space).
    mu_i in [0, 1], c in [0, 1]; broadcast.  The true single-scattering albedo is one
    adaptive quadrature per distinct mu_i.
    """
    phase = check_phase(phase, PHASES)
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    (mu_i,) = check_cosines(mu_i, names=("mu_i",))
    c = check_albedo(c)
    mu_i, c = np.broadcast_arrays(mu_i, c)
    out = np.empty(mu_i.shape)
    extra = None
    if phase != "three_term":
        flat = mu_i.ravel()
        uniq, inv = np.unique(flat, return_inverse=True)
        a1 = np.array([single_scattering_albedo(float(x)) for x in uniq])
        if phase == "true":
            a1 = a1[inv].reshape(mu_i.shape)
            from fitlab.families.lambert_sphere.exact import true_phase

            for cv in np.unique(c):
                sel = c == cv
                out[sel] = cv * a1[sel] + true_phase.multiple_scattering_albedo(mu_i[sel], float(cv))
            return out
        extra = (a1 - three_term_single_albedo(uniq))[inv].reshape(mu_i.shape)
    for cv in np.unique(c):
        sel = c == cv
        out[sel] = _three_term_albedo(mu_i[sel], float(cv))
        if extra is not None:
            out[sel] += cv * extra[sel]
    return out


def spherical_albedo(c, phase: str | None = None):
    """Spherical (Bond) albedo kd = 2 int_0^1 a(mu_i) mu_i dmu_i; ``phase`` as in :func:`albedo`.  In [0, 1]:
    at c = 1, where kd = 1 (nothing is absorbed), the quadrature's rounding can land a few ulps above 1, and an
    excess of at most :data:`KD_ROUNDING` is returned as 1 (a larger one is an error of the quadrature, kept for
    the tests to see)."""
    out = _spherical_albedo(c, phase)
    out[(out > 1.0) & (out <= 1.0 + KD_ROUNDING)] = 1.0
    return out


#: the excess over 1 that :func:`spherical_albedo` takes for rounding: 16 ulps of 1
KD_ROUNDING = 16 * np.finfo(float).eps


def _spherical_albedo(c, phase):
    phase = check_phase(phase, PHASES)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    c = check_albedo(c)
    v, w = graded_gauss(8, 0.25, 1e-14)
    correction = 0.0
    if phase == "true":
        from fitlab.families.lambert_sphere.exact import true_phase

        out = np.empty(c.shape)
        a1 = single_albedo_nodes("true")
        for idx, cv in np.ndenumerate(c):
            a = cv * a1 + true_phase.multiple_scattering_albedo(v, float(cv))
            out[idx] = 2.0 * np.dot(w * v, a)
        return out
    if phase == "mixed":
        correction = 2.0 * np.dot(w * v, single_albedo_nodes("true") - three_term_single_albedo(v))
    out = np.empty(c.shape)
    for idx, cv in np.ndenumerate(c):
        out[idx] = 2.0 * np.dot(w * v, _three_term_albedo(v, float(cv))) + cv * correction
    return out
