r"""The Pareto front of cost against error, and the recommendations read off the numbers.

A method dominates another when it costs no more and errs no more, and is
strictly better in one of the two.  The front is the set no method dominates,
listed by increasing cost (so with strictly decreasing error); of exact
duplicates the first listed is kept.  Points with a non-finite or negative
cost or error are not on any front.

Recommendations (each rule applied to the measured rows; the baselines, which
model another material, are never recommended):

* real-time: among methods with generated C (GLSL is printed from the same
  expressions) that read no table (at most ``REALTIME_BYTES`` of data: constants
  a shader keeps without binding a texture), those with RMS relative error
  <= ``REALTIME_RMS`` and, on the grazing set (mu_i, mu_o down to 1e-6), max
  relative error <= ``REALTIME_GRAZING`` (a renderer meets grazing angles at every
  silhouette; a model 20x too bright there makes fireflies that no RMS over
  uniform points shows); the cheapest in C double, where every method within
  ``COST_TIE`` of that cost counts as equally cheap and the lowest RMS error among
  them wins (timings are noisy; a 10 % difference is not a reason to take the less
  accurate model);
* real-time, texture: the same rule with tables of any size (an engine that binds
  one more texture: the C timing reads it from a warm cache, as a texture unit would);
* offline: the lowest max relative error among methods costing at most
  ``OFFLINE_NS`` per evaluation (C double where measured, else numpy);
* reference: the lowest max relative error at any cost.
"""

from __future__ import annotations

import math

__all__ = ["pareto_front", "recommend", "REALTIME_RMS", "REALTIME_GRAZING", "REALTIME_BYTES", "OFFLINE_NS", "COST_TIE",
           "RULES"]  # fmt: skip

REALTIME_RMS = 1e-2
REALTIME_GRAZING = 1.0
REALTIME_BYTES = 4096
OFFLINE_NS = 1e4
COST_TIE = 0.10

_REALTIME = (
    f"the cheapest generated C (double) with RMS relative error <= {REALTIME_RMS:g} and max relative "
    f"error <= {REALTIME_GRAZING:g} on the grazing set; methods within "
    f"{COST_TIE:.0%} of that cost count as equally cheap and the lowest RMS error among them is taken"
)
RULES = {
    "real-time": f"reading no table (data <= {REALTIME_BYTES} bytes), {_REALTIME}",
    "real-time, texture": f"tables of any size, {_REALTIME}",
    "offline": f"the lowest max relative error among methods costing <= {OFFLINE_NS / 1e3:g} us per evaluation "
               "(C double where measured, else numpy)",
    "reference": "the lowest max relative error at any cost",
}  # fmt: skip


def _ok(x) -> bool:
    return x is not None and math.isfinite(x) and x >= 0.0


def pareto_front(costs, errors=None, *, infinite_errors: bool = False) -> list[int]:
    """Indices of the non-dominated points, by increasing cost (errors then strictly decrease).

    ``pareto_front(costs, errors)``, or ``pareto_front(points)`` with (cost, error) pairs (how
    :mod:`fitlab.discover` calls it).  Points with a non-finite or negative cost or error are on no
    front, except that ``infinite_errors=True`` counts an infinite error as the worst error (such a
    point is on the front only where nothing else costs as little: how discover keeps a candidate
    whose linearised error is infinite for its refit)."""
    if errors is None:
        pairs = [(float(a), float(b)) for a, b in costs]
        costs, errors = [p[0] for p in pairs], [p[1] for p in pairs]

    def admitted(c, e) -> bool:
        return _ok(c) and (_ok(e) or (infinite_errors and e is not None and e == math.inf))

    idx = [i for i, (c, e) in enumerate(zip(costs, errors)) if admitted(c, e)]
    idx.sort(key=lambda i: (costs[i], errors[i], i))
    front, best = [], None
    for i in idx:
        if best is None or errors[i] < best:
            front.append(i)
            best = errors[i]
    return front


def _cost(row) -> float:
    c = row.get("ns_c_double")
    return c if _ok(c) else row.get("ns_python", math.nan)


def _cheapest(rows: list[dict]) -> dict | None:
    """The cheapest in C double, the lowest RMS error among those within :data:`COST_TIE` of it."""
    if not rows:
        return None
    cheapest = min(r["ns_c_double"] for r in rows)
    tied = [r for r in rows if r["ns_c_double"] <= cheapest * (1.0 + COST_TIE)]
    return min(tied, key=lambda r: (r["rms_rel"], r["ns_c_double"]))


def recommend(rows: list[dict]) -> dict:
    """{use: row or None} for "real-time", "real-time, texture", "offline", "reference" by :data:`RULES` (rows:
    the BRDF-level rows with max_rel, rms_rel, max_rel_grazing, bytes, ns_c_double, ns_python, group)."""
    cands = [r for r in rows if r["group"] != "baseline"]
    out = {}
    rt = [r for r in cands if _ok(r.get("ns_c_double")) and _ok(r["rms_rel"]) and r["rms_rel"] <= REALTIME_RMS
          and _ok(r.get("max_rel_grazing")) and r["max_rel_grazing"] <= REALTIME_GRAZING]  # fmt: skip
    out["real-time"] = _cheapest([r for r in rt if _ok(r.get("bytes")) and r["bytes"] <= REALTIME_BYTES])
    out["real-time, texture"] = _cheapest(rt)
    off = [r for r in cands if _ok(_cost(r)) and _cost(r) <= OFFLINE_NS and _ok(r["max_rel"])]
    out["offline"] = min(off, key=lambda r: (r["max_rel"], r["rms_rel"])) if off else None
    ref = [r for r in cands if _ok(r["max_rel"])]
    out["reference"] = min(ref, key=lambda r: (r["max_rel"], r["rms_rel"])) if ref else None
    return out
