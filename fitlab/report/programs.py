r"""Cost of the generated C: build each program the catalogue needs once, time its routines.

One harness for everything (:func:`fitlab.codegen.bench.time_routines`, the harness
of ``fitlab bench codegen``): the generated C compiled with
:data:`fitlab.codegen.native.STRICT_FLAGS`, called in a C loop over the same
seeded random inputs (the family's ``timing_inputs``; kd =
kd_true(c) from the tables, H-parts at mu = mu_i), in double and in float, best
of ``repeat`` rounds that interleave every routine of every program.  Published
presets are printed from their fit records
(:func:`fitlab.report.methods.preset_records`), which go straight into
:func:`fitlab.codegen.build_program`.  A program that cannot be built (no
compiler) leaves its columns empty and says why.  A part no program prints (a target of a family
without one, a richer form, a published preset of a part) is timed as a routine of its own, its form with
its numbers (:func:`form_costs`), in one more program and run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fitlab.codegen import DEFAULT_FORMS, build_program, emit, load_program
from fitlab.codegen.bench import time_expressions, time_routines
from fitlab.codegen.native import CompileError, build
from fitlab.core import get_target
from fitlab.report.methods import CSpec, brdf_report, preset_records

__all__ = ["c_costs", "form_costs", "form_expressions", "timing_inputs"]


def timing_inputs(n: int, data_dir: Path) -> dict:
    """Seeded random inputs by argument name, from the measured family's report
    (``timing_inputs(n, data_dir)``)."""
    return brdf_report().timing_inputs(n, data_dir)


def _program(spec: CSpec):
    """(Program, {routine: (target, label)}) for a spec's program; the labels name its part routines."""
    if spec.build is not None:
        return spec.build()[0], {}
    if spec.fits_dir is None and spec.preset is None:
        return brdf_report().baseline_program(), {}
    if spec.preset is not None:
        records = preset_records(spec.preset)
        prog = build_program({t: rec for (t, _), rec in records.items()})
        labels = {get_target(t).routine: (t, f"{f} / {r['origin']['preset']}")
                  for (t, f), r in records.items() if t in prog.parts}  # fmt: skip
        return prog, labels
    forms = dict(spec.forms)
    prog = load_program(Path(spec.fits_dir), forms=forms, model=DEFAULT_FORMS)
    labels = {get_target(t).routine: (t, forms.get(t, get_target(t).default_form)) for t in prog.parts}
    return prog, labels


def form_expressions(part_methods) -> dict:
    """{c_key: (args, expression with its numbers, domain)} of the part methods that have a ``form_routine`` (the
    first of each c_key), for :func:`fitlab.codegen.bench.time_expressions`."""
    out = {}
    for pm in part_methods:
        if pm.form_routine is not None and pm.c_key is not None and pm.c_key not in out:
            out[pm.c_key] = pm.form_routine
    return out


def form_costs(part_methods, workdir: Path, inputs: dict, repeat: int) -> tuple[dict, list]:
    """ns per evaluation (double, float) of each part method's form with its numbers as a routine of its own
    (:func:`form_expressions`), all timed in one interleaved run: {c_key: (ns double, ns float)}, and notes (a
    program that does not compile is noted, not timed).  For the parts no family program times (a family without
    one, a richer form).  An input the measured family's timing inputs lack (another family's: alpha) is drawn
    uniformly in the routine's domain, seeded, as many points as the others."""
    try:
        return time_expressions(form_expressions(part_methods), inputs, repeat=repeat, workdir=workdir), []
    except CompileError as exc:
        return {}, [f"C not timed for the parts' own routines: {str(exc).splitlines()[0]}"]


def c_costs(methods, workdir: Path, inputs: dict, repeat: int, tick=None) -> tuple[dict, dict, list]:
    """Build every program the methods' C specs name (``tick()`` after each), then time every method's C
    routine and the part routines of the same programs in one interleaved harness run.

    Returns ({method name: (ns double, ns float)}, {(target, label): (ns double, ns float)}, notes).
    """
    workdir = Path(workdir)
    by_key = {}
    for m in methods:
        if m.c is not None:
            by_key.setdefault(m.c.program_key, (m.c, []))[1].append(m)
    cases, notes = {}, []
    for k, (key, (spec, ms)) in enumerate(sorted(by_key.items(), key=lambda kv: repr(kv[0]))):
        try:
            prog, labels = _program(spec)
            files = spec.build()[1] if spec.build is not None else emit(prog, "c")
            lib = build(files, prog, workdir / f"program_{k}")
        except CompileError as exc:
            notes.append(f"C not timed for {', '.join(m.name for m in ms)}: {str(exc).splitlines()[0]}")
            if tick:
                tick()
            continue
        jobs = [(("method", m.name), m.c.routine) for m in ms]
        jobs += [(("part", label), routine) for routine, label in labels.items()
                 if not any(key[0] == ("part", label) for key in cases)]  # fmt: skip
        for what, routine in jobs:
            args = [inputs[a] for a in prog.routine(routine).signature()]
            for dt in (np.float64, np.float32):
                cases[(what, dt)] = (lib, routine, args, dt)
        if tick:
            tick()
    ns = time_routines(cases, repeat)
    costs, parts = {}, {}
    for what in dict.fromkeys(w for w, _ in cases):
        kind, name = what
        (costs if kind == "method" else parts)[name] = (ns[(what, np.float64)], ns[(what, np.float32)])
    return costs, parts, notes
