r"""An adaptive search for a fit's worst point: does a validation set find the maximum of the error?

A validation set is a finite set of points; the error of a fit between them can be larger.  Starting from
the set's worst points, :func:`search_worst` climbs the error over the target's exact values
(:attr:`fitlab.core.Target.exact_grid`), one small tensor grid per step:

* each input x > 0 is moved multiplicatively, x rho^(-1, 0, 1) clipped to the domain (the functions fitlab
  fits turn on scales proportional to the distance to an edge at 0: the grazing layer mu ~ alpha, the
  small-mu layer of 1 - E), an input at 0 is tried at 0 and at its domain's width times 2^-20;
* the step rho starts at 2 and is square-rooted whenever no neighbour is worse, until rho - 1 < 1e-3.

It is a local search (a pattern search on log coordinates), not a proof: what it gives is a lower bound on
the true maximum that is at least the set's maximum, and the ratio of the two says how close the set came.
It reads and writes nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fitlab.core import Dataset, Target
from fitlab.fit.metrics import relative_errors

__all__ = ["search_worst"]

_FIRST_STEP = 2.0
_LAST_STEP = 1e-3  # stop when the multiplicative step rho - 1 falls below this


def _candidates(x: float, rho: float, lo: float, hi: float) -> np.ndarray:
    if x <= 0.0:
        near = lo + (hi - lo) * 2.0**-20
        return np.array([x, max(near, lo)])
    return np.unique(np.clip([x / rho, x, x * rho], lo, hi))


def search_worst(
    target: Target,
    approx: Callable[..., np.ndarray],
    starts: Dataset,
    *,
    domain: dict | None = None,
    count: int = 6,
    max_steps: int = 60,
) -> dict:
    """The largest error of ``approx`` (a function of the target's inputs, in order) found by climbing from
    the ``count`` worst points of ``starts`` (a dataset of the target: its validation set) over the target's
    exact values, inside ``domain`` ({input: (lo, hi)}; default the target's whole domain).

    Returns {"max_rel": the largest error found (the target's error measure), "worst": its point with
    "exact" and "approx", "set_max_rel": the largest error on ``starts``, "evaluations": exact values
    computed}.  Needs ``target.exact_grid`` over the target's own inputs (ValueError otherwise)."""
    if target.exact_grid is None or tuple(target.residual_axes) != tuple(target.inputs):
        raise ValueError(f"search_worst: target {target.name} has no exact values on grids of its inputs")
    exact_grid = target.exact_grid  # not None (above); a frozen dataclass's field
    names = tuple(target.inputs)
    bounds = dict(target.domain)
    bounds.update(domain or {})

    def errors(points: dict) -> tuple:
        inputs, y, aux = exact_grid({n: np.asarray(points[n], dtype=float) for n in names})
        flat = {n: np.asarray(inputs[n], dtype=float).ravel() for n in names}
        y = np.asarray(y, dtype=float).ravel()
        ds = Dataset(flat, y, "search", {k: np.asarray(v, dtype=float).ravel() for k, v in aux.items()} or None)
        a = np.asarray(approx(*(flat[n] for n in names)), dtype=float)
        return relative_errors(a, y, target.scale(ds)), y, a, flat

    err = relative_errors(np.asarray(approx(*(starts.inputs[n] for n in names)), dtype=float), starts.y,
                          target.scale(starts))  # fmt: skip
    order = np.argsort(-np.where(np.isfinite(err), err, np.inf))
    best = {"max_rel": float(err[order[0]]), "worst": None}
    evaluations = 0
    seen = set()
    for i in order:
        if len(seen) >= count:
            break
        point = tuple(float(starts.inputs[n][i]) for n in names)
        if point in seen:
            continue
        seen.add(point)
        here, here_err = point, float(err[i])
        rho = _FIRST_STEP
        for _ in range(max_steps):
            axes = {n: _candidates(x, rho, *bounds[n]) for n, x in zip(names, here)}
            e, y, a, flat = errors(axes)
            evaluations += e.size
            k = int(np.argmax(np.where(np.isfinite(e), e, np.inf)))
            if e[k] > here_err * (1 + 1e-12):
                here, here_err = tuple(float(flat[n][k]) for n in names), float(e[k])
            elif rho - 1.0 < _LAST_STEP:
                break
            else:
                rho = float(np.sqrt(rho))
        if here_err >= best["max_rel"] or best["worst"] is None:
            e, y, a, flat = errors({n: np.array([x]) for n, x in zip(names, here)})
            evaluations += 1
            if float(e[0]) >= best["max_rel"] or best["worst"] is None:
                best = {"max_rel": float(e[0]), "worst": {**dict(zip(names, here)), "exact": float(y[0]),
                                                          "approx": float(a[0])}}  # fmt: skip
    return {**best, "set_max_rel": float(err[order[0]]), "evaluations": evaluations}
