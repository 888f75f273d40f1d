r"""Benchmark (not a test): what a discovered form costs in the generated C, beside the form it
would replace.

Each variant's fits are generated (``fitlab codegen``'s program and C back end), compiled with the
strict flags, and one routine is timed in its C loop over the same random inputs, best of
``repeat``; variants are timed in one run, so only their ratios carry meaning.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

__all__ = ["routine_cost", "ROUTINE_OF_TARGET", "COST_ROUNDS", "COST_REPEAT"]

#: interleaved rounds, and timings per round, of each variant (the best of all is kept)
COST_ROUNDS = 2
COST_REPEAT = 7

#: the generated routine that evaluates each target, and its arguments
ROUTINE_OF_TARGET = {
    "H0": ("h0", ("mu", "c")),
    "H1": ("h1", ("mu", "c")),
    "kd_of_c": ("kd_of_c", ("c",)),
    "c_of_kd": ("c_of_kd", ("kd",)),
    "fast_brdf": ("brdf_fast", ("mu_i", "mu_o", "cos_phi", "c", "kd")),
}


def _inputs(names, n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.0, 1.0, n) if name == "cos_phi" else rng.random(n) for name in names]


def routine_cost(target: str, forms: list[str | None], fits_dir: Path = Path("fits"), n: int = 200_000,
                 repeat: int = COST_REPEAT, dtype=np.float64) -> dict[str, float]:  # fmt: skip
    """ns per evaluation of ``target``'s routine for each form (None: the default form)."""
    from fitlab.codegen import generate
    from fitlab.codegen.bench import _best
    from fitlab.codegen.native import build, compiler
    from fitlab.codegen.program import build_program

    if target not in ROUTINE_OF_TARGET:
        raise KeyError(f"no generated routine for {target!r}; targets: {', '.join(ROUTINE_OF_TARGET)}")
    if compiler() is None:
        raise RuntimeError("no C compiler found (cc, gcc or clang)")
    routine, names = ROUTINE_OF_TARGET[target]
    args = [np.ascontiguousarray(a, dtype=dtype) for a in _inputs(names, n)]
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        models = {}
        for k, form in enumerate(forms):
            chosen = {} if form is None else {target: form}
            program = build_program(Path(fits_dir), forms=chosen)
            models[form] = build(generate("c", fits_dir, forms=chosen), program, Path(tmp) / f"v{k}")
        for _ in range(COST_ROUNDS):  # interleaved rounds: drift in machine load hits every variant alike
            for form, model in models.items():
                t = _best(lambda: model(routine, *args, dtype=dtype), repeat) / n * 1e9
                out[form or "default"] = min(out.get(form or "default", np.inf), t)
    return out
