r"""Benchmark (not a test): what a discovered form costs in the generated C, beside the form it
would replace.

Each variant's program is built once (``fitlab codegen``'s program and C back end), compiled with
the strict flags, and the target's routine (:attr:`fitlab.core.Target.routine`) is timed in its C
loop over the same random inputs, best of ``repeat`` (:func:`fitlab.timing.best_seconds`); variants
are timed in one run, so only their ratios carry meaning.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from fitlab.codegen import DEFAULT_FORMS, emit, load_program
from fitlab.codegen.native import build, compiler
from fitlab.core import get_target, targets
from fitlab.timing import best_seconds

__all__ = ["routine_cost", "COST_ROUNDS", "COST_REPEAT"]

#: interleaved rounds, and timings per round, of each variant (the best of all is kept)
COST_ROUNDS = 2
COST_REPEAT = 7


def _inputs(names, n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.0, 1.0, n) if name == "cos_phi" else rng.random(n) for name in names]


def routine_cost(target: str, forms: list[str | None], fits_dir: Path | None = None, n: int = 200_000,
                 repeat: int = COST_REPEAT, dtype=np.float64) -> dict[str, float]:  # fmt: skip
    """ns per evaluation of ``target``'s routine for each form (None: the default form)."""
    routine = get_target(target).routine if target in targets() else None
    if routine is None:
        with_routine = [t.name for t in targets().values() if t.routine is not None]
        raise KeyError(f"no generated routine for {target!r}; targets: {', '.join(with_routine)}")
    if compiler() is None:
        raise RuntimeError("no C compiler found (cc, gcc or clang)")
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        models, names = {}, ()
        for k, form in enumerate(forms):
            program = load_program(
                fits_dir,
                forms={} if form is None else {target: form},
                family=get_target(target).family,
                model=DEFAULT_FORMS,
            )
            models[form] = build(emit(program, "c"), program, Path(tmp) / f"v{k}")
            names = program.routine(routine).signature()
        args = [np.ascontiguousarray(a, dtype=dtype) for a in _inputs(names, n)]
        for _ in range(COST_ROUNDS):  # interleaved rounds: drift in machine load hits every variant alike
            for form, model in models.items():
                t = best_seconds(lambda model=model: model(routine, *args, dtype=dtype), repeat) / n * 1e9
                out[form or "default"] = min(out.get(form or "default", np.inf), t)
    return out
