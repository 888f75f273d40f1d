r"""The half space of Lambertian spheres with the WHOLE phase function: multiple
scattering by Fourier order in azimuth, by two independent methods.

fitlab's three-term engine (:mod:`brdf`, :mod:`hfunction`) solves the half space
whose phase function is cut to A_0..A_2 in every collision.  This module solves
the half space of the material itself.  Single scattering has its closed form
c p(u)/(mu_i + mu_o) (eq. 10) and is not computed here; what is computed is the
multiple scattering, order by order in azimuth, with the phase function's
Legendre series

    p(u) = (1/4pi) sum_k A_k P_k(u),  A_k = 4 (2k+1) (-1)^k lambda_k^2,  lambda_k = int_0^1 x P_k(x) dx

(the phase function is the spherical autocorrelation of the clamped cosine;
lambda_0..2 = 1/2, 1/3, 1/8, lambda_k = 0 for odd k >= 3 and
lambda_{k+2} = -lambda_k (k-1)/(k+4) for even k, :func:`legendre_moments`), cut at
degree L = :data:`DEGREE` = 256 in the multiple scattering (single scattering keeps the
whole p).  A_k ~ (16/pi) k^-4; the multiple scattering of the degree-L half space
converges to the true one like L^-4.7 away from grazing and L^-4.1 at grazing (measured,
below).

Details: docs/derivation.md, section ``fitlab.families.lambert_sphere.exact.true_phase``."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact.doubling import doubling_step
from fitlab.numerics import single_threaded_blas
from fitlab.physics.lambert_sphere import LEGENDRE_A

__all__ = [
    "DEGREE",
    "METHODS",
    "PHASES",
    "legendre_moments",
    "node_rule",
    "INTERPOLATION_RULE",
    "interpolation_panels",
    "assoc_normalised",
    "OrderSolution",
    "solve_order",
    "needed_orders",
    "multiple_scattering_orders",
    "multiple_scattering_sum",
    "multiple_scattering_albedo",
    "clear_cache",
]

#: Legendre degree after the first collision (A_k ~ k^-4; error ~ L^-4.7: docs/derivation.md).
DEGREE = 256
METHODS = ("newton", "doubling")
#: phase functions this module can solve: the whole one ("true") and the paper's cut ("three_term").
PHASES = ("true", "three_term")
#: relative size (to order 0, over the nodes >= 1e-3) below which a Fourier order of the multiple scattering
#: is dropped: the orders dropped sum to at most 1.5e-12 of the BRDF (docs/derivation.md)
ORDER_TOLERANCE = 1e-12
#: at most this many Fourier orders (more than ever needed; the order loop stops earlier)
MAX_ORDERS = 96


def legendre_moments(degree: int, phase: str = "true") -> np.ndarray:
    """A_0..A_degree of p(u) = (1/4pi) sum A_k P_k(u).

    "true": A_k = 4 (2k+1) (-1)^k lambda_k^2, lambda_k = int_0^1 x P_k(x) dx, from
    lambda_0..2 = 1/2, 1/3, 1/8, lambda_odd>=3 = 0, lambda_{k+2} = -lambda_k (k-1)/(k+4).
    "three_term": 1, -4/3, 5/16 and zeros.
    """
    degree = int(degree)
    phase = _checks.choice(phase, "phase", PHASES)
    a = np.zeros(degree + 1)
    if phase == "three_term":
        a[: min(3, degree + 1)] = LEGENDRE_A[: min(3, degree + 1)]
        return a
    lam = np.zeros(degree + 1)
    lam[0] = 0.5
    if degree >= 1:
        lam[1] = 1.0 / 3.0
    if degree >= 2:
        lam[2] = 0.125
    for k in range(2, degree - 1, 2):
        lam[k + 2] = -lam[k] * (k - 1) / (k + 4)
    k = np.arange(degree + 1)
    return 4.0 * (2 * k + 1) * (-1.0) ** k * lam**2


def _geometric_edges(ratio: float, smallest: float) -> np.ndarray:
    """0, then ratio^J, ..., ratio, 1 with ratio^J <= ``smallest``: the panels' edges of :func:`node_rule`."""
    n_panels = int(np.ceil(np.log(smallest) / np.log(ratio)))
    return np.concatenate(([0.0], ratio ** np.arange(n_panels, -1, -1.0)))


def node_rule(degree: int, per_panel: int = 12, ratio: float = 0.25, smallest: float = 1e-10):
    """Composite Gauss rule on [0, 1]: panels [ratio^(j+1), ratio^j] down to ``smallest``, then [0, ratio^J].

    Each panel of length h gets max(per_panel, per_panel + ceil(0.6 degree h)) nodes (the Legendre
    functions of degree L oscillate about L h / pi times on it).  Increasing nodes.
    """
    edges = _geometric_edges(ratio, smallest)
    xs, ws = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        n = max(per_panel, int(np.ceil(per_panel + 0.6 * degree * (b - a))))
        x, w = np.polynomial.legendre.leggauss(n)
        xs.append(a + 0.5 * (b - a) * (x + 1.0))
        ws.append(0.5 * (b - a) * w)
    return np.concatenate(xs), np.concatenate(ws)


def assoc_normalised(m: int, degree: int, mu) -> np.ndarray:
    """Q_l^m(mu) = sqrt((l-m)!/(l+m)!) P_l^m(mu) (no Condon-Shortley phase), rows l = m..degree.

    Stable recurrences: Q_m^m = prod_j sqrt((2j-1)/(2j)) (1-mu^2)^(m/2), Q_{m+1}^m = sqrt(2m+1) mu Q_m^m,
    Q_l^m = ((2l-1) mu Q_{l-1}^m - sqrt((l-1)^2 - m^2) Q_{l-2}^m) / sqrt(l^2 - m^2).
    """
    mu = np.asarray(mu, dtype=float)
    s = np.sqrt((1.0 - mu) * (1.0 + mu))
    out = np.zeros((degree - m + 1,) + mu.shape)
    if degree < m:
        return out
    q = np.ones_like(mu)
    for j in range(1, m + 1):
        q = q * s * np.sqrt((2.0 * j - 1.0) / (2.0 * j))
    out[0] = q
    if degree > m:
        out[1] = np.sqrt(2.0 * m + 1.0) * mu * q
    for ell in range(m + 2, degree + 1):
        out[ell - m] = (
            (2 * ell - 1) * mu * out[ell - 1 - m] - np.sqrt((ell - 1.0) ** 2 - m * m) * out[ell - 2 - m]
        ) / np.sqrt(ell * ell - m * m)
    return out


@dataclass(frozen=True)
class OrderSolution:
    """The discrete half space of Fourier order m: R at the nodes and what the Nystrom step needs."""

    order: int
    c: float
    method: str
    phase: str
    degree: int
    nodes: np.ndarray
    weights: np.ndarray
    moments: np.ndarray  # c-free A_l, l = m..degree (index l - m)
    q_nodes: np.ndarray  # Q_l^m at the nodes (m = 0: even l >= 2 orthogonalised to 1), rows l - m
    r: np.ndarray  # R(mu_i, mu_j), the whole reflection function of the discrete problem (symmetric)
    iterations: int
    smallest: float
    km: np.ndarray  # K-(mu_i, mu_j) = k(mu_i, -mu_j), c-free
    a1: np.ndarray  # A1 = E - (c/2) K+ W - (c/4) M R W K- W at the solution (the Nystrom step's matrix)
    #: (theta, V, V^-1) of M^-1 A1 at a late Newton iterate, or None where A1 is near the identity
    #: (high orders): the preconditioner of the Nystrom step (:func:`_rows`)
    rates: tuple | None = None

    @property
    def signs(self):
        return (-1.0) ** (np.arange(self.order, self.degree + 1) + self.order)

    @property
    def single(self):
        """Single scattering of the discrete problem at node pairs, c k(mu_i, -mu_j)/(mu_i + mu_j)."""
        mu = self.nodes
        return self.c * self.km / (mu[:, None] + mu[None, :])


def _kernels(moments, signs, q):
    """K+ = sum_l A_l Q_l Q_l^T and K- (the same with (-1)^(l+m)) on the nodes (a matrix product: numpy's
    einsum over three operands does not use BLAS and cost 20 times more here)."""
    kp = (q * moments[:, None]).T @ q
    km = (q * (moments * signs)[:, None]).T @ q
    return kp, km


def _node_vectors(m, degree, moments, mu, w):
    q = assoc_normalised(m, degree, mu)
    if m == 0:
        q = q.copy()
        total = w.sum()
        for ell in range(2, degree + 1, 2):
            q[ell] -= (q[ell] @ w) / total
    return q


def _closed_loop(c, mu, w, kp, km, r):
    """A1 = E - (c/2) K+ W - (c/4) M R W K- W."""
    n = mu.size
    return np.eye(n) - 0.5 * c * kp * w[None, :] - 0.25 * c * mu[:, None] * ((r * w[None, :]) @ (km * w[None, :]))


def _residual(c, mu, w, kp, km, r):
    # R, K+ and K- are symmetric, so K+ W R = (R W K+)^T
    rw = r * w[None, :]
    rwk = mu[:, None] * (rw @ kp)
    return (
        mu[:, None] * r
        + r * mu[None, :]
        - 0.5 * c * (rwk + rwk.T)
        - 0.25 * c * mu[:, None] * (rw @ (km * w[None, :]) @ r) * mu[None, :]
        - c * km
    )


def _conserve(r, s):
    """Symmetric rank-2 correction so that R s = 1 exactly (c = 1, m = 0)."""
    e = 1.0 - r @ s
    a = s / (s @ s)
    return r + np.outer(e, a) + np.outer(a, e) - np.outer(a, a) * (e @ s)


def _rates(a1, mu):
    """(theta, V, V^-1): the eigen-decomposition of M^-1 A1."""
    theta, v = np.linalg.eig(a1 / mu[:, None])
    vi = np.linalg.inv(v)
    if np.all(theta.imag == 0.0) and np.all(v.imag == 0.0):
        theta, v, vi = theta.real, v.real, vi.real
    return theta, v, vi


#: a step that reduces the residual by less than this factor makes the next step refresh the decomposition
_SLOW = 1e-2


def _newton(c, mu, w, kp, km, critical, max_steps=40):
    """Inexact Newton on the bounded Riccati residual.  The Sylvester step A1 D M + M D A1^T = -F is solved
    through a decomposition of M^-1 A1: at first the identity's (A1 = E, D = -F/(mu_i + mu_j), exact as the
    kernel vanishes; at high orders A_l, l >= m, are so small that this alone converges in a few steps), and
    the eigen-decomposition at the current iterate whenever a step reduced the residual by less than
    :data:`_SLOW`.  Returns R, the number of steps and the last decomposition (None: the identity's)."""
    s = 0.5 * mu * w
    r = c * km / (mu[:, None] + mu[None, :])
    scale = max(float(np.max(np.abs(c * km))), 1e-300)
    best = (np.inf, r, 0)
    rates = None
    previous = np.inf
    steps = 0
    for steps in range(1, max_steps + 1):
        if critical:
            r = _conserve(r, s)
        f = _residual(c, mu, w, kp, km, r)
        res = float(np.max(np.abs(f))) / scale
        if res < best[0]:
            best = (res, r, steps)
        if res < 4e-16 or (steps > 3 and res > 0.5 * best[0] and best[0] < 1e-13):
            break
        # at c = 1, m = 0 the zero rate must be dropped from every step, so the first step decomposes too
        if (critical and rates is None) or res > _SLOW * previous:
            rates = _rates(_closed_loop(c, mu, w, kp, km, r), mu)
        previous = res
        if rates is None:
            r = r - f / (mu[:, None] + mu[None, :])
            continue
        theta, v, vi = rates
        y = -f / mu[:, None] / mu[None, :]
        z = vi @ y @ vi.T
        den = theta[:, None] + theta[None, :]
        if critical:
            i0 = int(np.argmin(np.abs(theta)))
            den[i0, i0] = np.inf
        r = r + (v @ (z / den) @ v.T).real
    r = best[1]
    if critical:
        r = _conserve(r, s)
    return 0.5 * (r + r.T), best[2], rates


def _doubling(c, mu, w, kp, km, critical):
    n = mu.size
    inv = 1.0 / mu
    tau = 2.0**-60
    # thin layer by single scattering with exact exponentials (u normalisation: R = 2 rho/(mu_j w_j))
    r = 0.5 * c * km * (w * mu)[None, :] / (mu[:, None] + mu[None, :]) * -np.expm1(-tau * (inv[:, None] + inv[None, :]))
    x = tau * (inv[:, None] - inv[None, :])
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.where(x == 0.0, 1.0, np.expm1(x) / x)
    td = 0.5 * c * kp * w[None, :] * (tau * inv)[:, None] * np.exp(-tau * inv)[:, None] * rel
    d = np.exp(-tau * inv)
    one = np.ones(n)
    k = 0
    while True:
        k += 1
        r_new, td = doubling_step(r, td, d)
        tau *= 2.0
        d = np.exp(-tau * inv)
        if critical:  # a conservative slab: uniform radiance in, uniform out (R 1 + T 1 = 1)
            rs = r_new @ one
            r_new = r_new * (1.0 + (1.0 - rs - td @ one - d) / rs)[:, None]
        change = np.max(np.abs(r_new - r))
        r = r_new
        if (change <= 1e-17 * np.max(np.abs(r)) and tau > 1e3) or tau > 2.0**55:
            break
    big_r = 2.0 * r / (mu * w)[None, :]
    return 0.5 * (big_r + big_r.T), k


RULES = {"newton": dict(per_panel=12, ratio=0.25), "doubling": dict(per_panel=14, ratio=0.2)}


@lru_cache(maxsize=8)
def _rule(method, degree, smallest):
    mu, w = node_rule(degree, smallest=smallest, **RULES[method])
    mu.setflags(write=False)
    w.setflags(write=False)
    return mu, w


#: solutions kept: about 4.5 MB each at L = 256, one c needs about 31 orders (:data:`ORDER_TOLERANCE`)
_CACHED_ORDERS = 64


@lru_cache(maxsize=_CACHED_ORDERS)
def _solve_cached(method, phase, degree, m, c, smallest):
    mu, w = _rule(method, degree, smallest)
    moments = legendre_moments(degree, phase)[m:]
    q = _node_vectors(m, degree, moments, mu, w)
    kp, km = _kernels(moments, (-1.0) ** (np.arange(m, degree + 1) + m), q)
    critical = m == 0 and c == 1.0
    rates = None
    with single_threaded_blas():
        if c == 0.0 or degree < m:
            r, it = np.zeros((mu.size, mu.size)), 0
        elif _below_double(c):
            r, it = c * km / (mu[:, None] + mu[None, :]), 0  # single scattering: the rest is O(c^2), below 1e-308
        elif method == "newton":
            r, it, rates = _newton(c, mu, w, kp, km, critical)
        else:
            r, it = _doubling(c, mu, w, kp, km, critical)
        a1 = _closed_loop(c, mu, w, kp, km, r)
        if method == "doubling":
            rates = _rates(a1, mu)
    for a in (moments, q, r, km, a1, *(rates or ())):
        a.setflags(write=False)
    return OrderSolution(m, c, method, phase, degree, mu, w, moments, q, r, it, smallest, km, a1, rates)


def clear_cache() -> None:
    """Forget every cached solution (for timing a cold solve)."""
    _solve_cached.cache_clear()
    _needed_cached.cache_clear()


def solve_order(
    order: int,
    c: float,
    method: str = "newton",
    phase: str = "true",
    degree: int | None = None,
    smallest: float = 1e-10,
) -> OrderSolution:
    """The discrete half space of Fourier order ``order`` at particle albedo c (cached)."""
    method = _checks.choice(method, "method", METHODS)
    phase = _checks.choice(phase, "phase", PHASES)
    c = _checks.real_scalar(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    degree = _checks.positive_int(DEGREE if degree is None else degree, "degree")
    if phase == "three_term":
        degree = 2
    return _solve_cached(method, phase, int(degree), int(order), float(c), float(smallest))


def _rows(sol: OrderSolution, u: np.ndarray):
    """Nystrom rows R(u_a, nodes): r (u A1^T + M) = b(u), b_j = c k(u, -mu_j) + (c/2) mu_j sum_l w_l k(u, mu_l) R_lj.

    Solved as (u A1 + M) r^T = b^T by iterative refinement on the bounded residual, preconditioned by the
    solution's decomposition of M^-1 A1 (or by A1 = E where it has none: high orders, where A1 - E is tiny).
    Also returns k(u, nodes) (c-free).
    """
    c, mu, w = sol.c, sol.nodes, sol.weights
    qu = assoc_normalised(sol.order, sol.degree, u)  # (nl, nu)
    k_plus = qu.T @ (sol.moments[:, None] * sol.q_nodes)  # k(u, mu_j)
    k_minus = qu.T @ ((sol.moments * sol.signs)[:, None] * sol.q_nodes)  # k(u, -mu_j)
    b = c * k_minus + 0.5 * c * ((k_plus * w[None, :]) @ sol.r) * mu[None, :]
    a1 = sol.a1
    rhs = b.T  # (N, nu)

    def solve(rates):
        if rates is None:

            def approx(y):
                return y / (mu[:, None] + u[None, :])
        else:
            theta, v, vi = rates

            def approx(y):
                z = vi @ (y / mu[:, None])
                return (v @ (z / (1.0 + u[None, :] * theta[:, None]))).real

        x = approx(rhs)
        last = np.inf
        for _ in range(12):
            res = rhs - (a1 @ x) * u[None, :] - mu[:, None] * x
            dx = approx(res)
            x = x + dx
            # per column (a column at u = 0 is exact at once and dwarfs the others); the steps stall at
            # about 5e-16 of the column, where rounding sets the floor
            change = float(np.max(np.max(np.abs(dx), axis=0) / np.maximum(np.max(np.abs(x), axis=0), 1e-300)))
            if change <= 1e-15 or (change <= 1e-13 and change > 0.5 * last):
                return x, True
            last = change
        return x, False

    x, converged = solve(sol.rates)
    if not converged:  # the preconditioner is too far from A1 (the identity, or an early iterate's): decompose A1
        x, _ = solve(_rates(a1, mu))
    return x.T, k_plus


#: the rule on which :func:`_rows_interpolated` interpolates (:func:`interpolation_panels`): panels of at most
#: ``longest`` in mu below mu = ``top``, of ``theta_panels`` equal widths in theta = arccos(mu) above it, each
#: with ``per_panel`` Chebyshev points plus ``per_degree`` per unit length (of mu or theta) and Legendre degree
INTERPOLATION_RULE = dict(per_panel=16, per_degree=0.7, longest=1.0 / 8.0, top=0.25, theta_panels=12)


@lru_cache(maxsize=4)
def interpolation_panels(degree: int, smallest: float, ratio: float = RULES["newton"]["ratio"]):
    """Panels [a, b] covering [0, 1] in mu, each with Chebyshev points of the first kind in its variable (mu, or
    theta = arccos(mu) in the panels above ``top``, where Legendre functions of degree L oscillate evenly in theta
    and ever faster in mu, on scales down to 1/L^2 at mu = 1) and their barycentric weights:
    ((a, b, points in mu, points in the variable, weights, in theta), ...), increasing.  Below ``top`` the
    panels are those of :func:`node_rule` (geometric toward 0, where the rows vary on the scale of mu itself).
    """
    rule = INTERPOLATION_RULE
    edges = _geometric_edges(ratio, smallest)
    edges = edges[edges < rule["top"]]
    edges = np.unique(
        np.concatenate(
            [
                np.linspace(a, b, int(np.ceil((b - a) / rule["longest"])) + 1)
                for a, b in zip(edges, np.append(edges[1:], rule["top"]))
            ]
        )
    )
    theta_edges = np.linspace(np.arccos(rule["top"]), 0.0, rule["theta_panels"] + 1)
    panels = []

    def panel(lo, hi, theta):
        n = max(rule["per_panel"], int(np.ceil(rule["per_panel"] + rule["per_degree"] * degree * abs(hi - lo))))
        k = np.arange(n)
        t = lo + 0.5 * (hi - lo) * (1.0 - np.cos((2 * k + 1) * np.pi / (2 * n)))
        bw = (-1.0) ** k * np.sin((2 * k + 1) * np.pi / (2 * n))
        x = np.cos(t) if theta else t
        for arr in (x, t, bw):
            arr.setflags(write=False)
        a, b = (np.cos(lo), np.cos(hi)) if theta else (lo, hi)
        panels.append((float(a), float(b), x, t, bw, theta))

    for lo, hi in zip(edges[:-1], edges[1:]):
        panel(lo, hi, False)
    for lo, hi in zip(theta_edges[:-1], theta_edges[1:]):
        panel(lo, hi, True)
    return tuple(panels)


def _barycentric(x, bw, u):
    """The matrix L (u.size, x.size) of the polynomial interpolation through the points x: f(u) ~ L f(x)."""
    d = u[:, None] - x[None, :]
    hit = d == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = bw[None, :] / d
        mat = t / t.sum(axis=1, keepdims=True)
    rows = hit.any(axis=1)
    mat[rows] = hit[rows]
    return mat


def _rows_interpolated(sol: OrderSolution, u: np.ndarray):
    """What :func:`_rows` returns, for many cosines: the Nystrom rows at the Chebyshev points of
    :func:`interpolation_panels`, interpolated per panel.  What is interpolated is smooth: the numerators
    (u + mu_j) R(u, mu_j) (R itself has the pole 1/(u + mu_j), as sharp as the node mu_j is small) and
    k(u, mu_j), each divided by sqrt(1 - u^2) at odd orders (whose Legendre functions carry it).  Every order
    is within 1e-12 of the BRDF of the rows at each cosine (tests/test_true_phase.py)."""
    mu = sol.nodes

    def odd(v):  # Q_l^m has the factor (1 - u^2)^(m/2): for odd m, sqrt(1 - u^2) times a polynomial
        return np.sqrt((1.0 - v) * (1.0 + v)) if sol.order % 2 else np.ones_like(v)

    panels = interpolation_panels(sol.degree, sol.smallest)
    x_all = np.concatenate([p[2] for p in panels])
    r_all, k_all = _rows(sol, x_all)
    s_all = odd(x_all)[:, None]
    r_all = r_all * (x_all[:, None] + mu[None, :]) / s_all
    k_all = k_all / s_all
    rows, k_plus = np.empty((u.size, mu.size)), np.empty((u.size, mu.size))
    start = 0
    for a, b, x, t, bw, theta in panels:
        part = slice(start, start + x.size)
        start += x.size
        sel = np.flatnonzero((u >= a) & (u <= b))
        if sel.size == 0:
            continue
        mat = _barycentric(t, bw, np.arccos(u[sel]) if theta else u[sel])
        us, su = u[sel], odd(u[sel])[:, None]
        rows[sel] = (mat @ r_all[part]) * (su / (us[:, None] + mu[None, :]))
        k_plus[sel] = (mat @ k_all[part]) * su
    return rows, k_plus


def _interpolation_size(degree: int, smallest: float) -> int:
    return sum(p[2].size for p in interpolation_panels(degree, smallest))


def _ms_numerators(sol: OrderSolution, mu_a, mu_b):
    """(mu_a + mu_b) Rm(mu_a, mu_b) and the pole sign, for paired arrays (flat).  The Nystrom rows are
    computed at each distinct cosine, or, where there are more distinct cosines than
    :func:`interpolation_panels` has points, interpolated (:func:`_rows_interpolated`)."""
    c, w = sol.c, sol.weights
    if c == 0.0 or sol.degree < sol.order:
        return np.zeros(mu_a.shape), 0.0
    uniq, inv = np.unique(np.concatenate((mu_a, mu_b)), return_inverse=True)
    ia, ib = inv[: mu_a.size], inv[mu_a.size :]
    ua, ka = np.unique(ia, return_inverse=True)
    ub, kb = np.unique(ib, return_inverse=True)
    with single_threaded_blas():
        if uniq.size > _interpolation_size(sol.degree, sol.smallest):
            rows, k_plus = _rows_interpolated(sol, uniq)
        else:
            rows, k_plus = _rows(sol, uniq)
        rw = rows * w[None, :]
        kw = k_plus * w[None, :]
        zmat = rw @ sol.km * w[None, :]
        # x = sum_l R(a, l) w_l k(l, b), y = sum_l w_l k(a, l) R(l, b), z = sum_lk R(a, l) w_l K-(l, k) w_k R(k, b)
        if ua.size * ub.size <= 2 * mu_a.size:
            # the pairs fill (most of) a grid, as in a table or an albedo: one product per sum, then a gather,
            # instead of gathering a row of quadrature weights per pair
            x = (rw[ua] @ k_plus[ub].T)[ka, kb]
            y = (kw[ua] @ rows[ub].T)[ka, kb]
            z = (zmat[ua] @ rows[ub].T)[ka, kb]
        else:
            x = np.einsum("pj,pj->p", rw[ia], k_plus[ib])
            y = np.einsum("pj,pj->p", kw[ia], rows[ib])
            z = np.einsum("pj,pj->p", zmat[ia], rows[ib])
    num = 0.5 * c * (mu_a * x + mu_b * y) + 0.25 * c * mu_a * mu_b * z
    # sign of the log pole at (0, 0): the diverging sum at u = 0 (Y(0, 0) on the rule)
    pole = float(np.sign(y[(mu_a == 0.0) & (mu_b == 0.0)][0])) if np.any((mu_a == 0.0) & (mu_b == 0.0)) else 0.0
    return num, pole


def needed_orders(
    c: float, method: str = "newton", phase: str = "true", degree: int | None = None, smallest: float = 1e-10
) -> int:
    """Number of Fourier orders kept: orders m are solved until two in a row have
    max |Rm_m| over the nodes >= 1e-3 below ORDER_TOLERANCE times that of order 0."""
    phase = _checks.choice(phase, "phase", PHASES)
    if phase == "three_term":
        return 3
    return _needed_cached(method, phase, int(DEGREE if degree is None else degree), float(c), float(smallest))


def _below_double(c: float) -> bool:
    """The multiple scattering, O(c^2), is below double's smallest normal number (c < 1.5e-154): it is zero to
    double precision beside single scattering, O(c).  Solving for it there ran on subnormal numbers, and the
    order count (:func:`needed_orders`) compared rounding noise and kept every order: 80 s at c = 1e-300."""
    return c > 0.0 and c * c < np.finfo(float).tiny


@lru_cache(maxsize=256)
def _needed_cached(method, phase, degree, c, smallest):
    if c == 0.0 or _below_double(c):
        return 1
    ref = None
    small = 0
    for m in range(0, min(degree, MAX_ORDERS - 1) + 1):
        sol = solve_order(m, c, method, phase, degree, smallest)
        sel = sol.nodes >= 1e-3
        rm = (sol.r - sol.single)[np.ix_(sel, sel)]
        size = float(np.max(np.abs(rm)))
        if ref is None:
            ref = size
        small = small + 1 if size < ORDER_TOLERANCE * ref else 0
        if small == 2:
            return m + 1
    return min(degree, MAX_ORDERS - 1) + 1


def multiple_scattering_orders(
    mu_i,
    mu_o,
    c: float,
    method: str = "newton",
    phase: str = "true",
    degree: int | None = None,
    orders: int | None = None,
    smallest: float = 1e-10,
):
    """Fourier orders fm_0, fm_1, ... (fitlab's azimuth, 1/sr) of the multiple scattering, one c.

    mu_i, mu_o in [0, 1], broadcast; returns a tuple of arrays, one per order
    (``orders`` of them, default :func:`needed_orders`).  fm_m at mu_i = mu_o = 0 is +-inf
    (log pole), finite elsewhere.
    """
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    mu_o = _checks.real_array(mu_o, "mu_o", 0.0, 1.0)
    c = _checks.real_scalar(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    mu_i, mu_o = np.broadcast_arrays(mu_i, mu_o)
    if orders is None:
        orders = needed_orders(c, method, phase, degree, smallest)
    # each distinct (mu_i, mu_o) pair once: a grid in (mu_i, mu_o, phi) repeats every pair at each phi, and the
    # numerators gather a row of quadrature weights per pair (each pair's arithmetic is the same either way)
    pairs, where = np.unique(np.stack((mu_i.ravel(), mu_o.ravel()), axis=1), axis=0, return_inverse=True)
    a, b = pairs[:, 0].copy(), pairs[:, 1].copy()
    s = a + b
    pole = s == 0.0
    out = []
    for m in range(int(orders)):
        sol = solve_order(m, c, method, phase, degree, smallest)
        num, psign = _ms_numerators(sol, b, a)
        with np.errstate(divide="ignore", invalid="ignore"):
            val = num / s
        val[pole] = psign * np.inf if c > 0.0 else 0.0
        val *= (-1.0) ** m * (1.0 if m == 0 else 2.0) / (4.0 * np.pi)
        out.append(val[where.ravel()].reshape(mu_i.shape))
    return tuple(out)


def multiple_scattering_sum(
    mu_i,
    mu_o,
    phi,
    c: float,
    method: str = "newton",
    phase: str = "true",
    degree: int | None = None,
    orders: int | None = None,
    smallest: float = 1e-10,
):
    """sum_m fm_m(mu_i, mu_o) cos(m phi) for one c (phi = 0 back-scattering); +inf at mu_i = mu_o = 0 (c > 0)."""
    phi = _checks.real_array(phi, "phi", domain="(-inf, inf), finite (radians)", allow_inf=False)
    modes = multiple_scattering_orders(mu_i, mu_o, c, method, phase, degree, orders, smallest)
    shape = np.broadcast_shapes(modes[0].shape, np.shape(phi))
    total = np.zeros(shape)
    pole = np.zeros(shape, dtype=bool)
    for m, fm in enumerate(modes):
        fm = np.broadcast_to(fm, shape)
        inf = ~np.isfinite(fm)
        pole |= inf
        total += np.where(inf, 0.0, fm) * np.cos(m * np.broadcast_to(phi, shape))
    total[pole] = np.inf
    return total


def multiple_scattering_albedo(
    mu_i, c: float, method: str = "newton", phase: str = "true", degree: int | None = None, smallest: float = 1e-10
):
    """2 pi int_0^1 fm_0(mu_i, mu_o) mu_o dmu_o on the solution's own rule (exact in the discretisation)."""
    mu_i = _checks.real_array(mu_i, "mu_i", 0.0, 1.0)
    c = _checks.real_scalar(c, "c", 0.0, 1.0, domain="[0, 1] (particle albedo)")
    sol = solve_order(0, c, method, phase, degree, smallest)
    flat = mu_i.ravel()
    v, w = sol.nodes, sol.weights
    a = np.repeat(flat, v.size)
    b = np.tile(v, flat.size)
    num, _ = _ms_numerators(sol, b, a)
    rm = (num / (a + b)).reshape(flat.size, v.size)
    return (0.5 * rm @ (w * v)).reshape(mu_i.shape)
