r"""A fit's accuracy re-measured where it is used, never copied from its record.

A fit file states the error its maker measured (``validation``: max and RMS of the
target's error measure on the target's validation set, restricted to the fit's
``domain``).  :func:`measure_fit` measures it again, on the target's own
validation set over the target's whole domain (or, for a fit allowed to cover
part of it, over the fit's domain), from the fit's expression and parameters as
they stand in the file; :func:`verify_fit` refuses a fit whose re-measured error
is more than :data:`TOLERANCE` worse than the recorded one (beyond :data:`fitlab.fit.metrics.ROUNDING`), or that is not
finite somewhere on the domain.  ``fitlab codegen`` prints the re-measured
figures; ``verify_fit(fitlab.store.load(path))`` runs the same check on a fit file.

Non-finite values are looked for on the validation set (which holds the
domain's edges where the target is defined) and on a probe grid of
:data:`PROBE` interior points per input (log-spaced towards each end, where
forms with log and sqrt terms turn), so that a value the validation set
happens to miss still counts.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from fitlab.core import get_target
from fitlab.fit.metrics import ROUNDING, summary
from fitlab.store import FitFileError, FitFunction

__all__ = ["TOLERANCE", "PROBE", "measure_fit", "verify_fit", "describe_measured"]

#: a fit whose re-measured max or RMS error exceeds (1 + TOLERANCE) x the recorded one, plus :data:`ROUNDING`, is
#: refused (rounding: the file's figures come from the form, the re-measured ones from the expression as the file
#: writes it)
TOLERANCE = 0.10
#: interior points per input of the non-finite probe grid (besides the two ends)
PROBE = 7


def _probe_axis(lo: float, hi: float) -> np.ndarray:
    """PROBE points inside (lo, hi), crowded towards both ends (offsets 1e-9 .. 1/2 of the width).  The ends
    themselves are the validation set's: it holds them where the target is defined there (a target may have no
    value where several inputs reach their ends at once, as a BRDF at mu_i = mu_o = 0)."""
    width = hi - lo
    offsets = width * np.logspace(-9, math.log10(0.5), (PROBE + 1) // 2)
    return np.unique(np.concatenate((lo + offsets, hi - offsets)))


def _fit_domain(fit: FitFunction) -> dict:
    return {k: (float(lo), float(hi)) for k, (lo, hi) in fit.domain.items()}


def _target_domain(fit: FitFunction) -> dict:
    """The target's whole domain over the fit's inputs."""
    return {k: (float(lo), float(hi)) for k, (lo, hi) in get_target(fit.target).domain.items() if k in fit.inputs}


def measure_fit(fit: FitFunction, *, allow_partial_domain: bool = False) -> dict:
    """The fit's error on its target's validation set: over the target's whole domain, or with
    ``allow_partial_domain`` over the fit's own domain when that is narrower.

    Returns {"max_rel", "max_rel_nonzero", "rms_rel", "max_abs", "points", "worst"} (as a fit record's
    ``validation``, :func:`fitlab.fit.metrics.summary`) with "domain" (the domain measured over: the clamps
    of code that prints the fit), "partial" (whether that is narrower than the target's), "measure" (the
    target's error measure) and "nonfinite" (an input point where the fit is not finite, or None)."""
    target = get_target(fit.target)
    own, whole = _fit_domain(fit), _target_domain(fit)
    partial = allow_partial_domain and own != whole
    domain = own if partial else whole
    # the set restricted to the domain measured, as refit restricts it: a set may hold points just outside the
    # domain (a computed input such as fast_brdf's kd = kd_true(c), 1 at c = 1 up to rounding), which are in no
    # fit's claim
    valid = target.validation().restricted(domain)
    xs = [valid.inputs[n] for n in fit.inputs]
    approx = fit.evaluate(*xs)
    figures = summary(approx, valid.y, target.scale(valid), valid.inputs)
    nonfinite = None
    bad = ~np.isfinite(approx)
    if np.any(bad):
        i = int(np.argmax(bad))
        nonfinite = {n: float(x[i]) for n, x in zip(fit.inputs, xs)}
    else:
        grid = [_probe_axis(*domain[n]) for n in fit.inputs]
        points = np.array(list(itertools.product(*grid))).T
        values = fit.evaluate(*points)
        bad = ~np.isfinite(values)
        if np.any(bad):
            i = int(np.argmax(bad))
            nonfinite = {n: float(points[k][i]) for k, n in enumerate(fit.inputs)}
    return {**figures, "domain": domain, "partial": partial, "measure": target.error_measure, "nonfinite": nonfinite}


def _where(domain: dict) -> str:
    return ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in domain.items())


def verify_fit(fit: FitFunction, *, allow_partial_domain: bool = False) -> dict:
    """:func:`measure_fit`, then refuse (one :class:`FitFileError` line naming the file) a fit that is not
    finite somewhere on the domain measured, or whose max or RMS error there is more than :data:`TOLERANCE`
    worse than the record's ``validation`` states.  Returns the measured figures, also set as ``fit.measured``.

    Without ``allow_partial_domain`` a fit made on part of its target's domain is measured over the whole
    domain like any other: it passes only if it holds its stated accuracy there too."""
    source = str(fit.path or f"{fit.target}/{fit.form}")
    m = measure_fit(fit, allow_partial_domain=allow_partial_domain)
    own = _fit_domain(fit)
    hint = (
        f"; it was fitted on {_where(own)} only (--allow-partial-domain prints it for that domain)"
        if own != _target_domain(fit) and not m["partial"]
        else ""
    )
    if m["nonfinite"] is not None:
        at = ", ".join(f"{k} = {v:.6g}" for k, v in m["nonfinite"].items())
        raise FitFileError(f"{source}: not finite at {at}, inside {_where(m['domain'])}{hint}")
    recorded = fit.record.get("validation") or {}
    for key, label in (("max_rel", "max"), ("max_rel_nonzero", "max (exact zeros left out)"), ("rms_rel", "RMS")):
        stated = recorded.get(key)
        if stated is None or not isinstance(stated, (int, float)):
            continue
        got = m[key]
        if not (got <= (1 + TOLERANCE) * stated + ROUNDING):  # NaN refused too
            raise FitFileError(
                f"{source}: re-measured {label} error {got:.3g} on {fit.target}'s validation set over "
                f"{_where(m['domain'])} ({m['points']} points), the file states {float(stated):.3g} "
                f"(more than {TOLERANCE:.0%} worse){hint}"
            )
    fit.measured = m
    return m


def describe_measured(m: dict) -> str:
    """The figures of :func:`measure_fit` as generated code states them, in one phrase."""
    measure = m["measure"].split(":")[0].strip()
    where = f"; over {_where(m['domain'])} only, the fit's domain, inputs clamped to it" if m["partial"] else ""
    rel = m["max_rel"] if math.isfinite(m["max_rel"]) else m["max_rel_nonzero"]
    zeros = " without the exact zeros" if not math.isfinite(m["max_rel"]) else ""
    return f"max {rel:.2e}{zeros}, RMS {m['rms_rel']:.2e} ({measure}, {m['points']} points{where})"
