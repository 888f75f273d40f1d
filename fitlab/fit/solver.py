r"""Least-squares fitting of a form with optimistix, and its minimax refinement.

The residual of point i is w_i (f(theta; x_i) - y_i) / scale_i (relative by
default, see fitlab.families.lambert_sphere.targets).  Stage 1 solves the plain problem (w = 1)
with Levenberg-Marquardt.  Stage 2, the minimax refinement, is Lawson's
iteratively reweighted least squares: w_i^2 <- w_i^2 |r_i| / sum_j w_j^2 |r_j|,
each round a warm-started LM solve of at most ``SOLVER_SETTINGS["round_steps"]`` steps (a round
needs a step towards the reweighted optimum, not its convergence: on H0 the
best round and its error are the same as with 400 steps per round, in a
quarter of the steps); weights concentrate on the extremal points and the max
error falls towards the minimax value.  Stage 1 runs the same compiled solve
in chunks of that many steps until it converges or reaches ``max_steps``.  The best parameters
by max training error are kept, so refinement never makes a fit worse on the
data it sees.  The data, weights and start travel as arguments of one jitted
solve, so every round reuses a single compilation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from fitlab.core import Dataset, float64
from fitlab.numerics import single_threaded_blas

__all__ = ["FitError", "FitResult", "fit_form", "fit_form_scipy", "SOLVER_SETTINGS"]

SOLVER_SETTINGS = {
    "solver": "optimistix.LevenbergMarquardt",
    "rtol": 1e-10,
    "atol": 1e-14,
    "max_steps": 400,
    "round_steps": 60,
}


class FitError(Exception):
    """A fit cannot start or produced nothing usable."""


@dataclass
class FitResult:
    theta: np.ndarray  # full parameter vector, form.params order
    l2_steps: int
    total_steps: int
    rounds: int
    result: str
    train_max: float
    train_rms: float
    l2_seconds: float
    seconds: float
    history: list = field(default_factory=list)  # (round, max train error)


def _training_arrays(form, train: Dataset, scale: np.ndarray):
    """The training points as arrays: every point must be finite (refused naming the first that is not, never
    left out unseen); the points whose error scale is 0 (exact zeros of a relative error) are left out."""
    finite = np.isfinite(train.y)
    for name in form.inputs:
        finite &= np.isfinite(train.inputs[name])
    if not np.all(finite):
        i = int(np.argmax(~finite))
        point = ", ".join(f"{n}={train.inputs[n][i]:.6g}" for n in form.inputs)
        raise FitError(
            f"{form.key}: the training value at {point} is {float(train.y[i])!r}; every training point must be finite"
        )
    keep = np.asarray(scale, dtype=float) > 0.0
    if not np.any(keep):
        raise FitError(f"{form.key}: no training point with a finite value and a nonzero scale")
    xs = tuple(np.asarray(train.inputs[n][keep], dtype=float) for n in form.inputs)
    return xs, np.asarray(train.y[keep], dtype=float), 1.0 / np.asarray(scale[keep], dtype=float)


def _check_start(form, theta, xs, y, inv_scale):
    r = (form.numpy_fit_function(theta, *xs) - y) * inv_scale
    if not np.all(np.isfinite(r)):
        i = int(np.argmax(~np.isfinite(r)))
        point = ", ".join(f"{n}={x[i]:.6g}" for n, x in zip(form.inputs, xs))
        raise FitError(f"{form.key}: the start parameters give a non-finite value at {point}; choose another start")


def _prepare(form, train, scale, theta0, weights):
    """Start vector, training arrays, 1/scale and the indices of the free parameters."""
    theta0 = np.asarray(form.vector(form.start_values) if theta0 is None else theta0, dtype=float)
    # an emphasis weight is folded into the scale: residual = w (f - y)/scale
    scale = np.asarray(scale, dtype=float) if weights is None else np.asarray(scale, dtype=float) / weights
    xs, y, inv_scale = _training_arrays(form, train, scale)
    _check_start(form, theta0, xs, y, inv_scale)
    free = np.array([form.params.index(p) for p in form.free_params], dtype=int)
    return theta0, xs, y, inv_scale, free


@float64
def fit_form(
    form, train: Dataset, scale: np.ndarray, theta0=None, *, minimax_rounds: int = 40, weights=None, on_step=None
) -> FitResult:
    """Fit ``form``'s free parameters to ``train``; returns the full parameter vector.

    theta0: full start vector (default: ``form.start_values``); fixed
    parameters keep their entries in theta0.  ``on_step(stage)``, when given, is called after the
    least-squares solve ("least squares") and after each minimax round ("minimax K/N"): a progress hook.
    """
    with single_threaded_blas():  # LM's QR of a tall, narrow Jacobian: one thread is faster (fitlab.numerics)
        return _fit(form, train, scale, theta0, minimax_rounds, weights, on_step)


def _fit(form, train, scale, theta0, minimax_rounds, weights, on_step) -> FitResult:
    import equinox as eqx
    import jax.numpy as jnp
    import optimistix as optx

    t_start = time.perf_counter()
    theta0, xs, y, inv_scale, free = _prepare(form, train, scale, theta0, weights)
    f = form.jax_function

    def residual(theta_free, args):
        base, sqrt_w, xs_, y_, inv_ = args
        theta = base.at[free].set(theta_free)
        return sqrt_w * (f(theta, *xs_) - y_) * inv_

    solver = optx.LevenbergMarquardt(rtol=SOLVER_SETTINGS["rtol"], atol=SOLVER_SETTINGS["atol"])

    @eqx.filter_jit
    def solve(theta_free, args):
        sol = optx.least_squares(residual, solver, theta_free, args=args, max_steps=SOLVER_SETTINGS["round_steps"],
                                 throw=False)  # fmt: skip
        r = residual(sol.value, args[:1] + (jnp.ones_like(args[1]),) + args[2:])
        return sol.value, sol.stats["num_steps"], sol.result == optx.RESULTS.successful, r

    base = jnp.asarray(theta0)
    data = (jnp.asarray(xs[0]),) if len(xs) == 1 else tuple(jnp.asarray(x) for x in xs)
    args_for = lambda w: (base, jnp.asarray(w), data, jnp.asarray(y), jnp.asarray(inv_scale))  # noqa: E731

    value, l2_steps, ok = jnp.asarray(theta0[free]), 0, False
    while not ok and l2_steps < SOLVER_SETTINGS["max_steps"]:  # stage 1 to convergence, in chunks
        value, steps, ok, r = solve(value, args_for(np.ones_like(y)))
        l2_steps += int(steps)
        ok = bool(ok)
    r = np.asarray(r)
    if not np.all(np.isfinite(r)):
        raise FitError(f"{form.key}: the least-squares solution gives non-finite residuals")
    l2_seconds = time.perf_counter() - t_start
    total = l2_steps
    if on_step is not None:
        on_step("least squares")
    best = (float(np.max(np.abs(r))), np.asarray(value), r)
    results = ["successful" if bool(ok) else "max_steps or stagnation"]
    history = [(0, best[0])]
    weights = np.ones_like(y)
    for k in range(1, minimax_rounds + 1):
        weights = weights * np.abs(r)
        if not weights.sum() > 0.0:
            break  # every residual is zero: the fit is exact, nothing is left to level
        weights = np.maximum(weights / weights.sum(), 1e-14 / weights.size)
        value, steps, ok, r_new = solve(jnp.asarray(value), args_for(np.sqrt(weights * weights.size)))
        total += int(steps)
        if on_step is not None:
            on_step(f"minimax {k}/{minimax_rounds}")
        r_new = np.asarray(r_new)
        if not np.all(np.isfinite(r_new)):
            break  # keep the best finite solution; a non-finite step never reaches the result
        r = r_new
        history.append((k, float(np.max(np.abs(r)))))
        if history[-1][1] < best[0]:
            best = (history[-1][1], np.asarray(value), r)
            results.append("successful" if bool(ok) else "max_steps or stagnation")
    theta = theta0.copy()
    theta[free] = best[1]
    r = best[2]
    return FitResult(
        theta=theta,
        l2_steps=l2_steps,
        total_steps=total,
        rounds=minimax_rounds,
        result=results[-1],
        train_max=best[0],
        train_rms=float(np.sqrt(np.mean(r**2))),
        l2_seconds=l2_seconds,
        seconds=time.perf_counter() - t_start,
        history=history,
    )


def fit_form_scipy(form, train: Dataset, scale: np.ndarray, theta0=None, *, weights=None) -> FitResult:
    """The stage-1 problem solved by scipy.optimize.least_squares (MINPACK LM,
    finite-difference Jacobian), for a side-by-side comparison."""
    from scipy.optimize import least_squares

    t_start = time.perf_counter()
    theta0, xs, y, inv_scale, free = _prepare(form, train, scale, theta0, weights)

    def residual(theta_free):
        theta = theta0.copy()
        theta[free] = theta_free
        return (form.numpy_fit_function(theta, *xs) - y) * inv_scale

    sol = least_squares(residual, theta0[free], method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=20000)
    theta = theta0.copy()
    theta[free] = sol.x
    r = residual(sol.x)
    dt = time.perf_counter() - t_start
    return FitResult(
        theta,
        int(sol.nfev),
        int(sol.nfev),
        0,
        sol.message,
        float(np.max(np.abs(r))),
        float(np.sqrt(np.mean(r**2))),
        dt,
        dt,
    )
