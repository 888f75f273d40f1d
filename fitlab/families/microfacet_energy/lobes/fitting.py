r"""Fitting a lobe shape to one simulated lobe (one kind, order, alpha and mu_i), with optimistix.

The data of a lobe are the bin averages y_b of f mu_o over the (mu_o, |phi_o|) bins of :mod:`.tables`,
their standard errors se_b, and the order's albedo A with its standard error se_A.  A shape's bin average
is integrated, not sampled at the bin's centre: Gauss-Legendre with :data:`NODES` x :data:`NODES` nodes
per bin (:func:`bin_averages`), so that model and data are the same functional of the lobe.

The measure (what is minimised): the chi-square of the bins plus the energy's,

    sum_b ((m_b - y_b) / se_b)^2 + B ((sum_b m_b Omega_b - A) / se_A)^2,   B = 80 (the number of bins),

least squares weighted by the standard errors, i.e. the maximum-likelihood fit of the binned estimates.
Why this and not a plain relative measure: a bin's variance is about y_b / (N Omega_b) (few paths per bin,
weights <= 1), so the bin term is about N sum_b Omega_b y_b ((m_b - y_b)/y_b)^2, the relative error of each
bin weighted by the energy it holds, and the noisy near-empty bins weigh what their noise allows; the
energy term (the best-measured number of the lobe) keeps the lobe's albedo where the simulation puts it,
which a chi-square with the data's own variances would bias low; it is weighted as much as the bins
together (B), because where a shape cannot follow a lobe the bins alone would trade the energy for the
shape (a renderer sees the energy first).  A bin no path reached (se_b = 0) gets
the standard error of one path's weight in it, 1/(N Omega_b).

The solver: optimistix Levenberg-Marquardt (rtol 1e-8, atol 1e-10, at most 256 steps), compiled once for
every lobe (the data travel as arguments), each parameter in its interval of :data:`BOUNDS` (a logistic
change of variable), from :data:`STARTS` starting points (the deviation angle's
sign decides the basin), the best kept.  Reported per lobe: the steps of the kept start and of all, the
seconds (after compilation, which is reported apart), the chi-square per degree of freedom, and the
parameters' standard errors from the Jacobian at the solution, (J^T J)^-1 scaled by the chi-square per
degree of freedom where that exceeds 1 (the misfit counted as noise).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from fitlab.core import float64
from fitlab.families.microfacet_energy.lobes.tables import MU_EDGES, PHI_EDGES, solid_angles

__all__ = [
    "NODES",
    "quadrature",
    "bin_averages",
    "bin_averages_numpy",
    "LobeFit",
    "fit_lobes",
    "SOLVER",
    "STARTS",
    "lobe_data",
    "BOUNDS",
    "ENERGY_WEIGHT",
]

NODES = 4
SOLVER = {"solver": "optimistix.LevenbergMarquardt", "rtol": 1e-8, "atol": 1e-10, "max_steps": 256}
#: the interval each parameter is fitted in (where a form has it): the solver works on u with
#: theta = lo + (hi - lo) / (1 + exp(-u)).  Without them a lobe the shape cannot follow (the conductors'
#: narrow forward streak at small alpha) drives the fit to degenerate corners (sigma ~ 1e-10 times a tilt
#: exp(26), sigma_n -> infinity, eta in the hundreds) whose parameters no smooth function of (alpha, mu_i)
#: can follow.  Every lobe the shapes do follow (the diffuse facets', the conductors' from alpha = 0.35 up)
#: fits well inside them.  alpha_l in [0.4328, 1.3322] is eta in [-0.9, 50].
BOUNDS = {
    "alpha_l": (0.4328, 1.3322),
    "sigma_n": (0.1, 2.5),
    "b": (-4.0, 4.0),
    "k": (-3.0, 3.0),
    "theta_d": (-1.5, 1.5),
    "a": (-0.9, 0.9),
}
#: the weight of the energy's residual: sqrt(number of bins), so that the energy counts as much as the bins
#: together where a shape cannot follow a lobe (without it the fitted lobe of a conductor's narrow forward
#: streak loses up to 30 % of its energy)
ENERGY_WEIGHT = float(np.sqrt((len(MU_EDGES) - 1) * (len(PHI_EDGES) - 1)))
#: starting values of the deviation angle (the other parameters start at the form's start, the scale at the
#: lobe's albedo)
STARTS = (0.0, -0.6, 0.6)


def quadrature():
    """(mu_o nodes (10 NODES,), cos_phi nodes (8 NODES,), weights (10 NODES,), (8 NODES,)): Gauss-Legendre in
    each bin, weights divided by the bin's width (a bin average is a weighted sum)."""
    x, w = np.polynomial.legendre.leggauss(NODES)

    def nodes(edges):
        e = np.asarray(edges)
        lo, hi = e[:-1, None], e[1:, None]
        return (lo + (hi - lo) * (x + 1) / 2).ravel(), np.broadcast_to(w / 2, (e.size - 1, NODES)).ravel()

    mu, wm = nodes(MU_EDGES)
    phi, wp = nodes(PHI_EDGES)
    return mu, np.cos(phi), wm, wp


def _reduce(g, wm, wp):
    nm, npf = len(MU_EDGES) - 1, len(PHI_EDGES) - 1
    return (g * wm[:, None] * wp[None, :]).reshape(nm, NODES, npf, NODES).sum(axis=(1, 3))


def bin_averages(f, theta, mu_i, alpha):
    """Bin averages (10, 8) of f mu_o for the JAX function ``f(theta, mu_o, cos_phi, mu_i, alpha)``."""
    import jax.numpy as jnp

    mu, c, wm, wp = (jnp.asarray(a) for a in quadrature())
    g = f(theta, mu[:, None], c[None, :], mu_i, alpha) * mu[:, None]
    return _reduce(g, wm, wp)


def bin_averages_numpy(f, mu_i, alpha) -> np.ndarray:
    """Bin averages (10, 8) of f mu_o for a numpy function ``f(mu_o, cos_phi, mu_i, alpha)``."""
    mu, c, wm, wp = quadrature()
    g = np.asarray(f(mu[:, None], c[None, :], mu_i, alpha), dtype=float) * mu[:, None]
    g = np.broadcast_to(g, (mu.size, c.size))
    return _reduce(g, wm, wp)


def lobe_data(value, se, albedo, albedo_se, paths) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(y, se with empty bins given one path's weight, A, se_A) of one lobe (module docstring)."""
    omega = solid_angles()
    se = np.where(se > 0, se, 1.0 / (paths * omega))
    return np.asarray(value, float), se, float(albedo), float(max(albedo_se, 1.0 / paths))


@dataclass
class LobeFit:
    """Per-lobe fits of one form: arrays over the lobes (L,) or (L, P)."""

    form: str
    params: tuple
    theta: np.ndarray  # (L, P) every parameter, form.params order
    theta_se: np.ndarray  # (L, P), 0 for fixed parameters
    chi2_dof: np.ndarray
    steps: np.ndarray  # LM steps of the kept start
    steps_all: np.ndarray  # LM steps of every start
    seconds: np.ndarray  # wall seconds of every start together, after compilation
    compile_seconds: float
    converged: np.ndarray


def _canonical(params, theta) -> None:
    """The one representative of equivalent parameter vectors (in place): the flattenings enter squared, so
    sigma_n -> |sigma_n| and 1 - a -> |1 - a|."""
    if "sigma_n" in params:
        i = params.index("sigma_n")
        theta[i] = abs(theta[i])
    if "a" in params:
        i = params.index("a")
        theta[i] = 1.0 - abs(1.0 - theta[i])


@float64
def fit_lobes(form, lobes, theta_start=None, progress=None) -> LobeFit:
    """Fit ``form`` (a :class:`fitlab.forms.Form` in :data:`.shapes.SHAPE_INPUTS`) to each lobe of ``lobes``:
    a list of dicts with y, se, A, A_se (:func:`lobe_data`), mu_i, alpha.  ``theta_start`` (L, P) replaces
    the starts (one start per lobe; the fixed parameters take their values from it too)."""
    import equinox as eqx
    import jax
    import jax.numpy as jnp
    import optimistix as optx

    f = form.jax_function
    free = np.array([form.params.index(p) for p in form.free_params], dtype=int)
    omega = jnp.asarray(solid_angles())
    bounded = np.array([p in BOUNDS for p in form.free_params])
    lo = np.array([BOUNDS.get(p, (0.0, 1.0))[0] for p in form.free_params])
    width = np.array([BOUNDS.get(p, (0.0, 1.0))[1] for p in form.free_params]) - lo

    def to_theta(u):
        return jnp.where(bounded, lo + width / (1.0 + jnp.exp(-u)), u)

    def to_u(t):
        q = np.clip((t - lo) / width, 1e-6, 1 - 1e-6)
        return np.where(bounded, np.log(q / (1 - q)), t)

    def residual(u, args):
        base, y, se, a, a_se, mu_i, alpha = args
        theta = base.at[free].set(to_theta(u))
        m = bin_averages(f, theta, mu_i, alpha)
        energy = ENERGY_WEIGHT * (jnp.sum(m * omega) - a) / a_se
        return jnp.concatenate([((m - y) / se).ravel(), jnp.atleast_1d(energy)])

    solver = optx.LevenbergMarquardt(rtol=SOLVER["rtol"], atol=SOLVER["atol"])

    @eqx.filter_jit
    def solve(tf, args):
        sol = optx.least_squares(residual, solver, tf, args=args, max_steps=SOLVER["max_steps"], throw=False)
        r = residual(sol.value, args)
        # the Jacobian in theta (for the standard errors): in u, divided by dtheta/du
        jac = jax.jacfwd(residual)(sol.value, args) / jax.jacfwd(to_theta)(sol.value).diagonal()
        return to_theta(sol.value), sol.stats["num_steps"], sol.result == optx.RESULTS.successful, jnp.sum(r * r), jac

    def starts(lobe, k):
        if theta_start is not None:
            return [np.asarray(theta_start[k], dtype=float)]
        out = []
        for td in STARTS:
            t = form.vector(form.start_values)
            if "sigma" in form.params:
                t[form.params.index("sigma")] = max(lobe["A"], 1e-6)
            if "theta_d" in form.free_params:
                t[form.params.index("theta_d")] = td
            elif td != 0.0:
                continue
            out.append(t)
        return out

    n_lobes, n_params = len(lobes), len(form.params)
    theta = np.zeros((n_lobes, n_params))
    theta_se = np.zeros((n_lobes, n_params))
    chi2 = np.zeros(n_lobes)
    steps, steps_all, seconds = (np.zeros(n_lobes, dtype=int), np.zeros(n_lobes, dtype=int), np.zeros(n_lobes))
    converged = np.zeros(n_lobes, dtype=bool)
    dof = (len(MU_EDGES) - 1) * (len(PHI_EDGES) - 1) + 1 - free.size
    compile_seconds = 0.0
    for k, lobe in enumerate(lobes):
        best = None
        t0 = time.perf_counter()
        for start in starts(lobe, k):
            args = (jnp.asarray(start), *(jnp.asarray(lobe[n]) for n in ("y", "se", "A", "A_se", "mu_i", "alpha")))
            u0 = jnp.asarray(to_u(start[free]))
            if compile_seconds == 0.0:
                tc = time.perf_counter()
                jax.block_until_ready(solve(u0, args))
                compile_seconds = time.perf_counter() - tc
                t0 = time.perf_counter()
            value, n, ok, c2, jac = jax.block_until_ready(solve(u0, args))
            c2 = float(c2)
            steps_all[k] += int(n)
            if np.isfinite(c2) and (best is None or c2 < best[3]):
                best = (np.asarray(value), int(n), bool(ok), c2, np.asarray(jac), start)
        seconds[k] = time.perf_counter() - t0
        if best is None:
            theta[k], chi2[k] = np.nan, np.nan
            continue
        value, n, ok, c2, jac, start = best
        theta[k] = start
        theta[k, free] = value
        _canonical(form.params, theta[k])
        chi2[k] = c2 / dof
        steps[k], converged[k] = n, ok
        try:
            cov = np.linalg.inv(jac.T @ jac) * max(chi2[k], 1.0)
            theta_se[k, free] = np.sqrt(np.maximum(np.diag(cov), 0.0))
        except np.linalg.LinAlgError:
            theta_se[k, free] = np.inf
        if progress is not None:
            progress.update(1)
    return LobeFit(form.name, form.params, theta, theta_se, chi2, steps, steps_all, seconds, compile_seconds, converged)
