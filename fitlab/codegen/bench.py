r"""The one C timing harness: ns per evaluation of compiled routines, in interleaved rounds.

:func:`time_routines` calls each case's C loop (no Python per element) in turn, round
after round (:mod:`fitlab.timing`), so that a change of machine load hits every case
alike; ``fitlab bench codegen`` (the family's benchmark) and ``fitlab report`` use it.
:func:`time_expressions` times bare expressions (a form with its numbers) through it, each printed as a
routine of its own.  Only ratios within one run carry meaning.
"""

from __future__ import annotations

import numpy as np

from fitlab.timing import interleaved_best

__all__ = ["time_routines", "expressions_program", "time_expressions"]


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


def expressions_program(exprs: dict):
    """(Program, {routine name: key}) of expressions {key: (args, expr, domain)}: each a routine ``expr_K`` of its
    own taking ``args``, every input clamped into its interval of ``domain`` ({arg: (lo, hi)})."""
    from fitlab.codegen._model import Program, Routine
    from fitlab.codegen._policy import with_domain

    routines, keys = [], {}
    for key, (args, expr, domain) in exprs.items():
        name = f"expr_{len(routines)}"
        routines.append(
            with_domain(Routine(name, tuple(args), expr, str(key), domain={a: tuple(domain[a]) for a in args}))
        )
        keys[name] = key
    return Program(tuple(routines), (), (), name="fitlab_expressions"), keys


def time_expressions(
    exprs: dict, inputs: dict | None = None, n: int = 200_000, repeat: int = 5, seed: int = 0, workdir=None
) -> dict:
    """ns per evaluation, {key: (double, float)}, of expressions {key: (args, expr, domain)} printed in C
    (:func:`expressions_program`), compiled with the strict flags (:func:`fitlab.codegen.native.build`, in
    ``workdir`` or a temporary folder) and timed in one interleaved run (:func:`time_routines`).  An argument
    has the values ``inputs`` gives it by name, else ``n`` (or the length of the given ones) drawn uniformly in
    its domain with ``numpy.random.default_rng(seed)``, argument by argument in routine order.  A program that
    does not compile raises :class:`fitlab.codegen.native.CompileError`."""
    import contextlib
    import tempfile
    from pathlib import Path

    from fitlab.codegen.languages import emit
    from fitlab.codegen.native import build

    if not exprs:
        return {}
    program, keys = expressions_program(exprs)
    inputs = dict(inputs or {})
    count = len(next(iter(inputs.values()))) if inputs else n
    rng = np.random.default_rng(seed)
    for r in program.routines:
        for a in r.signature():
            if a not in inputs:
                lo, hi = r.domain[a]
                inputs[a] = rng.uniform(float(lo), float(hi), count)
    folder = (
        contextlib.nullcontext(workdir)
        if workdir is not None
        else tempfile.TemporaryDirectory(prefix="fitlab-expressions-")
    )
    with folder as where:
        lib = build(emit(program, "c"), program, Path(where) / "expressions")
        cases = {(name, dt): (lib, name, [inputs[a] for a in program.routine(name).signature()], dt)
                 for name in keys for dt in (np.float64, np.float32)}  # fmt: skip
        ns = time_routines(cases, repeat)
    return {key: (ns[(name, np.float64)], ns[(name, np.float32)]) for name, key in keys.items()}
