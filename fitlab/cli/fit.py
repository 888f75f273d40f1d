"""``fitlab fit``: fit a form of one's own to a column of one's own table (CSV), and write the fit file.

:mod:`fitlab.fit.user` does the work and reads and writes nothing but the table; this module checks every
option, the table, the form and the output folder before the fit starts (each refusal one line, exit
status 2), fits with a progress bar, and writes OUT/COLUMN.NAME.json atomically only when the fit's
held-out error is finite (exit status 1 otherwise, nothing written).
"""

from __future__ import annotations

import math
from pathlib import Path

from fitlab.cli._common import RunFailure, UsageError, add_quiet, describe, integer, one_line, output_folder, say, \
    write_failure

__all__ = ["add_arguments", "run", "parse_start", "parse_user_domain"]


def add_arguments(p) -> None:
    describe(p, "Fit a form written as an expression (parameters a0, a1, ...; the other names are columns of the "
                "table) to a column of a CSV table (a header row naming the columns, then one row per point; # "
                "lines skipped) by the refit's optimistix least squares and minimax refinement, one row in four "
                "held out for validation, and write OUT/COLUMN.NAME.json, which `fitlab codegen --fit` prints in "
                "every language. Every check of the table and the form is made before the fit (one line, exit "
                "status 2).",
             'fitlab fit E.csv --target E --form "(a0 + a1*mu)/(1 + a2*alpha + a3*mu)" --name rational')  # fmt: skip
    p.add_argument("table", metavar="TABLE.csv", help="the table: CSV with a header row")
    p.add_argument("--target", required=True, metavar="COLUMN", help="the column to fit")
    p.add_argument("--form", required=True, metavar="EXPRESSION",
                   help="the form: + - * / ** and sqrt, log, exp, cos, sin, acos, atan, tanh, Abs, Max, Min, safe_pow "
                        "of numbers, pi, E, the parameters a0, a1, ... and the input columns")
    p.add_argument("--inputs", metavar="X,Y", help="the input columns, in argument order (default: the columns the "
                                                   "form names, in the table's order)")
    p.add_argument("--domain", action="append", metavar="NAME=LO:HI",
                   help="fit only the rows with LO <= NAME <= HI (once per input); the fit's domain is the bounding "
                        "box of the rows fitted")
    p.add_argument("--name", metavar="NAME", help="the form's name: OUT/COLUMN.NAME.json, function COLUMN_NAME in "
                                                  "generated code (default: form_ and 6 hex digits of the expression)")
    p.add_argument("--start", metavar="a0=V,a1=V",
                   help="start values of some parameters (the others: a<k> starts at 1/(k + 1))")
    p.add_argument("--error", choices=("relative", "absolute"), default="relative",
                   help="relative: |f - y| / max(|y|, 1e-3 max|y|) (the default), or absolute: |f - y|")
    p.add_argument("--holdout-every", type=integer(2, 1000), default=4, metavar="K",
                   help="hold out one row in K of the rows sorted by the inputs (default 4)")
    p.add_argument("--minimax-rounds", type=integer(0, 1000), default=40, metavar="N",
                   help="Lawson minimax rounds after least squares (default 40, as refit; 0: least squares only)")
    p.add_argument("--out", default="fits", help="folder for the fit JSON (default: fits, below the current folder)")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary (JSON) instead of the text")
    add_quiet(p)


def parse_start(text: str | None) -> dict:
    """``"a0=1,a1=0"`` -> {"a0": 1.0, "a1": 0.0}; ValueError (one line) on a malformed item or a name given twice."""
    out = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"--start {item!r}: write NAME=VALUE, e.g. a0=1,a1=0")
        if name in out:
            raise ValueError(f"--start: {name} given twice")
        try:
            out[name] = float(value)
        except ValueError:
            raise ValueError(f"--start {item!r}: {value!r} is not a number") from None
        if not math.isfinite(out[name]):
            raise ValueError(f"--start {item!r}: not a finite number")
    return out


def parse_user_domain(items) -> dict:
    """``["mu=0.1:1", ...]`` -> {"mu": (0.1, 1.0)}; ValueError (one line) on a malformed item or an input given
    twice."""
    out = {}
    for item in items or ():
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        name = name.strip()
        if not sep or not sep2 or not name:
            raise ValueError(f"--domain {item!r}: write NAME=LO:HI, e.g. mu=0.1:1")
        if name in out:
            raise ValueError(f"--domain {item!r}: {name} given twice; give each input once")
        try:
            lo_f, hi_f = float(lo), float(hi)
        except ValueError:
            raise ValueError(f"--domain {item!r}: LO and HI must be numbers") from None
        if not (math.isfinite(lo_f) and math.isfinite(hi_f) and lo_f < hi_f):
            raise ValueError(f"--domain {item!r}: need finite LO < HI")
        out[name] = (lo_f, hi_f)
    return out


def run(args) -> int:
    from fitlab.fit.user import UserDataError, prepare, read_csv_table, relative_file

    try:
        start = parse_start(args.start)
        domain = parse_user_domain(args.domain)
    except ValueError as exc:
        raise UsageError(one_line(exc)) from None
    inputs = None if args.inputs is None else [n.strip() for n in args.inputs.split(",") if n.strip()]
    if inputs is not None and not inputs:
        raise UsageError("--inputs: name at least one column, e.g. --inputs mu,alpha")
    out = output_folder(args.out, "--out")
    try:
        table = read_csv_table(args.table)
        prep = prepare(table, args.target, args.form, inputs=inputs, domain=domain, name=args.name, start=start,
                       error=args.error, holdout_every=args.holdout_every)  # fmt: skip
        path = out / f"{args.target}.{prep.form.name}.json"
        if path.is_dir():
            raise UsageError(f"--out {args.out}: {path} is a folder, where the fit will be written")
        file = relative_file(args.table, out)
    except UserDataError as exc:
        raise UsageError(one_line(exc)) from None

    from tqdm import tqdm

    from fitlab.fit.solver import FitError
    from fitlab.fit.user import run_fit, stages

    bar = tqdm(total=stages(args.minimax_rounds), desc=f"fit {args.target}/{prep.form.name}", unit="stage",
               leave=False, disable=args.quiet)  # fmt: skip

    def on_step(stage):
        bar.set_postfix_str(stage, refresh=False)
        bar.update()

    try:
        fit = run_fit(prep, args.minimax_rounds, on_step)
    except (FitError, ValueError, ArithmeticError) as exc:
        raise RunFailure(f"{args.target}/{prep.form.name}: the fit failed: {one_line(exc)}; nothing written") from None
    finally:
        bar.close()
    record = fit.record
    record["user_data"]["file"] = file
    v = record["validation"]
    if not (math.isfinite(v["max_rel"]) and math.isfinite(v["rms_rel"])):
        raise RunFailure(f"{args.target}/{prep.form.name}: the held-out error is not finite (max {v['max_rel']}, "
                         f"RMS {v['rms_rel']}): the fit has a pole or NaN on the held-out rows; nothing written")
    from fitlab.store import FitFileError, strict_json, write_fit

    try:
        write_fit(path, record)
    except FitFileError as exc:  # what fitlab writes it can read back: a record it would refuse is never written
        raise RunFailure(one_line(exc)) from None
    except OSError as exc:
        raise write_failure(out, exc) from None
    if args.json:
        print(strict_json(_summary(record, path)), end="")
    else:
        print(_text(record, table.name))
    say(args, f"wrote {path}")
    return 0


def _summary(record: dict, path: Path) -> dict:
    return {
        "target": record["target"], "form": record["form"], "path": str(path), "inputs": record["inputs"],
        "expression": record["expression"], "params": record["params"], "domain": record["domain"],
        "error_measure": record["error_measure"], "training_rows": record["training"]["points"],
        "validation": record["validation"],
    }  # fmt: skip


def _text(record: dict, table: str) -> str:
    v, user = record["validation"], record["user_data"]
    worst = v["worst"]
    at = ", ".join(f"{k}={worst[k]:.6g}" for k in record["inputs"])
    measure = (f"relative, floor {user['scale_floor']:.6g}" if user["error"] == "relative" else "absolute")
    params = ", ".join(f"{k} = {x:.10g}" for k, x in record["params"].items())
    domain = ", ".join(f"{k} in [{lo:.6g}, {hi:.6g}]" for k, (lo, hi) in record["domain"].items())
    return "\n".join([
        f"{record['target']}/{record['form']}: {len(record['params'])} parameters fitted to "
        f"{record['training']['points']} rows of {table}, {v['points']} rows held out",
        f"held-out error ({measure}): max {v['max_rel']:.3e} at {at} ({record['target']} {worst['exact']:.6g}, fit "
        f"{worst['approx']:.6g}); RMS {v['rms_rel']:.3e}; max absolute {v['max_abs']:.3e}",
        f"domain: {domain}",
        f"parameters: {params}",
    ])  # fmt: skip
