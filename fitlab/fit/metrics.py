"""Error measures: max and RMS relative error, and where the worst point lies."""

from __future__ import annotations

import numpy as np

__all__ = ["relative_errors", "summary"]


def relative_errors(approx, exact, scale) -> np.ndarray:
    """|approx - exact| / scale; where scale == 0, 0 if approx == exact else inf.

    NaN anywhere in ``approx`` counts as an infinite error: a form that returns
    NaN on its domain is as wrong as it can be.
    """
    approx, exact, scale = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (approx, exact, scale)))
    diff = np.abs(approx - exact)
    with np.errstate(divide="ignore", invalid="ignore"):
        err = np.where(scale > 0.0, diff / np.where(scale > 0.0, scale, 1.0), np.where(diff == 0.0, 0.0, np.inf))
    err[~np.isfinite(approx)] = np.inf
    return err


def summary(approx, exact, scale, inputs: dict) -> dict:
    """max_rel, rms_rel, max_abs, points and the worst point (inputs, exact, approx)."""
    err = relative_errors(approx, exact, scale)
    i = int(np.argmax(err))
    with np.errstate(over="ignore", invalid="ignore"):
        rms = float(np.sqrt(np.mean(err**2)))
        absolute = np.abs(np.asarray(approx, dtype=float) - exact)
    nonzero = np.asarray(scale, dtype=float) > 0.0
    return {
        "max_rel": float(err[i]),
        # the same without the exact zeros of the target (c = 0 for most constants),
        # where any approximation that misses the zero has an infinite relative error
        "max_rel_nonzero": float(np.max(err[nonzero])) if np.any(nonzero) else 0.0,
        "rms_rel": rms,
        "max_abs": float(np.max(np.where(np.isfinite(absolute), absolute, np.inf))),
        "points": int(err.size),
        "worst": {
            **{k: float(v[i]) for k, v in inputs.items()},
            "exact": float(exact[i]),
            "approx": float(np.asarray(approx)[i]),
        },
    }
