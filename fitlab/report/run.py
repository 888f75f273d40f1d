r"""Run the whole report: catalogue, accuracy, cost, exact engine, Monte Carlo, refits.

:func:`build_report` measures and returns a :class:`Report` (rows for the CSV,
the recommendations and the context the markdown needs); it writes nothing.
Everything that can fail on bad input (fits folder, fit files, tables) fails
before the slow work.
"""

from __future__ import annotations

import math
import os
import platform
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fitlab.codegen.native import STRICT_FLAGS, compiler
from fitlab.core import get_target
from fitlab.numerics import single_threaded_blas
from fitlab.report.accuracy import brdf_accuracy, part_accuracy
from fitlab.report.cost import jax_costs, numpy_costs
from fitlab.report.methods import (
    ReportError,
    brdf_methods,
    brdf_report,
    family_reports,
    fit_group,
    fit_inventory,
    part_methods,
    preset_variants,
    report_parts,
)
from fitlab.report.pareto import recommend
from fitlab.report.programs import c_costs, form_costs, timing_inputs
from fitlab.report.refits import recorded_seconds, refit_costs, refit_jobs
from fitlab.report.settings import FULL, Settings, family_settings
from fitlab.report.validation import fresh_set, validation_sets
from fitlab.store import TableError, fits_folder

__all__ = ["Report", "build_report"]

NAN = math.nan


@dataclass
class Report:
    settings: Settings
    rows: list  # dicts with the columns of fitlab.report.write.COLUMNS
    recommendations: dict  # use -> BRDF row (or None)
    context: dict = field(default_factory=dict)
    #: the settings of the family whose BRDF the report measures (fitlab.report.settings.family_settings)
    family_settings: Any = None


def _check_tables(data_dir: Path) -> None:
    """Every family's tables (its ``check_tables``), in ``data_dir`` or where the family reads them."""
    for hook in family_reports().values():
        try:
            hook.check_tables(hook.tables_dir(data_dir))
        except TableError as exc:
            raise ReportError(str(exc)) from None


class _Progress:
    """One tqdm bar whose total grows as each stage announces its steps."""

    def __init__(self, enabled: bool):

        self.bar = tqdm(total=0, desc="report", unit="step", disable=not enabled)

    def stage(self, desc: str, steps: int) -> None:
        self.bar.set_description(desc)
        self.bar.total += steps
        self.bar.refresh()

    def tick(self) -> None:
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


def _brdf_rows(methods, acc, c_ns, py_ns, jax_tp) -> list[dict]:
    rows = []
    for m in methods:
        a = acc[m.name]
        w = a["worst"]
        rows.append({
            "section": "brdf", "target": "f_r", "group": m.group, "method": m.name, "source": m.source,
            "points": a["points"], "max_rel": a["max_rel"], "rms_rel": a["rms_rel"],
            "max_rel_away": a["max_rel_away"], "max_rel_grazing": a.get("max_rel_grazing", NAN),
            "max_abs_c0": a.get("max_abs_c0", NAN), "max_rel_fresh": a.get("max_rel_fresh", NAN),
            "rms_rel_fresh": a.get("rms_rel_fresh", NAN), "albedo_err": a.get("albedo_err", NAN), "bytes": m.bytes,
            "ns_c_double": c_ns.get(m.name, (NAN, NAN))[0], "ns_c_float": c_ns.get(m.name, (NAN, NAN))[1],
            "ns_python": py_ns.get(m.name, NAN), "jax_evals_per_s": jax_tp.get(m.name, NAN),
            "note": "worst at " + ", ".join(f"{k}={v:.4g}" for k, v in w.items())
                    + ("; grazing worst at " + ", ".join(f"{k}={v:.4g}" for k, v in a["worst_grazing"].items())
                       if "worst_grazing" in a else ""),
        })  # fmt: skip
    return rows


def _part_rows(settings, entries, data_dir, part_ns, inputs, tick) -> tuple[list[dict], list[str]]:

    by_target = {name: part_methods(name, entries, data_dir) for name in settings.parts}
    untimed = [pm for pms in by_target.values() for pm in pms if pm.c_key not in part_ns]
    with tempfile.TemporaryDirectory(prefix="fitlab-report-parts-") as tmp:
        own_ns, notes = form_costs(untimed, Path(tmp), inputs, settings.repeat)
    rows = []
    for name, pms in by_target.items():
        t = get_target(name)
        for pm in pms:
            a = part_accuracy(pm, t)
            ns = part_ns.get(pm.c_key, own_ns.get(pm.c_key, (NAN, NAN))) if pm.c_key else (NAN, NAN)
            rows.append({"section": "part", "target": name, "group": pm.group, "method": pm.name,
                         "source": pm.source, "points": a["points"], "max_rel": a["max_rel"],
                         "max_rel_nonzero": a["max_rel_nonzero"], "rms_rel": a["rms_rel"], "ns_c_double": ns[0],
                         "ns_c_float": ns[1], "note": t.error_measure.split(":")[0]})  # fmt: skip
        tick()
    return rows, notes


def _refit_rows(entries, settings, fits_dir, progress) -> list[dict]:

    jobs = refit_jobs(entries, settings.refits)
    progress.stage("refits", len(jobs))
    costs = refit_costs(jobs, fits_dir, progress.tick)
    rows = [
        {
            "section": "refit",
            "target": r["target"],
            "group": "refit",
            "method": r["form"],
            "source": r["path"],
            "max_rel": r["max_rel"],
            "seconds": r["seconds"],
            "note": f"{r['steps']} steps; the file records max rel {r['recorded_max_rel']:.4g}",
        }
        for r in costs
    ]
    if settings.refits is None:
        for e in entries:
            if e.kind != "refit":
                rows.append({"section": "refit", "target": e.target, "group": fit_group(e), "method": e.form,
                             "source": str(e.path), "max_rel": e.max_rel, "seconds": recorded_seconds(e.record),
                             "note": f"made by {e.kind}: its one-off cost is the search, not timed here "
                                     "(seconds: as its record states, if it does)"})  # fmt: skip
    return rows


def _resolved(settings: Settings) -> Settings:
    """``settings`` with None replaced: the parts and the refits by the family's choice where its report settings
    make one (``parts``, ``refits``), the parts and the preset variants by every one the families name."""
    fam = family_settings(settings, brdf_report())
    if settings.parts is None and getattr(fam, "parts", None) is not None:
        settings = replace(settings, parts=tuple(fam.parts))
    if settings.refits is None and getattr(fam, "refits", None) is not None:
        settings = replace(settings, refits=tuple(fam.refits))
    if settings.parts is None:
        settings = replace(settings, parts=report_parts())
    if settings.preset_c is None:
        settings = replace(settings, preset_c=preset_variants())
    return settings


def build_report(settings: Settings = FULL, fits_dir: Path | None = None, data_dir: Path | None = None,
                 use_cache: bool = True, progress: bool = True) -> Report:  # fmt: skip
    """Measure everything :mod:`fitlab.report` describes; returns the rows (writes nothing).
    ``fits_dir``: the fits measured (None: the packaged fits); ``data_dir``: the exact tables (None: where
    each family reads them, :mod:`fitlab.resources`).

    Bad input (the fits folder, a fit file, the tables) fails here, before any slow work."""

    t_start = time.perf_counter()
    settings = _resolved(settings)
    fits_dir = fits_folder(fits_dir)
    data_dir = Path(data_dir) if data_dir is not None else None
    entries = fit_inventory(fits_dir)
    _check_tables(data_dir)
    p = _Progress(progress)
    try:
        with single_threaded_blas():
            rows, context = _measure(settings, entries, fits_dir, data_dir, use_cache, p)
    finally:
        p.close()
    import jax

    context.update(wall_seconds=time.perf_counter() - t_start, fits_dir=str(fits_dir),
                   machine=f"{platform.machine()}, {os.cpu_count()} CPUs, BLAS on 1 thread, JAX on "
                           f"{jax.default_backend()}")  # fmt: skip
    return Report(
        settings,
        rows,
        recommend([r for r in rows if r["section"] == "brdf"]),
        context,
        family_settings(settings, brdf_report()),
    )


def _measure(settings, entries, fits_dir, data_dir, use_cache, p) -> tuple[list, dict]:
    hook = brdf_report()  # the family's exact engine and Monte Carlo

    fam = family_settings(settings, hook)
    n_materials = (
        hook.validation_materials(fam)[0].size
        + hook.fresh_materials(np.random.default_rng(settings.fresh_seed), fam)[0].size
    )
    p.stage("validation set", n_materials)
    valid, grazing = validation_sets(settings, use_cache, p.tick)
    fresh = fresh_set(settings, use_cache, p.tick)
    energy_mu = np.maximum(np.linspace(0.0, 1.0, settings.energy_mu), 1e-3)
    energy_c, energy_materials = hook.energy_materials(fam)
    energy = (energy_mu, energy_c, hook.exact_kd(energy_c), [hook.exact_albedo(energy_mu, cv) for cv in energy_c],
              hook.directional_albedo)  # fmt: skip
    p.stage("catalogue", 1)
    methods = brdf_methods(fits_dir, entries, data_dir, settings.preset_c, settings.discovered_brdf)
    if not settings.all_c:
        methods = [m if m.group in ("refit", "baseline") else replace(m, c=None) for m in methods]
    p.tick()
    p.stage("BRDF accuracy", len(methods))
    acc = {}
    for m in methods:
        acc[m.name] = brdf_accuracy(m, valid, grazing, fresh, energy)
        p.tick()
    p.stage("C cost", len({m.c.program_key for m in methods if m.c is not None}))
    c_inputs = timing_inputs(settings.c_points, data_dir)
    with tempfile.TemporaryDirectory(prefix="fitlab-report-") as tmp:
        c_ns, part_ns, notes = c_costs(methods, Path(tmp), c_inputs, settings.repeat, p.tick)
    py_inputs = timing_inputs(settings.numpy_points, data_dir)
    p.stage("numpy cost", settings.repeat)
    py_ns = numpy_costs([m for m in methods if m.timed], py_inputs, settings.repeat, p.tick)
    jax_methods = [m for m in methods if m.expr is not None and (settings.all_jax or m.group == "refit")]
    p.stage("JAX throughput", len(jax_methods))
    jax_tp = jax_costs(jax_methods, timing_inputs(settings.jax_points, data_dir), settings.repeat, p.tick)
    rows = _brdf_rows(methods, acc, c_ns, py_ns, jax_tp)
    p.stage("parts", len(settings.parts))
    parts, part_notes = _part_rows(settings, entries, data_dir, part_ns, c_inputs, p.tick)
    rows += parts
    notes = notes + part_notes
    # the family's own engines (for the Lambert sphere the exact engine and Monte Carlo): their rows, and what
    # its sections of report.md read from the context
    engine_rows, engine_context = hook.measure_engines(settings, fam, py_inputs, p)
    rows += engine_rows
    rows += _refit_rows(entries, settings, fits_dir, p)
    counts = {}
    for e in entries:
        g = fit_group(e)
        counts[g] = counts.get(g, 0) + 1

    context = {
        "c_compiler": f"{Path(compiler() or 'no C compiler').name} {' '.join(STRICT_FLAGS)}",
        "fits": counts,
        "validation": valid.grid, "validation_points": len(valid), "grazing": grazing.grid,
        "grazing_points": len(grazing), "fresh": fresh.grid, "fresh_points": len(fresh),
        "energy": f"directional albedo at {energy_materials} x {settings.energy_mu} incident cosines uniform on "
                  "[0, 1] (0 read as 1e-3), against the exact one",
        "notes": notes, **engine_context, "exact_source": hook.SOURCES["exact"],
        "c_points": settings.c_points, "repeat": settings.repeat,
        "jax_points": settings.jax_points, "numpy_points": settings.numpy_points,
    }  # fmt: skip
    return rows, context
