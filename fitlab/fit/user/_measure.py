"""A fit of one's own table measured again: its held-out error from the table alone, and a probe of its domain
for a point where it is not finite."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from fitlab.fit.user._limits import UserDataError
from fitlab.fit.user._split import error_scale, prepare_rows
from fitlab.fit.user._table import UserTable

__all__ = ["remeasure", "nonfinite_point", "PROBE_POINTS"]


def remeasure(record: Mapping, table: UserTable) -> dict:
    """The held-out error of the fit ``record`` measured again on ``table`` (the table its ``user_data``
    names): the rows in the record's domain, checked and split again as a fit does (:func:`prepare_rows`), the
    fit evaluated there and measured with the record's error (:func:`fitlab.fit.metrics.summary`).

    Every figure the record states of its table is derived again from the table and must be the one derived
    (:class:`UserDataError` otherwise, naming the first that differs): the sha256, the rows, the domain (the
    bounding box of the rows inside the stated domain: a domain edited wider than the rows is refused), the
    error's floor, the split, and the numbers of rows fitted and held out."""
    from fitlab.fit.metrics import summary
    from fitlab.store import FitFunction

    user = record["user_data"]
    if table.sha256 != user["sha256"]:
        raise UserDataError(
            f"{table.name}: sha256 {table.sha256[:16]}..., the fit was made on a table with "
            f"{user['sha256'][:16]}...; the table changed since the fit"
        )
    inputs, target = list(record["inputs"]), record["target"]
    stated = {k: (float(lo), float(hi)) for k, (lo, hi) in record["domain"].items()}
    rows = prepare_rows(table, target, inputs, domain=stated, error=user["error"], holdout_every=user["holdout_every"])
    derived = rows.user_data()
    differ = [
        (what, says, gives)
        for what, says, gives in (
            ("user_data.rows", user["rows"], derived["rows"]),
            *(
                (f"the domain of {k}", f"[{stated[k][0]!r}, {stated[k][1]!r}]", f"[{lo!r}, {hi!r}]")
                for k, (lo, hi) in rows.domain.items()
            ),
            ("user_data.scale_floor", repr(float(user["scale_floor"])), repr(float(derived["scale_floor"]))),
            ("user_data.holdout_offset", user["holdout_offset"], derived["holdout_offset"]),
            ("training.points", record.get("training", {}).get("points", len(rows.train)), len(rows.train)),
            ("validation.points", record.get("validation", {}).get("points", len(rows.valid)), len(rows.valid)),
        )
        if says != gives
    ]
    if differ:
        what, says, gives = differ[0]
        raise UserDataError(
            f"the fit states {what} {says}, its table {Path(table.name).name} gives {gives}; the fit file was "
            "edited or is not this table's"
        )
    valid = rows.valid
    fit = FitFunction(dict(record))
    approx = fit.evaluate(*(valid.inputs[n] for n in inputs))
    return summary(approx, valid.y, error_scale(valid.y, user["error"], user["scale_floor"]), valid.inputs)


#: points of the probe of a fit's domain (:func:`nonfinite_point`): a tensor grid of at most this many, and as
#: many uniformly random points (a fixed seed)
PROBE_POINTS = 65_536


def nonfinite_point(fit, domain: Mapping[str, Sequence[float]] | None = None) -> dict | None:
    """A point of the box ``domain`` (default the fit's) where the fit ``fit`` (a
    :class:`fitlab.store.FitFunction`) is not finite, or None: probed on a tensor grid of n points per input
    (n^d <= :data:`PROBE_POINTS`, at least the two ends; crowded towards both ends, where forms with log and
    sqrt terms turn) and on :data:`PROBE_POINTS` uniformly random points (a fixed seed), which fall between
    the grid's lines."""
    box = {k: (float(lo), float(hi)) for k, (lo, hi) in (domain or fit.domain).items()}
    names = list(fit.inputs)
    d = len(names)
    n = max(2, int(math.floor(PROBE_POINTS ** (1.0 / d) + 1e-9)))
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, n))  # Chebyshev-Lobatto: both ends, crowded there
    axes = [box[k][0] + (box[k][1] - box[k][0]) * t for k in names]
    grid = [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]
    lo, hi = np.array([box[k][0] for k in names]), np.array([box[k][1] for k in names])
    cloud = lo + (hi - lo) * np.random.default_rng(20240).random((PROBE_POINTS, d))
    for points in (grid, list(cloud.T)):
        points = [np.clip(x, box[k][0], box[k][1]) for x, k in zip(points, names)]
        values = fit.evaluate(*points)
        bad = ~np.isfinite(values)
        if np.any(bad):
            i = int(np.argmax(bad))
            return {k: float(x[i]) for k, x in zip(names, points)}
    return None
