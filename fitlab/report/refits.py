r"""The one-off cost of each refit: wall seconds of :func:`fitlab.fit.refit.refit` (nothing written).

Each target's training and validation sets are built before the clock starts
(they are cached per process, shared by the target's forms and by the report's
accuracy section), so a refit's seconds are its own: JIT compilation, Levenberg-Marquardt, the minimax
rounds and the validation.  Every fit file whose form :mod:`fitlab.forms`
defines is refitted with the domain its record states; the refit's validation
max error is reported beside the file's (equal when the file is reproducible).
A fit made by other means (``origin``, e.g. discovered) cannot be refitted here;
the seconds its record states, if any (``origin.seconds``), are shown instead.
"""

from __future__ import annotations

import math
import time

from fitlab.core import get_target
from fitlab.fit.refit import refit
from fitlab.store import resolve_form

__all__ = ["refit_jobs", "refit_costs", "recorded_seconds"]


def _domain(record) -> dict:
    """The record's domain as refit takes it: {input: (lo, hi)}."""
    return {name: (float(lo), float(hi)) for name, (lo, hi) in record.get("domain", {}).items()}


def refit_jobs(entries, only=None) -> list:
    """(FitEntry, domain) for every refittable fit file (or those ``only`` names as (target, form))."""
    jobs = []
    for e in entries:
        if e.form not in get_target(e.target).forms:
            continue
        if only is not None and (e.target, e.form) not in only:
            continue
        jobs.append((e, _domain(e.record)))
    return jobs


def recorded_seconds(record) -> float:
    """The seconds a fit record's origin states (``seconds``, ``wall_seconds`` or ``wall_s``), else NaN."""
    origin = record.get("origin")
    if isinstance(origin, dict):
        for key in ("seconds", "wall_seconds", "wall_s"):
            if isinstance(origin.get(key), (int, float)):
                return float(origin[key])
    return math.nan


def refit_costs(jobs, fits_dir, tick=None) -> list[dict]:
    """Rows (target, form, seconds, steps, refit and recorded validation max error)."""
    rows = []
    for e, domain in jobs:
        t = get_target(e.target)
        t.training()  # cached per process: built before the clock starts
        t.validation()
        t0 = time.perf_counter()
        res = refit(t, resolve_form(e.target, e.form, fits_dir), domain=domain)
        seconds = time.perf_counter() - t0
        rows.append({"target": e.target, "form": e.form, "path": str(e.path), "seconds": seconds,
                     "steps": int(res.record["optimizer"]["total_steps"]),
                     "max_rel": float(res.record["validation"]["max_rel"]), "recorded_max_rel": e.max_rel})  # fmt: skip
        if tick:
            tick()
    return rows
