r"""Benchmark (not a test): what the generated BRDF costs per evaluation.

The generated C (full runtime model, fast variant) and two baselines compiled
the same way (Lambert kd/pi; qualitative Oren-Nayar, sigma = 0.5), each from
one sympy expression through the same printer, are timed on the same random
inputs in a C loop (no Python per element), best of ``repeat`` rounds that
interleave the cases (:func:`time_routines`, the one C timing harness, also used
by ``fitlab report``; the timer is :mod:`fitlab.timing`); the generated numpy
module is timed vectorised over the same inputs.  Only ratios within one run
carry meaning.
"""

from __future__ import annotations

import importlib.util
import tempfile
from pathlib import Path

import numpy as np

from fitlab.codegen import load_program
from fitlab.codegen.emit import emit
from fitlab.codegen.native import build
from fitlab.codegen.program import Program, Routine
from fitlab.families.lambert_sphere.forms.baselines import BASELINE_INPUTS, LAMBERT, oren_nayar
from fitlab.timing import best_seconds, interleaved_best

__all__ = ["baseline_program", "bench_codegen", "random_inputs", "time_routines"]


def baseline_program() -> Program:
    """Lambert and Oren-Nayar (sigma = 0.5) from :mod:`fitlab.families.lambert_sphere.forms.baselines`, as routines."""
    return Program(
        (Routine("baseline_lambert", BASELINE_INPUTS, LAMBERT, "Lambert, kd/pi."),
         Routine("baseline_oren_nayar", BASELINE_INPUTS, oren_nayar(), "Oren-Nayar (qualitative), sigma = 0.5.")),
        (), (), name="baselines",
    )  # fmt: skip


def random_inputs(n: int, seed: int = 0) -> dict:
    """The benchmark's inputs: mu_i, mu_o, c uniform on [0, 1), cos_phi uniform on [-1, 1) (numpy, seeded)."""
    rng = np.random.default_rng(seed)
    mu_i, mu_o, c = rng.random(n), rng.random(n), rng.random(n)
    return {"mu_i": mu_i, "mu_o": mu_o, "c": c, "cos_phi": rng.uniform(-1, 1, n)}


def time_routines(cases: dict, repeat: int = 5) -> dict:
    """ns per evaluation of compiled routines: {key: (lib, routine name, arrays, dtype)} -> {key: ns}.

    Each array is converted to the case's dtype once, before any timing.  Each
    round calls every case's C loop once, in turn; a case's time is its best
    round.  Interleaving makes a change of machine load hit every case alike,
    so the ratios between cases hold even on a shared machine.
    """
    conv = {k: (lib, name, [np.ascontiguousarray(a, dtype=dt) for a in args], dt)
            for k, (lib, name, args, dt) in cases.items()}  # fmt: skip
    fns = {k: (lambda lib=lib, name=name, arrays=arrays, dt=dt: lib(name, *arrays, dtype=dt))
           for k, (lib, name, arrays, dt) in conv.items()}  # fmt: skip
    best = interleaved_best(fns, repeat)
    return {k: best[k] / conv[k][2][0].size * 1e9 for k in cases}


def bench_codegen(fits_dir: Path = Path("fits"), n: int = 1_000_000, repeat: int = 5) -> dict:
    prog = load_program(Path(fits_dir))
    base = baseline_program()
    x = random_inputs(n)
    mu_i, mu_o, c, cos_phi = x["mu_i"], x["mu_o"], x["c"], x["cos_phi"]
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        model = build(emit(prog, "c"), prog, Path(tmp) / "model")
        baselines = build(emit(base, "c"), base, Path(tmp) / "base")
        module = Path(tmp) / f"{prog.name}.py"
        module.write_text(emit(prog, "python")[module.name])
        spec = importlib.util.spec_from_file_location("bench_generated", module)
        py = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(py)
        kd = py.kd_of_c(c)
        cases = {
            "lambert (baseline)": (baselines, "baseline_lambert", (mu_i, mu_o, cos_phi, kd)),
            "oren_nayar (baseline)": (baselines, "baseline_oren_nayar", (mu_i, mu_o, cos_phi, kd)),
            "brdf_fast (eq. 41)": (model, "brdf_fast", (mu_i, mu_o, cos_phi, c, kd)),
            "brdf (runtime model)": (model, "brdf", (mu_i, mu_o, cos_phi, c)),
        }
        timed = time_routines({(label, "C " + np.dtype(dt).name): (lib, name, args, dt)
                               for label, (lib, name, args) in cases.items() for dt in (np.float64, np.float32)},
                              repeat)  # fmt: skip
        rows.update(timed)
        for label, fn, args in (("brdf (runtime model)", py.brdf, (mu_i, mu_o, cos_phi, c)),
                                ("brdf_fast (eq. 41)", py.brdf_fast, (mu_i, mu_o, cos_phi, c, kd))):  # fmt: skip
            rows[(label, "numpy float64")] = best_seconds(lambda: fn(*args), max(1, repeat // 2)) / n * 1e9
    ref = rows[("lambert (baseline)", "C float64")]
    print(f"generated BRDF cost, {n} random inputs, best of {repeat} (ns per evaluation; x = / Lambert C double)")
    for (label, how), ns in rows.items():
        print(f"  {label:<24} {how:<14} {ns:8.2f} ns  {ns / ref:7.1f} x")
    return {f"{label} / {how}": ns for (label, how), ns in rows.items()}
