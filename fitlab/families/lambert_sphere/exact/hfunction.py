r"""Exact H-functions of the three-term half space, by two independent methods.

For a characteristic function Psi (see :mod:`characteristic`), H is the solution
of Chandrasekhar's equation

    H(u) = 1 + u H(u) \int_0^1 Psi(v) H(v) / (u + v) dv,      u in [0, inf].

Method ``"chandrasekhar"`` (default): Nystrom discretisation of the better
conditioned twin equation

    1/H(u) = sqrt(K(0)) + \int_0^1 v Psi(v) H(v) / (u + v) dv

on a graded composite Gauss rule, solved by Newton's method (fixed-point warm
start); H at any u then follows from the same formula (Nystrom interpolation).
At c = 1, order 0, sqrt(K(0)) = 0 and H grows like u; Newton still converges
quadratically from the warm start because the twin equation, unlike the plain
one, has an isolated root there (tested, including 1 - 1e-12).

Method ``"fock"``: the Fock/Krein closed form (paper eq. 16) with t = e^x / u,

    log H(u) = -(1/pi) \int_{-inf}^{inf} log K(e^x) / (2 cosh(x + log u)) dx,

summed by the trapezoidal rule.  The integrand is analytic in the strip
|Im x| < pi/2 (the poles of 1/cosh, the branch points of atan, and the zeros of
K, including the near-conservative pair t = +-i sqrt(K(0)/J(0)), all lie on its
edge), so the error falls like exp(-pi^2/h): h = 0.1 gives far below 1e-16.  The
log singularity of K at t = 0 when c = 1 only makes the left tail decay like
x e^x instead of e^x.  No iteration, no Jacobian: the two methods share nothing
but Psi.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact._quadrature import graded_gauss
from fitlab.families.lambert_sphere.exact.characteristic import (
    Characteristic,
    check_albedo,
    check_order,
    lambert_sphere_characteristic,
)

__all__ = ["h_function", "HSolution", "solve_h", "h_fock", "METHODS"]

METHODS = ("chandrasekhar", "fock")


@dataclass(frozen=True)
class HSolution:
    """Nystrom solution of the H-equation: H at the nodes of a quadrature rule."""

    char: Characteristic
    nodes: np.ndarray
    weights: np.ndarray
    h_nodes: np.ndarray
    newton_steps: int
    residual: float

    @property
    def sqrt_k0(self) -> float:
        return float(np.sqrt(self.char.k0))

    def _sums(self, u):
        v, w = self.nodes, self.weights
        psi_h = w * self.char(v) * self.h_nodes
        u = np.asarray(u, dtype=float)
        flat = u.ravel()
        finite = np.isfinite(flat)
        inv_uv = np.zeros((flat.size, v.size))
        inv_uv[finite] = 1.0 / (flat[finite, None] + v[None, :])
        return u.shape, flat, finite, inv_uv, psi_h

    def __call__(self, u):
        """H(u) for u in [0, inf]."""
        shape, flat, finite, inv_uv, psi_h = self._sums(u)
        return self._h(flat, finite, inv_uv, psi_h).reshape(shape)

    def _h(self, flat, finite, inv_uv, psi_h):
        denom = self.sqrt_k0 + inv_uv @ (self.nodes * psi_h)
        with np.errstate(divide="ignore"):
            out = 1.0 / denom
        out[~finite] = np.inf if self.sqrt_k0 == 0.0 else 1.0 / self.sqrt_k0
        out[flat == 0.0] = 1.0  # exact; the Nystrom sum gives it to one ulp
        return out

    def h_minus_one_over_u(self, u):
        """(H(u) - 1)/u without cancellation: H(u) int Psi H/(u+v) dv.

        Diverges like -Psi(0) log u as u -> 0; returns inf at u = 0 when
        Psi(0) != 0.
        """
        shape, flat, finite, inv_uv, psi_h = self._sums(u)
        h = self._h(flat, finite, inv_uv, psi_h)  # the same sums as self(u), not formed twice
        out = h * (inv_uv @ psi_h)
        zero = flat == 0.0
        if np.any(zero):
            p0 = self.char.coefficients[0]
            out[zero] = np.sign(p0) * np.inf if p0 != 0.0 else 0.0
        out[~finite] = 0.0
        return out.reshape(shape)

    def moment(self, n: int) -> float:
        """alpha_n = int_0^1 H(u) u^n du."""
        return float(self.weights @ (self.h_nodes * self.nodes**n))


def _newton(char: Characteristic, v, w, tol=1e-15, max_steps=60):
    s = np.sqrt(char.k0)
    a = (w * v * char(v))[None, :] / (v[:, None] + v[None, :])
    x = np.ones_like(v)
    # A few damped fixed-point sweeps put Newton inside its basin even at c = 1.
    for _ in range(8):
        x = 1.0 / (s + a @ x)
    steps = 0
    res = np.inf
    for steps in range(1, max_steps + 1):  # noqa: B007 (the count of steps taken is returned)
        f = 1.0 / x - s - a @ x
        jac = -np.diag(1.0 / x**2) - a
        dx = np.linalg.solve(jac, -f)
        x = x + dx
        res = float(np.max(np.abs(dx / x)))
        if res < tol:
            break
    f = 1.0 / x - s - a @ x
    return x, steps, float(np.max(np.abs(f * x)))


@lru_cache(maxsize=4096)
def _solve_cached(coefficients: tuple, k0: float, n: int, ratio: float) -> HSolution:
    char = Characteristic(coefficients, k0)
    v, w = graded_gauss(n, ratio)
    if char.is_zero:
        return HSolution(char, v, w, np.ones_like(v), 0, 0.0)
    h, steps, res = _newton(char, v, w)
    h.setflags(write=False)
    return HSolution(char, v, w, h, steps, res)


def solve_h(char: Characteristic, nodes_per_panel: int = 16, ratio: float = 0.25) -> HSolution:
    """Nystrom/Newton solution of the H-equation for ``char`` (cached)."""
    _checks.characteristic(char, Characteristic)
    nodes_per_panel = _checks.positive_int(nodes_per_panel, "nodes_per_panel")
    ratio = _checks.real_scalar(ratio, "ratio", 0.0, 1.0, domain="(0, 1)", open_ends=True)
    return _solve_cached(tuple(float(p) for p in char.coefficients), float(char.k0), nodes_per_panel, ratio)


def h_fock(char: Characteristic, u, h: float = 0.1):
    """H(u) from the Fock/Krein integral (paper eq. 16), trapezoidal in log t."""
    _checks.characteristic(char, Characteristic)
    u = _checks.real_array(u, "u", 0.0, np.inf)
    h = _checks.real_scalar(h, "h", 0.0, np.inf, domain="(0, inf)", open_ends=True)
    u = np.asarray(u, dtype=float)
    out = np.ones(u.shape)
    if char.is_zero:
        return out
    inf = np.isinf(u)
    out[inf] = np.inf if char.k0 == 0.0 else 1.0 / np.sqrt(char.k0)
    pos = (u > 0.0) & ~inf
    if not np.any(pos):
        return out
    up = u[pos]
    centre = -np.log(up)
    lo = np.floor((min(centre.min(), 0.0) - 52.0) / h) * h
    hi = np.ceil((max(centre.max(), 0.0) + 46.0) / h) * h
    x = np.arange(lo, hi + 0.5 * h, h)
    log_k = char.log_k(np.exp(x))
    # 1/(2 cosh(x - centre)), written to avoid overflow
    d = np.abs(x[None, :] - centre[:, None])
    weight = np.exp(-d) / (1.0 + np.exp(-2.0 * d))
    out[pos] = np.exp(-(h / np.pi) * (weight @ log_k))
    return out


def _check_mu(mu) -> np.ndarray:
    mu = np.asarray(mu, dtype=float)
    if np.any(np.isnan(mu)) or np.any(mu < 0.0):
        raise ValueError("mu must lie in [0, inf] (a direction cosine; inf gives H(inf))")
    return mu


def h_function(order, mu, c, method: str = "chandrasekhar"):
    """Exact H-function H_m(mu; c) of the three-term Lambert-sphere half space.

    order: Fourier order m in {0, 1, 2} (characteristic function Psi_m, paper
    eqs. 13-15).  mu in [0, inf]: H(0) = 1 and mu = inf gives
    H_m(inf) = K_m(0)^(-1/2) (paper eq. 32 for m = 0; infinite at c = 1).
    c in [0, 1], both ends included.  mu and c broadcast.

    method: "chandrasekhar" (Nystrom + Newton on the twin integral equation) or
    "fock" (Fock/Krein integral).  They agree to about 1e-13 relative
    (tests/test_hfunction.py).
    """
    order = _checks.fourier_order(order)
    method = _checks.choice(method, "method", METHODS)
    mu = _checks.real_array(mu, "mu", 0.0, np.inf)
    c = _checks.real_array(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    order = check_order(order)
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    mu = _check_mu(mu)
    c = check_albedo(c)
    mu, c = np.broadcast_arrays(mu, c)
    out = np.empty(mu.shape)
    for cv in np.unique(c):
        sel = c == cv
        char = lambert_sphere_characteristic(order, cv)
        if method == "chandrasekhar":
            out[sel] = solve_h(char)(mu[sel])
        else:
            out[sel] = h_fock(char, mu[sel])
    return out
