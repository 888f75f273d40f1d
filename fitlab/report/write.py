r"""The report's files: report.csv (every number), report.md (tables), accuracy_vs_cost.png.

:func:`write_outputs` renders all three in memory, then writes them as one
unit (:func:`fitlab._io.atomic_write_many`): a failure while writing leaves all
three as they were; only the final renames, each atomic, happen one by one.
Every column of the CSV but :data:`TIMING_COLUMNS` is reproducible run to run.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from pathlib import Path

from fitlab._io import atomic_write_many
from fitlab.report.methods import GROUPS, brdf_report
from fitlab.report.pareto import RULES, pareto_front
from fitlab.report.plot import plot_cost, plot_png

__all__ = [
    "COLUMNS",
    "TIMING_COLUMNS",
    "FILES",
    "csv_text",
    "markdown",
    "parts_table",
    "as_shown",
    "write_outputs",
    "report_source",
    "section_rows",
    "sci",
    "ns",
]

#: the CSV's columns; ``section`` says what a row is (brdf, part, exact, exact_h, time_to_error, refit)
COLUMNS = ("section", "target", "group", "method", "source", "points", "paths", "target_error", "max_rel",
           "max_rel_nonzero", "rms_rel", "max_rel_away", "max_rel_grazing", "max_abs_c0", "max_rel_fresh",
           "rms_rel_fresh", "albedo_err", "bytes", "ns_c_double", "ns_c_float", "ns_python", "jax_evals_per_s",
           "seconds", "note")  # fmt: skip
#: the columns that hold timings (everything else is deterministic)
TIMING_COLUMNS = ("ns_c_double", "ns_c_float", "ns_python", "jax_evals_per_s", "seconds")
FILES = ("report.md", "accuracy_vs_cost.png", "report.csv")


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        if math.isnan(v):
            return ""
        return repr(v) if math.isfinite(v) else ("inf" if v > 0 else "-inf")
    return str(v)


def csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in COLUMNS])
    return buf.getvalue()


def sci(x) -> str:
    """A relative error as the report prints it (2 significant digits, "-" for none)."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return "inf" if math.isinf(x) else f"{x:.2e}"


def ns(x) -> str:
    """A time as the report prints it (3 significant digits, "-" for none)."""
    if x is None or math.isnan(x):
        return "-"
    if x < 100:
        return f"{x:.3g}"
    return f"{x:.0f}" if x < 1e6 else f"{x:.2e}"


def _bytes(x) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return f"{x:.0f}" if x < 1e4 else f"{x / 1e3:.1f} k"


def _rate(x) -> str:
    return "-" if x is None or math.isnan(x) else f"{x / 1e6:.3g}"


def section_rows(rows, name):
    """The report's rows of one ``section`` (the CSV's first column)."""
    return [r for r in rows if r["section"] == name]


def _front_marks(brdf) -> list[str]:
    xs = [plot_cost(r)[0] for r in brdf]
    marks = [[] for _ in brdf]
    for key, tag in (("max_rel", "max"), ("rms_rel", "RMS")):
        for i in pareto_front(xs, [r[key] for r in brdf]):
            marks[i].append(tag)
    return [", ".join(m) for m in marks]


def _brdf_table(brdf) -> list[str]:
    black = f"max abs, {brdf_report().BRDF_MATERIAL[0]} = 0"  # the black material's column
    out = [
        "| group | method | max rel | RMS rel | max rel, mu >= 1/64 | max rel, grazing | " + black + " | "
        "max rel, fresh | RMS rel, fresh | albedo error | data bytes | C double ns | C float ns | Python ns | "
        "JAX M eval/s | on the front |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    order = {g: k for k, g in enumerate(GROUPS)}
    marks = _front_marks(brdf)
    for k in sorted(range(len(brdf)), key=lambda k: (order.get(brdf[k]["group"], 99), k)):
        r = brdf[k]
        out.append(f"| {r['group']} | {r['method']} | {sci(r['max_rel'])} | {sci(r['rms_rel'])} | "
                   f"{sci(r.get('max_rel_away'))} | {sci(r.get('max_rel_grazing'))} | {sci(r.get('max_abs_c0'))} | "
                   f"{sci(r.get('max_rel_fresh'))} | {sci(r.get('rms_rel_fresh'))} | {sci(r.get('albedo_err'))} | "
                   f"{_bytes(r.get('bytes'))} | {ns(r.get('ns_c_double', math.nan))} | "
                   f"{ns(r.get('ns_c_float', math.nan))} | {ns(r.get('ns_python', math.nan))} | "
                   f"{_rate(r.get('jax_evals_per_s', math.nan))} | {marks[k]} |")  # fmt: skip
    return out


def _recommendations(rec) -> list[str]:
    out = [
        "| use | method | max rel | RMS rel | max rel, grazing | max / RMS rel, fresh set | albedo error | "
        "cost (ns per evaluation) | rule |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for use, rule in RULES.items():
        r = rec.get(use)
        if r is None:
            out.append(f"| {use} | none qualifies | | | | | | | {rule} |")
            continue
        cost, kind = plot_cost(r)
        out.append(f"| {use} | **{r['method']}** ({r['group']}) | {sci(r['max_rel'])} | {sci(r['rms_rel'])} | "
                   f"{sci(r.get('max_rel_grazing'))} | {sci(r.get('max_rel_fresh'))} / {sci(r.get('rms_rel_fresh'))} | "
                   f"{sci(r.get('albedo_err'))} | {ns(cost)} ({'C double' if kind == 'C' else 'Python'}) | {rule} |")  # fmt: skip
    return out


def parts_table(parts) -> list[str]:
    out = ["| target | method | group | max rel | max rel* | RMS rel | C double ns | C float ns |",
           "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in parts:
        out.append(f"| {r['target']} | {r['method']} | {r['group']} | {sci(r['max_rel'])} | "
                   f"{sci(r['max_rel_nonzero'])} | {sci(r['rms_rel'])} | {ns(r.get('ns_c_double', math.nan))} | "
                   f"{ns(r.get('ns_c_float', math.nan))} |")  # fmt: skip
    return out


def report_source(report) -> str:
    """What the report's exact values are (the family's ``SOURCES["exact"]``, recorded in its context)."""
    return report.context.get("exact_source", "the exact engine")


def _refit_section(rows) -> list[str]:
    out = ["## One-off cost of each refit", "",
           "Wall seconds of `fitlab.fit.refit.refit` (JIT, Levenberg-Marquardt, minimax rounds, validation; "
           "nothing written); the target's data is built beforehand (shared with the accuracy section).", "",
           "| target | form | seconds | refit max rel | note |", "|---|---|---|---|---|"]  # fmt: skip
    for r in section_rows(rows, "refit"):
        out.append(f"| {r['target']} | {r['method']} | {ns(r['seconds'])} | {sci(r['max_rel'])} | {r['note']} |")
    return out


def markdown(report) -> str:
    ctx, rows, s = report.context, report.rows, report.settings
    brdf = section_rows(rows, "brdf")
    hook = brdf_report()
    text = hook.REPORT_TEXT
    out = [f"# Accuracy and cost of every way to evaluate the {hook.BRDF_TITLE}", "",
           "Generated by `fitlab report`" + (" --quick" if s.name == "quick" else "")
           + " (do not edit); every number is in `report.csv`. All columns but the timings are reproducible "
           f"run to run. Machine: {ctx['machine']}; this run took {ctx['wall_seconds']:.0f} s.", "",
           f"**Accuracy.** Against `{report_source(report)}` on one fixed validation set: {ctx['validation']} "
           f"({ctx['validation_points']} points; {text['material']}). Every "
           f"`{ctx['fits_dir']}/*.json` is measured (" + ", ".join(f"{g}: {n}" for g, n in ctx["fits"].items()) + " files). Relative error "
           "|f - f_exact| / f_exact: the max over the set, the RMS, and the max away from the grazing pole "
           "(mu_i, mu_o >= 1/64); the uniform points never come closer to the pole than mu_i + mu_o of about "
           f"2^(-{s.log2_points}/2), so a second set looks there on purpose: {ctx['grazing']} "
           f"({ctx['grazing_points']} points; max rel, grazing). {text['black']} Nothing is fitted or selected on a "
           f"third, independent set: {ctx['fresh']} ({ctx['fresh_points']} points; max rel and RMS rel, fresh). "
           f"Albedo error: {ctx['energy']}, max over both. {text['parts']}", "",
           f"**Cost.** ns per evaluation of the generated C (`fitlab.codegen`, `{ctx['c_compiler']}`), called in a C "
           f"loop over {ctx['c_points']} random inputs, best of {ctx['repeat']} (`fitlab.codegen.bench`, the harness "
           f"of `fitlab bench codegen`); Python ns: numpy vectorised over {ctx['numpy_points']} inputs (the exact "
           "engine per point once set up, on fewer points; Monte Carlo per BRDF value); JAX: jit of the same sympy expression, "
           f"float64, {ctx['jax_points']} inputs, millions of evaluations per second, compilation excluded. The "
           "machine is shared: compare timings within this run only.", "",
           "**Memory.** data bytes: what a method reads besides its code: the exported tables' texture (float32; "
           "docs/table_export.md), the spline tables' knots and coefficients (float64), a fitted model's "
           "coefficients (float64, 8 bytes per number the fits set; the exact constants of the maths not counted).", "",
           "## Recommendations", "", *_recommendations(report.recommendations), "",
           "## The BRDF", "", "![accuracy vs cost](accuracy_vs_cost.png)", "",
           "*on the front*: no other method is both cheaper and more accurate (by max or RMS error). Monte Carlo "
           "is measured on its own points (bin averages, see below); the exact engine's error is the agreement "
           "of its two methods.", "",
           *_brdf_table(brdf), "",
           "## The parts", "",
           "max rel* leaves out the target's exact zeros. C ns: the part's routine in the generated code: in its "
           "family's program where one prints it, else its form with its numbers as a routine of its own (timed "
           "in one more run: compare within a run).", "",
           *parts_table(section_rows(rows, "part")), "",
           *hook.engine_sections(report), "",
           *_refit_section(rows)]  # fmt: skip
    if ctx["notes"]:
        out += ["", "## Notes", "", *(f"- {n}" for n in ctx["notes"])]
    return "\n".join(out) + "\n"


def as_shown(report, cwd: Path | None = None):
    """``report`` with its fits folder named as a person reads it: relative to ``cwd`` (default: the current
    folder) when the folder lies inside it, so that a report made in a checkout names fitlab/fits/..., not
    the checkout's absolute path; otherwise unchanged.  Rows and recommendations are copied, not edited."""
    folder = report.context.get("fits_dir")
    if not folder:
        return report
    try:
        shown = str(Path(folder).resolve().relative_to((cwd or Path.cwd()).resolve()))
    except ValueError:
        return report

    def row(r):
        return None if r is None else {k: v.replace(folder, shown) if isinstance(v, str) else v for k, v in r.items()}

    return dataclasses.replace(
        report,
        rows=[row(r) for r in report.rows],
        recommendations={k: row(r) for k, r in report.recommendations.items()},
        context={**report.context, "fits_dir": shown},
    )


def write_outputs(report, out_dir: Path) -> list[Path]:
    """Render report.md, accuracy_vs_cost.png and report.csv (the fits folder named by :func:`as_shown`) and
    write all three (or none)."""
    report = as_shown(report)
    brdf = section_rows(report.rows, "brdf")
    title = (
        f"{brdf_report().BRDF_TITLE}: error vs cost of every evaluation method "
        f"({report.context['validation_points']} validation points; fitlab report)"
    )
    files = {
        "report.md": markdown(report).encode(),
        "accuracy_vs_cost.png": plot_png(brdf, title),
        "report.csv": csv_text(report.rows).encode(),
    }
    out_dir = Path(out_dir)
    atomic_write_many({out_dir / name: data for name, data in files.items()})
    return [out_dir / name for name in files]
