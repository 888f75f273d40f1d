"""Error measures: max and RMS relative error, where the worst point lies, and when one fit is worse than
another (:func:`worse`, the one rule every comparison of two fits uses)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = ["relative_errors", "summary", "worse", "WORSE_RTOL", "ROUNDING"]

#: how much larger (relative) a figure must be than another's to count as larger, beyond rounding
WORSE_RTOL = 1e-6
#: ...plus this much: an error of a few ulp is rounding, and a fit exact in its form (the Fresnel of a dielectric)
#: has such errors, which move with the order of evaluation
ROUNDING = 1e-13


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


def worse(mine: Mapping, theirs: Mapping) -> bool:
    """Whether a fit whose validation figures (:func:`summary`) are ``mine`` is worse than one whose figures on the
    same points are ``theirs``: the one rule of every comparison of two fits (a refit against its start and the
    published presets of its form, :func:`fitlab.fit.refit.refit_verdict`; a fit against the one already in its
    file, ``fitlab refit`` and ``fitlab fit``).

    The max error decides (``max_rel``, infinite where a fit misses an exact zero of its target), then the max
    error without the target's exact zeros (``max_rel_nonzero``), then the RMS (``rms_rel``): the first that
    differs beyond rounding (by more than :data:`WORSE_RTOL` relative and :data:`ROUNDING` absolute).  A figure
    that is NaN (not measured) counts as infinite; equal figures are not worse."""
    for key in ("max_rel", "max_rel_nonzero", "rms_rel"):
        a, b = (_nan_as_inf(float(figures[key])) for figures in (mine, theirs))
        if a == b:
            continue
        if a > b * (1 + WORSE_RTOL) + ROUNDING:
            return True
        if b > a * (1 + WORSE_RTOL) + ROUNDING:
            return False
    return False


def _nan_as_inf(x: float) -> float:
    return math.inf if math.isnan(x) else x
