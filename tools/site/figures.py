"""Tables and numbers for the site and the README, rendered from what the report, the audit and the fits wrote.

Each function reads a committed output (docs/report.csv, docs/audit.json, fitlab/fits/*.json, the fit files'
JSON Schema, the command's parsers) and returns Markdown; nothing here measures or types a number.  The site's
pages call them as ``{{ name(args) }}`` (tools/site/hooks.py); tools/readme_table.py prints the README's table
with :func:`use_table`.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REPORT_CSV = ROOT / "docs" / "report.csv"
AUDIT_JSON = ROOT / "docs" / "audit.json"
FITS = ROOT / "fitlab" / "fits"
SCHEMA = ROOT / "fitlab" / "schemas" / "fit-1.schema.json"

#: the report's columns that hold numbers (every other column is text)
_NUMERIC = ("max_rel", "max_rel_nonzero", "rms_rel", "max_rel_away", "max_rel_grazing", "max_abs_c0", "max_rel_fresh",
            "rms_rel_fresh", "albedo_err", "bytes", "ns_c_double", "ns_c_float", "ns_python", "jax_evals_per_s",
            "seconds", "points", "paths", "target_error")  # fmt: skip


class FigureError(ValueError):
    """A page asks for a row, a column or a section the outputs do not hold."""


def sci(x: float, digits: int = 2) -> str:
    """A relative error as the site prints it: ``digits`` significant digits, 4.9e-4 (no padded exponent)."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, str):
        x = float(x)
    if math.isinf(x):
        return "inf"
    if x == 0:
        return "0"
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    return f"{mantissa}e{int(exponent)}"


def time_ns(x: float) -> str:
    """A time per evaluation in ns, us or ms, three significant digits."""
    for unit, scale in (("ms", 1e6), ("us", 1e3)):
        if x >= scale:
            return f"{x / scale:.3g} {unit}"
    return f"{x:.3g} ns"


# -- the report (docs/report.csv) --------------------------------------------------------------------------------
def report_rows(section: str = "brdf", path: Path = REPORT_CSV) -> list[dict]:
    """The report's rows of one section, the numeric columns as floats (nan where empty)."""

    def number(v: str) -> float:
        try:
            return float(v)
        except ValueError:
            return math.nan

    with open(path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["section"] == section]
    if not rows:
        raise FigureError(f"{path.name} has no rows of section {section!r}")
    return [{**r, **{k: number(r[k]) for k in _NUMERIC if k in r}} for r in rows]


def _cost(row: dict) -> str:
    if math.isfinite(row["ns_c_double"]):
        return f"{time_ns(row['ns_c_double'])} (C, double)"
    return f"{time_ns(row['ns_python'])} (numpy, per point)"


def _where(source: str) -> str:
    """How to get a method, from the report's source column: the command that prints it, or its module."""
    where = source.split(" (")[0]
    head, named_forms, _ = where.partition(": ")
    if head.startswith("fitlab/"):  # a folder of fits: "fitlab/fits/true: H0: log_exp, ..."
        return f"`fitlab codegen --fits {head}`"
    if where.startswith(("fitlab ", "fitlab.")):  # a command or a module
        return f"`{where}`"
    if named_forms:  # the packaged fits in the forms named: "H0: log_exp, H1: log_exp, ..."
        return "`fitlab codegen`"
    return where


USES = {"real-time": "real time (shaders, engines; no texture)", "real-time, texture": "real time with a texture",
        "offline": "offline (film, path tracers)", "reference": "reference (checking)"}  # fmt: skip


def use_table(path: Path = REPORT_CSV) -> str:
    """Which model for which job: the report's recommendation per use (:func:`fitlab.report.pareto.recommend`,
    the rule the report applies), with its error against the true BRDF and its cost."""
    from fitlab.report.pareto import recommend

    picks = recommend(report_rows("brdf", path))
    lines = ["| job | model | where | max / RMS relative error | max at grazing | cost per evaluation |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for use, label in USES.items():
        row = picks.get(use)
        if row is None:
            raise FigureError(f"the report recommends nothing for {use!r}")
        grazing = sci(row["max_rel_grazing"]) if math.isfinite(row["max_rel_grazing"]) else "-"
        lines.append(f"| {label} | {row['method']} | {_where(row['source'])} | "
                     f"{sci(row['max_rel'])} / {sci(row['rms_rel'])} | {grazing} | {_cost(row)} |")  # fmt: skip
    default = next(r for r in report_rows("claim", path) if "default" in r["method"])
    if default:  # what the generated banner states, on its own sets (the report's claim rows)
        lines += ["", f"`fitlab codegen` states in the banner of the default model, measured as it prints: "
                      f"{sci(default['max_rel'])} max and {sci(default['rms_rel'])} RMS relative error against the "
                      f"true BRDF over mu_i, mu_o in [0.01, 1], every c and phi; {sci(default['max_rel_grazing'])} "
                      "down to mu = 1e-6."]  # fmt: skip
    return "\n".join(lines)


def report_table(*groups: str, path: Path = REPORT_CSV) -> str:
    """The report's BRDF rows of the named groups (every group where none is named): errors and cost."""
    rows = [r for r in report_rows("brdf", path) if not groups or r["group"] in groups]
    if not rows:
        raise FigureError(f"the report has no BRDF rows in groups {groups}")
    lines = ["| group | method | max rel | RMS rel | max rel, grazing | C double | numpy |", "|---" * 7 + "|"]
    for r in rows:
        c = time_ns(r["ns_c_double"]) if math.isfinite(r["ns_c_double"]) else "-"
        py = time_ns(r["ns_python"]) if math.isfinite(r["ns_python"]) else "-"
        lines.append(f"| {r['group']} | {r['method']} | {sci(r['max_rel'])} | {sci(r['rms_rel'])} | "
                     f"{sci(r['max_rel_grazing'])} | {c} | {py} |")  # fmt: skip
    return "\n".join(lines)


def report_value(method: str, column: str, path: Path = REPORT_CSV) -> str:
    """One number of the report's BRDF rows: ``column`` of the row named ``method``, as the site prints it."""
    rows = {r["method"]: r for r in report_rows("brdf", path)}
    if method not in rows:
        raise FigureError(f"the report has no BRDF row {method!r}")
    if column not in rows[method]:
        raise FigureError(f"the report has no column {column!r}")
    value = rows[method][column]
    return time_ns(value) if column.startswith("ns_") else sci(value)


# -- the audit (docs/audit.json) ---------------------------------------------------------------------------------
def _audit(path: Path = AUDIT_JSON) -> dict:
    return json.loads(path.read_text())


_AUDIT_SETS = {
    "runtime_true": "true BRDF, validation lattice",
    "runtime_true_independent": "true BRDF, independent points and the mu = 0.01 edge",
    "runtime": "mixed reference, validation lattice",
}


def _audit_row(audit: dict, section: str, model: str) -> dict:
    matches = [r for r in audit.get(section, []) if r["model"] == model or r["model"].startswith(model)]
    if len(matches) != 1:
        raise FigureError(f"docs/audit.json's {section!r} has {len(matches)} rows named {model!r}")
    return matches[0]


def _point(worst: dict | None) -> str:
    if not worst:
        return ""
    return ", ".join(f"{k} = {'pi' if k == 'phi' and math.isclose(v, math.pi) else f'{v:.4g}'}"
                     for k, v in worst.items())  # fmt: skip


def audit_table(models: list[str], sections: list[str] = tuple(_AUDIT_SETS), path: Path = AUDIT_JSON) -> str:
    """The audit's runtime rows for ``models`` (a model's name, or the start of it) in each of ``sections``: max,
    max away from grazing (mu >= 1/64), RMS over the nonzero values, and the worst point."""
    audit = _audit(path)
    lines = ["| reference, set | model | max | max, mu >= 1/64 | RMS | worst point |", "|---|---|---|---|---|---|"]
    for section in sections:
        if section not in audit:
            raise FigureError(f"docs/audit.json has no section {section!r}")
        label = f"{_AUDIT_SETS.get(section, section)} ({audit[section][0]['points']:,} points)"
        for i, model in enumerate(models):
            row = _audit_row(audit, section, model)
            numbers = " | ".join(sci(row[k], 3) for k in ("max_rel", "max_rel_away", "rms_rel_nonzero"))
            lines.append(f"| {label if i == 0 else ''} | {row['model']} | {numbers} | {_point(row.get('worst'))} |")
    return "\n".join(lines)


def audit_value(section: str, model: str, key: str, path: Path = AUDIT_JSON) -> str:
    """One number of the audit: ``key`` of the row ``model`` (its name or the start of it) in ``section``."""
    row = _audit_row(_audit(path), section, model)
    if key not in row:
        raise FigureError(f"docs/audit.json's {section!r} row {row['model']!r} has no {key!r}")
    return sci(row[key])


# -- the packaged fits (fitlab/fits/*.json) ----------------------------------------------------------------------
def fits_table(family_targets: list[str] | None = None, fits: Path = FITS) -> str:
    """Every packaged fit of the named targets (every target where none is named): its form, validation max and
    RMS relative error, and its target's best published preset on the same set, as the fit files record them."""
    records = [json.loads(p.read_text()) for p in sorted(fits.glob("*.json"))]
    if family_targets:
        records = [r for r in records if r["target"] in family_targets]
    if not records:
        raise FigureError("no packaged fit for those targets")
    lines = ["| target | form | max rel | RMS rel | best published preset |", "|---|---|---|---|---|"]
    for r in sorted(
        records,
        key=lambda r: (
            r["target"].lower(),
            r["validation"]["max_rel"] if isinstance(r["validation"]["max_rel"], float) else math.inf,
        ),
    ):
        published = [p for p in r.get("published", []) if isinstance(p["validation"]["max_rel"], float)]
        best = min(published, key=lambda p: p["validation"]["max_rel"], default=None)
        best_text = f"{sci(best['validation']['max_rel'])} ({best['form']} / {best['preset']})" if best else "-"
        lines.append(
            f"| {r['target']} | {r['form']} | {sci(r['validation']['max_rel'])} | "
            f"{sci(r['validation']['rms_rel'])} | {best_text} |"
        )
    return "\n".join(lines)


# -- reference pages ---------------------------------------------------------------------------------------------
def fit_schema() -> str:
    """The fit files' JSON Schema: a table of the top-level fields with the limits it enforces, then the schema."""
    schema = json.loads(SCHEMA.read_text())
    required = set(schema.get("required", ()))
    limits = ("const", "enum", "minItems", "maxItems", "maxLength", "maxProperties", "minimum", "maximum")
    lines = ["| field | type | required | limits |", "|---|---|---|---|"]
    for name, spec in schema.get("properties", {}).items():
        kind = spec.get("type") or ("reference" if "$ref" in spec else "-")
        kind = " or ".join(kind) if isinstance(kind, list) else kind
        held = [f"{k} {json.dumps(spec[k])}" for k in limits if k in spec]
        if "pattern" in spec:
            held.append("pattern")
        if "$ref" in spec:
            held.append(f"see `{spec['$ref']}`")
        lines.append(f"| `{name}` | {kind} | {'yes' if name in required else ''} | {'; '.join(held)} |")
    text = SCHEMA.read_text().rstrip()
    lines += ["", f"The schema itself (`fitlab/schemas/{SCHEMA.name}`):", "", "```json", text, "```"]
    return "\n".join(lines)


def cli_help() -> str:
    """``fitlab --help`` and every command's ``--help``, as the parsers print them."""
    import argparse
    import os

    from fitlab.cli import COMMANDS, build_parser

    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal's width: the same width on every build
    try:
        parser = build_parser()
        subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parts = ["```text", parser.format_help().rstrip(), "```"]
        for name in COMMANDS:
            sub = subparsers.choices[name]
            parts += ["", f"## `fitlab {name}`", "", "```text", sub.format_help().rstrip(), "```"]
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return "\n".join(parts)
