r"""The one C timing harness: ns per evaluation of compiled routines, in interleaved rounds.

:func:`time_routines` calls each case's C loop (no Python per element) in turn, round
after round (:mod:`fitlab.timing`), so that a change of machine load hits every case
alike; ``fitlab bench codegen`` (the family's benchmark) and ``fitlab report`` use it.
Only ratios within one run carry meaning.
"""

from __future__ import annotations

import numpy as np

from fitlab.timing import interleaved_best

__all__ = ["time_routines"]


def time_routines(cases: dict, repeat: int = 5) -> dict:
    """ns per evaluation of compiled routines: {key: (lib, routine name, arrays, dtype)} -> {key: ns}.

    The count of evaluations is the size of a case's last array (a per-material evaluator's first
    two arguments are the materials and their indices).

    Each array is converted to the case's dtype once, before any timing.  Each
    round calls every case's C loop once, in turn; a case's time is its best
    round.  Interleaving makes a change of machine load hit every case alike,
    so the ratios between cases hold even on a shared machine.
    """
    conv = {k: (lib, name, [_converted(a, dt) for a in args], dt) for k, (lib, name, args, dt) in cases.items()}
    fns = {k: (lambda lib=lib, name=name, arrays=arrays, dt=dt: lib(name, *arrays, dtype=dt))
           for k, (lib, name, arrays, dt) in conv.items()}  # fmt: skip
    best = interleaved_best(fns, repeat)
    return {k: best[k] / conv[k][2][-1].size * 1e9 for k in cases}


def _converted(a, dtype) -> np.ndarray:
    """``a`` in ``dtype``, contiguous; integer arrays (indices) stay as they are."""
    a = np.asarray(a)
    return np.ascontiguousarray(a) if a.dtype.kind in "iu" else np.ascontiguousarray(a, dtype=dtype)
