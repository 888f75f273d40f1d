r"""The Lambert sphere's own engines in ``fitlab report``: the exact engine (its H-functions at two resolutions
of both methods, its BRDF's cost at a new albedo, the agreement of its two methods, the three-term engine
against discrete ordinates + doubling, the time to reach an error) and Monte Carlo at several path counts, as
the report's rows (the columns of :data:`fitlab.report.write.COLUMNS`) and the context its sections of
report.md read (:mod:`.markdown`).  The family's report (:mod:`.methods`) gives :func:`measure_engines` to the
generic report, which knows no family.
"""

from __future__ import annotations

import math

from fitlab.families.lambert_sphere.program.report.claims import claim_rows
from fitlab.families.lambert_sphere.program.report.exact_engine import (
    doubling_agreement,
    engine_agreement,
    exact_brdf_cost,
    h_convergence,
    time_to_error,
)
from fitlab.families.lambert_sphere.program.report.montecarlo import mc_study, mc_time_to_error

__all__ = ["SOURCES", "measure_engines"]

NAN = math.nan
#: what the report's exact-engine and Monte Carlo rows measured (their "source" column)
SOURCES = {
    "exact": "fitlab.families.lambert_sphere.exact.brdf (phase 'true': the whole phase function)",
    "exact_agreement": "fitlab.families.lambert_sphere.exact.true_phase (methods 'newton' and 'doubling')",
    "doubling": "fitlab.families.lambert_sphere.exact.doubling_reflection (three-term phase function)",
    "h": "fitlab.families.lambert_sphere.exact.hfunction",
    "monte carlo": "fitlab.families.lambert_sphere.mc (three-term multiple scattering)",
}


def measure_engines(settings, fam, inputs: dict, progress) -> tuple[list[dict], dict]:
    """(rows, context) of the exact engine and Monte Carlo, measured as hard as the family's report settings
    ``fam`` say (:class:`.settings.EngineSettings`); ``settings`` the report's (its error targets, repeats and
    seed), ``inputs`` the numpy timing inputs (the exact BRDF's cost is timed on the first
    ``fam.exact_cost_points``); ``progress.stage(name, steps)`` and ``progress.tick()`` show the stages."""
    progress.stage("exact engine", len(fam.nystrom_nodes) + len(fam.fock_steps) + 2)
    conv = h_convergence(fam.exact_orders, fam.exact_c, fam.exact_mu_points, fam.nystrom_nodes, fam.fock_steps,
                         tick=progress.tick)  # fmt: skip
    brdf_cost = exact_brdf_cost(inputs, settings.repeat, fam.exact_cost_points)
    progress.tick()
    dbl = doubling_agreement(fam.doubling_c, fam.doubling_orders) if fam.doubling_orders else None
    agree = engine_agreement(fam.doubling_c, fam.doubling_orders) if fam.doubling_orders else None
    progress.tick()
    rows = _exact_rows(brdf_cost, agree, dbl, conv, time_to_error(conv, settings.error_targets), SOURCES)
    progress.stage("Monte Carlo", len(fam.mc_paths))
    study = mc_study(fam, progress.tick, seed=settings.seed)
    rows += _mc_rows(study, [e for e in settings.error_targets if e >= 1e-3], mc_time_to_error, SOURCES)
    rows += claim_rows()  # what the generated code states (report.md's section of it: .claims)
    return rows, {"exact_cost": brdf_cost, "doubling": dbl, "engine_agreement": agree, "mc": study}


def _exact_rows(brdf_cost, engine, dbl, conv, ttes, src) -> list[dict]:
    """The exact engine's rows; ``engine``: the agreement of its two methods; ``dbl``: the three-term engine's
    agreement with discrete ordinates + doubling; ``src``: the family's ``SOURCES`` (what each row measured)."""
    agree = engine or {"max_rel": NAN, "rms_rel": NAN, "points": 0}
    where = (f"error: agreement of its two methods ({src['exact_agreement']}; c = {engine['c']:g}, orders "
             f"{', '.join(map(str, engine['orders']))}, {engine['node_pairs']} pairs with mu_i, mu_o >= 1e-3, "
             "relative to the BRDF)" if engine else "error not measured (skipped)")  # fmt: skip
    rows = [{
        "section": "brdf", "target": "f_r", "group": "exact", "method": "exact engine", "source": src["exact"],
        "points": agree["points"], "max_rel": agree["max_rel"], "rms_rel": agree["rms_rel"],
        "max_rel_away": agree["max_rel"], "ns_python": brdf_cost["ns_per_point"], "seconds": brdf_cost["setup_seconds"],
        "note": where + "; cost: ns per point once c is set up, seconds: the set-up at a new c",
    }]  # fmt: skip
    if dbl:
        rows.append({
            "section": "exact", "target": "f^m", "group": "exact", "method": "discrete ordinates + doubling",
            "source": src["doubling"], "points": dbl["points"], "max_rel": dbl["max_rel"],
            "rms_rel": dbl["rms_rel"], "seconds": dbl["seconds_per_order"],
            "ns_python": dbl["seconds_per_order"] / dbl["node_pairs"] * 1e9,
            "note": f"the three-term engine (the paper's model): f^m at {dbl['node_pairs']} node pairs per (c, order); "
                    "error: against its H route",
        })  # fmt: skip
    if engine:
        rows.append({
            "section": "exact", "target": "fm^m", "group": "exact", "method": "doubling, whole phase function",
            "source": src["exact_agreement"], "points": engine["points"], "max_rel": engine["max_rel"],
            "rms_rel": engine["rms_rel"], "seconds": engine["seconds_per_order"],
            "note": "the exact engine's second method: seconds per (c, order), its solve; error: against Newton, "
                    "relative to the BRDF",
        })  # fmt: skip
    for r in conv:
        rows.append({"section": "exact_h", "target": "H0, H1", "group": "exact",
                     "method": f"{r['method']}, {r['resolution']}", "source": src["h"],
                     "points": r["points"], "max_rel": r["max_rel"], "rms_rel": r["rms_rel"], "seconds": r["seconds"],
                     "note": "error against the other method at its default; seconds per (order, c): one solve "
                             "and the evaluation at the mu points"})  # fmt: skip
    rows.append({"section": "time_to_error", "target": "f_r", "group": "exact", "method": "exact engine (BRDF)",
                 "target_error": agree["max_rel"], "max_rel": agree["max_rel"],
                 "seconds": brdf_cost["setup_seconds"] + brdf_cost["ns_per_point"] * 1e-9,
                 "note": "one value at a new c, set-up included (further points at that c: the exact engine's "
                         "Python ns)"})  # fmt: skip
    for t in ttes:
        rows.append({"section": "time_to_error", "target": "H", "group": "exact", "method": t["method"],
                     "target_error": t["target"], "max_rel": t["max_rel"], "seconds": t["seconds"],
                     "note": t["resolution"]})  # fmt: skip
    return rows


def _mc_rows(study, targets, mc_time_to_error, src) -> list[dict]:
    rows = []
    for s in study:
        rows.append({
            "section": "brdf", "target": "f_r (bin averages)", "group": "monte carlo",
            "method": f"Monte Carlo {s['paths']:.0e} paths", "source": src["monte carlo"],
            "points": s["values"], "paths": s["paths"], "max_rel": s["max_rel"], "rms_rel": s["rms_rel"],
            "max_rel_away": s["max_rel"], "ns_python": s["ns_per_value"], "seconds": s["seconds"],
            "note": f"{s['jobs']} jobs x {s['paths']} paths; RMS se/exact {s['se_rms']:.3g}; error against exact "
                    "bin averages; ns per BRDF value",
        })  # fmt: skip
    for eps in targets:
        t = mc_time_to_error(study, eps)
        rows.append({"section": "time_to_error", "target": "f_r (bin averages)", "group": "monte carlo",
                     "method": "Monte Carlo", "target_error": eps, "paths": t["paths"], "seconds": t["seconds"],
                     "note": f"RMS relative error, extrapolated from {study[-1]['paths']} paths per job; "
                             f"{study[-1]['values']} values"})  # fmt: skip
    return rows
