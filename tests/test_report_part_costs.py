"""The report times a part no family program prints (the Fresnel targets, a richer form) as its form with its
numbers in a routine of its own: that routine computes what the part's method computes, and is timed."""

from __future__ import annotations

import numpy as np
import pytest

from fitlab.codegen import emit
from fitlab.codegen.bench import expressions_program
from fitlab.codegen.native import build, compiler
from fitlab.report.methods import fit_inventory, part_methods
from fitlab.report.programs import form_costs, form_expressions
from fitlab.store import fits_folder

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler")


@pytest.fixture(scope="module")
def methods():
    entries = fit_inventory(fits_folder(None))
    return [pm for target in ("F_cu_r", "F_au_r", "H0", "E_ggx_cor") for pm in part_methods(target, entries)]


def test_each_routine_computes_its_methods_values(methods, tmp_path):
    program, keys = expressions_program(form_expressions(methods))
    assert program.routines
    lib = build(emit(program, "c"), program, tmp_path)
    by_key = {pm.c_key: pm for pm in methods}
    rng = np.random.default_rng(3)
    for name, key in keys.items():
        pm = by_key[key]
        args = program.routine(name).signature()
        lo_hi = [pm.form_routine[2][a] for a in args]
        x = [rng.uniform(lo, hi, 200) for lo, hi in lo_hi]
        c = lib(name, *x, dtype=np.float64)
        py = pm.evaluate(**dict(zip(args, x, strict=True)))
        assert np.allclose(c, py, rtol=1e-12, atol=1e-14), (key, np.abs(c - py).max())
    # every published preset and fit of a Fresnel target gets a routine
    assert {k for k in keys.values() if k[0] == "F_cu_r"} == {pm.c_key for pm in methods if pm.target == "F_cu_r"}


def test_form_costs_times_every_routine(methods, tmp_path):
    """Every routine is timed, those of a family whose inputs the timing inputs lack (alpha) included."""
    from fitlab.report.programs import timing_inputs

    ns, notes = form_costs(methods, tmp_path, timing_inputs(2000, None), 2)
    assert notes == []
    assert set(ns) == {pm.c_key for pm in methods if pm.form_routine is not None}
    assert all(np.isfinite(d) and d > 0 and np.isfinite(f) and f > 0 for d, f in ns.values())
