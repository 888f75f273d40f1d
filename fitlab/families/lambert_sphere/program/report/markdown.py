r"""The Lambert sphere's prose of ``fitlab report`` (report.md, :func:`fitlab.report.write.markdown`): the BRDF's
name, what its material columns mean, and the sections on its own engines (the exact engine, the time to
reach an error, Monte Carlo), rendered from the rows and context the family report's measurements gave.  The
report (:mod:`.methods`) gives them to the generic writer, which knows no family.
"""

from __future__ import annotations

from fitlab.families.lambert_sphere.program.report.claims import claim_section
from fitlab.report.write import ns, report_source, sci, section_rows

__all__ = ["BRDF_TITLE", "REPORT_TEXT", "engine_sections"]

#: the BRDF the report measures, as its title and plot name it
BRDF_TITLE = "Lambert-sphere BRDF"
#: the sentences of the report's accuracy paragraph that speak of the material and the parts
REPORT_TEXT = {
    "material": "kd = kd_true(c) where a method takes kd",
    "black": "At c = 0 the BRDF is exactly 0: max abs, c = 0 is max |f| at the set's points with c = 0.",
    "parts": (
        "Parts (H0, H1, constants, albedo maps, fm1): each target's validation set and error measure "
        "(`fitlab.families.lambert_sphere.targets`, as in docs/audit.md)."
    ),
}


def engine_sections(report) -> list[str]:
    """The report.md sections on what the generated code states (:mod:`.claims`) and on the family's engines: the
    exact engine, the time to reach an error, Monte Carlo (markdown lines)."""
    return [
        *claim_section(report.rows),
        "",
        *_exact_section(report),
        "",
        *_time_to_error(report.rows),
        "",
        *_mc_section(report),
    ]


def _exact_section(report) -> list[str]:
    ctx, rows, fs = report.context, report.rows, report.family_settings
    ec = ctx["exact_cost"]
    out = ["## The exact engine", "",
           f"`{report_source(report)}` at a new albedo: set-up "
           f"{ec['setup_seconds']:.2f} s, then {ec['ns_per_point'] / 1e3:.3g} us per point "
           f"({ec['points']} points, c = {ec['c']:.4f})."]  # fmt: skip
    agree = ctx.get("engine_agreement")
    if agree:
        out += [
            "",
            f"Its error, the agreement of its two methods (Newton and doubling-adding, c = {agree['c']:g}, "
            f"Fourier orders {', '.join(map(str, agree['orders']))} of the multiple scattering at "
            f"{agree['node_pairs']} pairs with mu_i, mu_o >= 1e-3, relative to the BRDF): max "
            f"{sci(agree['max_rel'])}, RMS {sci(agree['rms_rel'])}. Doubling costs "
            f"{agree['seconds_per_order']:.2f} s per (c, order).",
        ]
    dbl = ctx["doubling"]
    if dbl:
        out += [
            "",
            "The three-term engine (the paper's model; H-functions), measured against the independent "
            "discrete ordinates + doubling "
            f"(`fitlab.families.lambert_sphere.exact.doubling_reflection`, c = {dbl['c']:g}, Fourier orders "
            f"{', '.join(map(str, dbl['orders']))}, {dbl['points']} node pairs with mu_i, mu_o >= 1e-3): "
            f"max {sci(dbl['max_rel'])}, RMS {sci(dbl['rms_rel'])}. Doubling itself costs "
            f"{dbl['seconds_per_order']:.2f} s per (c, order) for f^m at {dbl['node_pairs']} node pairs.",
        ]
    out += ["", "H-functions by both methods at coarser and finer resolution, each against the other method at "
            "its default (16 nodes per panel; h = 0.1); seconds per (order, c): one solve and the evaluation "
            f"at {fs.exact_mu_points} mu, orders {', '.join(map(str, fs.exact_orders))}, "
            f"c = {', '.join(f'{c:g}' for c in fs.exact_c)}.", "",
            "| method, resolution | max rel | RMS rel | ms per (order, c) |", "|---|---|---|---|"]  # fmt: skip
    for r in section_rows(rows, "exact_h"):
        out.append(f"| {r['method']} | {sci(r['max_rel'])} | {sci(r['rms_rel'])} | {r['seconds'] * 1e3:.3g} |")
    return out


def _time_to_error(rows) -> list[str]:
    out = ["## Time to reach a given error", "",
           "Exact engine: the coarsest resolution whose max error (as above) is within the target, for H at one "
           "albedo and the mu points above. Monte Carlo: RMS relative error of the BRDF bin averages, "
           "extrapolated from the largest run by se ~ N^(-1/2); seconds for all the run's values.", "",
           "| method | target error | how | seconds |", "|---|---|---|---|"]  # fmt: skip
    for r in section_rows(rows, "time_to_error"):
        how = r["note"] if r["group"] == "exact" else f"{r['paths']:.3g} paths per job"
        out.append(f"| {r['method']} | {sci(r['target_error'])} | {how} | {ns(r['seconds'])} |")
    return out


def _mc_section(report) -> list[str]:
    s = report.family_settings
    out = ["## Monte Carlo", "",
           f"`fitlab.families.lambert_sphere.mc`: c = {', '.join(map(str, s.mc_c))}, "
           f"mu_i = {', '.join(map(str, s.mc_mu_i))}, mu_o bins "
           f"{list(s.mc_mu_edges)}, {s.mc_phi_bins} |phi| bins; three-term multiple scattering, single scattering "
           "in closed form; errors against the exact bin averages. Seconds exclude compilation.", "",
           "| paths per job | values | max rel | RMS rel | RMS se/exact | seconds | ns per value |",
           "|---|---|---|---|---|---|---|"]  # fmt: skip
    for m in report.context["mc"]:
        out.append(f"| {m['paths']} | {m['values']} | {sci(m['max_rel'])} | {sci(m['rms_rel'])} | {sci(m['se_rms'])} | "
                   f"{m['seconds']:.3g} | {m['ns_per_value']:.3g} |")  # fmt: skip
    return out
