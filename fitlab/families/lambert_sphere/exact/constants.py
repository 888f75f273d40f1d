r"""The constants of the exact three-term BRDF, from moments of H0 and H1.

Derivation (docs/derivation.md gives it in full).  The invariance principle for
Fourier order m of a half space with phase function sum_l varpi_l P_l gives, with
varpi_l^m = varpi_l (l-m)!/(l+m)! and Chandrasekhar's azimuth convention,

    4 pi (mu + mu0) f^m(mu, mu0) = (2 - delta_m0) sum_l (-1)^(l+m) varpi_l^m psi_l(mu) psi_l(mu0),
    psi_l(mu) = P_l^m(mu) + (-1)^(l+m) (2pi/(2-delta_m0)) mu int_0^1 f^m(mu, mu') P_l^m(mu') dmu'.

Multiplying the first line by P_k^m(mu0), integrating, and using the Legendre
recurrence gives, for l = m..N-1 with beta_kl = int_0^1 psi_k P_l^m,

    (2l+1) mu psi_l - (l-m+1) psi_(l+1) - (l+m) psi_(l-1)
        = (-1)^(l+m) (2l+1) (mu/2) sum_k (-1)^(k+m) varpi_k^m beta_kl psi_k(mu).

With the classical structure psi_l = H_m(mu) (1-mu^2)^(m/2) r_l(mu), r_l a
polynomial of degree <= N - m and r_l(0) = P_l^m(0)/(1)^(m/2) (because H(0) = 1 and
the integral term vanishes at mu = 0), beta_kl is a linear combination of the
moments alpha_n = int_0^1 H_m(mu) mu^n dmu, and the recurrence becomes a small
algebraic system for the coefficients of r_l, solved here by Newton's method.

Order 1, explicitly (r_1 = 1 + l mu, r_2 = b mu, m = b^2/9, gamma = alpha_1 - alpha_3,
delta = alpha_0 - alpha_2 of H1):  l = -(5c/64) b gamma,  b = 3 + c (delta + l gamma),
i.e. b = (3 + c delta)/(1 + 5 c^2 gamma^2/64); this reproduces the l and m solved
here to 4.4e-16 (c = 1e-6 .. 1).

The same structure yields two identities that involve no moment at all, used as
tests: Psi_m(mu) = (1/2) sum_l (-1)^(l+m) varpi_l^m (1-mu^2)^m r_l(mu) r_l(-mu)
(for m = 1 this is l^2 + 45 m / 64 = (45 + 20 c)/64), and A = Psi_0(0) = 69c/128,
E = the mu^4 coefficient of Psi_0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np
from numpy.polynomial import polynomial as P

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact.characteristic import check_albedo, lambert_sphere_characteristic
from fitlab.families.lambert_sphere.exact.hfunction import HSolution, solve_h
from fitlab.families.lambert_sphere.exact.phase import MAX_DEGREE, associated_legendre_reduced, legendre_weights

__all__ = ["constants", "mode_polynomials", "ModePolynomials", "CONSTANT_NAMES"]

CONSTANT_NAMES = ("H0_inf", "l", "m", "A", "B", "C", "D", "E", "F")


@dataclass(frozen=True)
class ModePolynomials:
    """r_l(mu) for one Fourier order, and the bilinear form they define.

    f^m(mu_i, mu_o) = H(mu_i) H(mu_o) g(mu_i) g(mu_o) / (mu_i + mu_o)
                      * sum_jk matrix[j, k] mu_i^j mu_o^k,
    g(mu) = (1 - mu^2)^(m/2), in fitlab's azimuth convention (phi = 0 backward;
    docs/model.md, "Conventions").
    """

    order: int
    c: float
    r: dict  # l -> coefficients (low -> high)
    matrix: np.ndarray
    residual: float
    #: ``matrix`` less its single-scattering part (the same sum with r_l = reduced P_l^m, the c -> 0 limit: the
    #: three-term single scattering of this order), summed from r_l - P_l^m.  It is O(c^2), and its mu^0 entry is 0
    #: exactly (r_l(0) is fixed); as the difference of the two O(c) matrices it would keep only eps c of rounding
    #: there, which at grazing (where the multiple-scattering numerator is O(c^2 mu)) outweighs the value for
    #: c below about 1e-10 (the BRDF came out negative at c = 1e-12)
    multiple: np.ndarray


def _beta(h_moments, m, rk, ell):
    q = P.polymul(P.polymul(rk, associated_legendre_reduced(ell, m)), P.polypow([1.0, 0.0, -1.0], m))
    return float(np.dot(q, h_moments[: q.size]))


def _residuals(x, m, w, alpha, frozen=()):
    ls = list(range(m, MAX_DEGREE + 1))
    deg = MAX_DEGREE - m
    r = {}
    i = 0
    for ell in ls:
        r0 = associated_legendre_reduced(ell, m)[0]
        if ell in frozen:
            r[ell] = np.zeros(deg + 1)
            continue
        r[ell] = np.concatenate(([r0], x[i : i + deg]))
        i += deg
    out = []
    for ell in ls[:-1]:
        beta = {k: _beta(alpha, m, r[k], ell) for k in ls}
        lhs = P.polysub(
            P.polymul([0.0, 2 * ell + 1.0], r[ell]),
            P.polyadd((ell - m + 1.0) * r[ell + 1], (ell + m) * r.get(ell - 1, np.zeros(1))),
        )
        s = np.zeros(1)
        for k in ls:
            s = P.polyadd(s, (-1.0) ** (k + m) * w[k] * beta[k] * r[k])
        rhs = P.polymul([0.0, (-1.0) ** (ell + m) * (2 * ell + 1) / 2.0], s)
        d = P.polysub(lhs, rhs)
        out.append(np.pad(d, (0, deg + 2 - d.size)))
    return np.concatenate(out) if out else np.zeros(0), r


def _default_start(m, frozen=()):
    # c -> 0 limit: r_l = reduced P_l^m
    deg = MAX_DEGREE - m
    ls = [ell for ell in range(m, MAX_DEGREE + 1) if ell not in frozen]
    return np.concatenate([np.pad(associated_legendre_reduced(ell, m), (0, deg + 1))[1 : deg + 1] for ell in ls])


def _newton(x, m, w, alpha, frozen=()):
    """Newton on the recurrence from start x; returns (x, max residual)."""
    if x.size == 0:
        return x, 0.0
    for _ in range(50):
        f, _ = _residuals(x, m, w, alpha, frozen)
        jac = np.empty((f.size, x.size))
        for j in range(x.size):
            step = 1e-7 * max(1.0, abs(x[j]))
            xp = x.copy()
            xp[j] += step
            xm = x.copy()
            xm[j] -= step
            jac[:, j] = (_residuals(xp, m, w, alpha, frozen)[0] - _residuals(xm, m, w, alpha, frozen)[0]) / (2 * step)
        dx = np.linalg.lstsq(jac, -f, rcond=None)[0]
        x = x + dx
        if np.max(np.abs(dx)) < 1e-15 * max(1.0, np.max(np.abs(x))):
            break
    f, _ = _residuals(x, m, w, alpha, frozen)
    return x, float(np.max(np.abs(f))) if f.size else 0.0


#: a converged solution has a residual at rounding level (~1e-16); Newton that
#: stalls far above this has not found the physical root and is never accepted
RESIDUAL_TOLERANCE = 1e-12

# Continuation ladder in s = sqrt(1 - c), fixed so that results do not depend on
# the order in which c values are asked for: 0.5, 0.48, ..., 0.02, then halving.
_LADDER = tuple(np.round(0.5 - 0.02 * np.arange(25), 12)) + tuple(0.02 / 2.0 ** np.arange(1, 40))


# Order 0 walks the ladder down to this point only (s = 6.25e-4); see _solve_unknowns.
_LADDER_STOP = 29


@cache
def _conservative_unknowns(m):
    # Order-0 unknowns at c = 1 from the regular frozen system, r_1 = 0 put back
    # in its place: the s = 0 end of the near-conservative start.
    x, _ = _solve_unknowns(m, 1.0, (1,))
    deg = MAX_DEGREE - m
    return np.concatenate([x[:deg], np.zeros(deg), x[deg:]])


def _moment_data(m, c):
    sol: HSolution = solve_h(lambert_sphere_characteristic(m, c))
    alpha = np.array([sol.moment(n) for n in range(2 * MAX_DEGREE + 2 * m + 1)])
    return legendre_weights(m, c), alpha


@cache
def _ladder_solution(m, k):
    """Converged unknowns at ladder point k, each from the one before (k = 0 directly)."""
    s = _LADDER[k]
    x = _default_start(m) if k == 0 else _ladder_solution(m, k - 1)
    x, res = _newton(x, m, *_moment_data(m, 1.0 - s * s))
    if res > RESIDUAL_TOLERANCE:
        raise RuntimeError(f"moment relations of order {m}: continuation failed at s = {s} (residual {res:.1e})")
    return x


def _solve_unknowns(m, c, frozen=()):
    """The r_l coefficients at albedo c.

    Newton from the c -> 0 limit is used for s = sqrt(1 - c) >= 0.5.  Closer to
    c = 1 (order 0 has a fold at c = 1) it can stall on a non-solution, so there
    the solution is continued along the fixed ladder in s from s = 0.5 down to
    the ladder point just above s, and Newton finishes from there.  At c = 1 the
    reduced (frozen) system is regular and solved directly.
    """
    w, alpha = _moment_data(m, c)
    s = np.sqrt(1.0 - c)
    # Speed (constants(1 - 1e-16) took 20 s cold, 92 H solves, one per
    # ladder point and order).  The ladder is walked only down to
    # _LADDER[_LADDER_STOP] = 6.25e-4; below it (0 < s < 6.25e-4):
    # * order 1 has no fold and starts from the c -> 0 limit (the same root as the
    #   ladder's, to 4e-16, on s in [1e-8, 0.5]);
    # * order 0: the branch is analytic in s (r_1 ~ s, the rest ~ s^2), so the
    #   straight line in s from the conservative solution (s = 0, regular) to the
    #   last ladder point is within O(s * 6e-4) of the root, inside Newton's basin
    #   on the physical branch.  Accuracy is that of the Newton solve itself (near
    #   the fold the equations fix the root only to ~eps/s): B(1 - 1e-16) is now
    #   2e-12 off its expansion in s, 1.4e-9 before.
    # Everywhere else (s >= 6.25e-4, and c = 1) the path is the old one, so the
    # values on the committed data grids (s = 0 and s >= 1/256; their sha256 is
    # recorded in fits/*.json) are unchanged bit for bit.
    if frozen or s >= _LADDER[0]:
        x = _default_start(m, frozen)
    elif s >= _LADDER[_LADDER_STOP] or s == 0.0:
        x = _ladder_solution(m, max(i for i, sk in enumerate(_LADDER) if sk >= s)).copy()
    elif m != 0:
        x = _default_start(m, frozen)
    else:
        x0, xk = _conservative_unknowns(m), _ladder_solution(m, _LADDER_STOP)
        x = x0 + (s / _LADDER[_LADDER_STOP]) * (xk - x0)
    x, res = _newton(x, m, w, alpha, frozen)
    if res > RESIDUAL_TOLERANCE:
        raise RuntimeError(f"moment relations of order {m} at c = {c!r}: no convergence (residual {res:.1e})")
    return x, res


@lru_cache(maxsize=4096, typed=True)  # typed: True or 0.5+0j must not hit the entries of 1 or 0.5 and skip the checks
def mode_polynomials(order: int, c: float) -> ModePolynomials:
    """Solve the moment relations of Fourier order ``order`` at albedo c."""
    order = _checks.fourier_order(order)
    c = _checks.real_scalar(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    c = float(c)
    m = order
    # At c = 1 the order-0 system has a fold: r_1 ~ sqrt(1 - c) and the Jacobian
    # is singular, so Newton would stop at sqrt(eps) ~ 1e-8.  There r_1 = 0
    # exactly (psi_1 vanishes in the conservative limit) and the remaining
    # system for r_0, r_2 is regular.
    frozen = (1,) if (m == 0 and c == 1.0) else ()
    x, res = _solve_unknowns(m, c, frozen)
    w, alpha = _moment_data(m, c)
    _, r = _residuals(x, m, w, alpha, frozen)
    deg = MAX_DEGREE - m
    matrix, multiple = np.zeros((deg + 1, deg + 1)), np.zeros((deg + 1, deg + 1))
    for ell, rl in r.items():
        rl = np.pad(rl, (0, deg + 1 - rl.size))
        pl = associated_legendre_reduced(ell, m)
        d = rl - np.pad(pl, (0, deg + 1 - pl.size))  # O(c); 0 at mu^0
        matrix += (-1.0) ** (ell + m) * w[ell] * np.outer(rl, rl)
        # r r^T - p p^T = d p^T + p d^T + d d^T = d r^T + r d^T - d d^T
        multiple += (-1.0) ** (ell + m) * w[ell] * (np.outer(d, rl) + np.outer(rl, d) - np.outer(d, d))
    # (2 - delta)/(4 pi) and (-1)^m for fitlab's azimuth (phi = 0 backward; docs/model.md)
    scale = (-1.0) ** m * (1.0 if m == 0 else 2.0) / (4.0 * np.pi)
    return ModePolynomials(m, c, r, matrix * scale, res, multiple * scale)


def _constants_scalar(c: float) -> dict:
    k0 = lambert_sphere_characteristic(0, c).k0
    m0 = mode_polynomials(0, c).matrix * 2.0 * np.pi
    r1 = mode_polynomials(1, c).r
    out = {
        "H0_inf": np.inf if k0 == 0.0 else 1.0 / np.sqrt(k0),
        "l": float(r1[1][1]),
        "m": float(r1[2][1] ** 2 / 9.0),
        "A": m0[0, 0],
        "B": m0[0, 1],
        "C": m0[1, 1],
        "D": m0[1, 2],
        "E": m0[2, 2],
        "F": m0[0, 2],
    }
    return out


def constants(c):
    """Exact constants of the three-term BRDF at particle albedo c in [0, 1].

    Returns a dict with keys H0_inf (eq. 32), l, m (eq. 22), A..F (eq. 30); each
    value has the shape of c.  Conventions, with the normalisations settled in
    docs/errata.md:

      f0 = H0(mu_i) H0(mu_o) / (2 pi (mu_i + mu_o)) * (A + B (mu_i + mu_o) + C mu_i mu_o
           + D mu_i mu_o (mu_i + mu_o) + E mu_i^2 mu_o^2 + F (mu_i^2 + mu_o^2))
      f1 = c H1(mu_i) H1(mu_o) S (1 + (l^2 + 45 m/64) mu_i mu_o + l (mu_i + mu_o))
           / (3 pi (mu_i + mu_o))

    (f1 with 3 pi, not the 6 pi printed in eq. 22).  H0_inf is inf at c = 1.
    """
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    c = check_albedo(c)
    flat = c.ravel()
    rows = [_constants_scalar(float(cv)) for cv in flat]
    return {k: np.array([row[k] for row in rows]).reshape(c.shape) for k in CONSTANT_NAMES}
