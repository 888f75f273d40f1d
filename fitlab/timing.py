"""fitlab's one best-of-N wall-clock timer (benchmarks, the report, ``fitlab discover --cost``).

The shortest of N wall-clock times is the least disturbed by other load on the
machine; interleaving several functions round by round (:func:`interleaved_best`)
makes a change of load hit all of them alike, so the ratios between them hold
even on a shared machine.  Only ratios measured in one run carry meaning.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Hashable, Mapping
from typing import Any

__all__ = ["best_of", "best_seconds", "interleaved_best"]


def best_of(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """(shortest wall time in seconds of ``repeat`` calls of ``fn()``, what that fastest call returned)."""
    best, out = math.inf, None
    for _ in range(max(1, int(repeat))):
        t0 = time.perf_counter()
        res = fn()
        dt = time.perf_counter() - t0
        if dt < best:
            best, out = dt, res
    return best, out


def best_seconds(fn: Callable[[], Any], repeat: int) -> float:
    """The shortest of ``repeat`` wall-clock times of ``fn()``, in seconds."""
    return best_of(fn, repeat)[0]


def interleaved_best(fns: Mapping[Hashable, Callable[[], Any]], repeat: int, tick=None) -> dict:
    """{key: shortest wall time of fns[key]()} over ``repeat`` rounds; each round calls every function
    once, in turn (``tick()`` after each round)."""
    best = dict.fromkeys(fns, math.inf)
    for _ in range(repeat):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
        if tick:
            tick()
    return best
