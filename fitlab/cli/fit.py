"""``fitlab fit``: fit a form of one's own to a column of one's own table (CSV), and write the fit file.

:mod:`fitlab.fit.user` does the work and reads and writes nothing but the table; this module checks every
option, the table, the form and the output folder before the fit starts (each refusal one line, exit
status 2), fits with a progress bar, and writes OUT/COLUMN.NAME.json and the table beside it
(OUT/COLUMN.NAME.csv, which the fit names) as one unit, only when the fit's held-out error is finite (exit
status 1 otherwise, nothing written).  As ``fitlab refit`` does, it keeps a fit already there that is better
on the same held-out rows, or that cannot be compared (another table, domain, split or error; known before
the fit), unless ``--force`` (exit status 1, nothing written).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_quiet,
    describe,
    integer,
    one_line,
    output_folder,
    say,
    write_failure,
)

__all__ = ["add_arguments", "run", "parse_start", "parse_user_domain"]


def add_arguments(p) -> None:
    describe(p, "Fit a form written as an expression (parameters a0, a1, ...; the other names are columns of the "
                "table) to a column of a CSV table (a header row naming the columns, then one row per point; # "
                "lines skipped) by the refit's optimistix least squares and minimax refinement, one row in four "
                "held out for validation, and write OUT/COLUMN.NAME.json and a copy of the table beside it "
                "(OUT/COLUMN.NAME.csv), which `fitlab codegen --fit` prints in every language. Every check of the "
                "table and the form is made before the fit (one line, exit status 2). A fit already there that is "
                "better on the same held-out rows, or that was fitted to another table, domain or split, is kept "
                "(exit status 1) unless --force.",
             'fitlab fit E.csv --target E --form "(a0 + a1*mu)/(1 + a2*alpha + a3*mu)" --name rational')  # fmt: skip
    p.add_argument("table", metavar="TABLE.csv", help="the table: CSV with a header row")
    p.add_argument("--target", required=True, metavar="COLUMN", help="the column to fit")
    p.add_argument(
        "--form",
        required=True,
        metavar="EXPRESSION",
        help="the form: + - * / ** and sqrt, log, exp, cos, sin, acos, atan, tanh, Abs, Max, Min, safe_pow "
        "of numbers, pi, E, the parameters a0, a1, ... and the input columns",
    )
    p.add_argument(
        "--inputs",
        metavar="X,Y",
        help="the input columns, in argument order (default: the columns the form names, in the table's order)",
    )
    p.add_argument(
        "--domain",
        action="append",
        metavar="NAME=LO:HI",
        help="fit only the rows with LO <= NAME <= HI (once per input); the fit's domain is the bounding "
        "box of the rows fitted",
    )
    p.add_argument(
        "--name",
        metavar="NAME",
        help="the form's name: OUT/COLUMN.NAME.json, function COLUMN_NAME in "
        "generated code (default: form_ and 6 hex digits of the expression)",
    )
    p.add_argument(
        "--start", metavar="a0=V,a1=V", help="start values of some parameters (the others: a<k> starts at 1/(k + 1))"
    )
    p.add_argument(
        "--error",
        choices=("relative", "absolute"),
        default="relative",
        help="relative: |f - y| / max(|y|, 1e-3 max|y|) (the default), or absolute: |f - y|",
    )
    p.add_argument(
        "--holdout-every",
        type=integer(2, 1000),
        default=4,
        metavar="K",
        help="hold out one row in K of the rows sorted by the inputs (default 4)",
    )
    p.add_argument(
        "--minimax-rounds",
        type=integer(0, 1000),
        default=40,
        metavar="N",
        help="Lawson minimax rounds after least squares (default 40, as refit; 0: least squares only)",
    )
    p.add_argument("--out", default="fits", help="folder for the fit JSON (default: fits, below the current folder)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the fit in --out of this column and name even when it is better on the same held-out "
        "rows, or was fitted to another table, domain, split or error",
    )
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
    from fitlab.fit.user import UserDataError, prepare, read_csv_table, table_beside

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
    except UserDataError as exc:
        raise UsageError(one_line(exc)) from None
    path = out / f"{args.target}.{prep.form.name}.json"
    beside = table_beside(path)
    for target in (path, beside):
        if target.is_dir():
            raise UsageError(f"--out {args.out}: {target} is a folder, where the fit will be written")
    old, note = _existing(path, prep, args.force)

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
    v = record["validation"]
    if not (math.isfinite(v["max_rel"]) and math.isfinite(v["rms_rel"])):
        raise RunFailure(
            f"{args.target}/{prep.form.name}: the held-out error is not finite (max {v['max_rel']}, "
            f"RMS {v['rms_rel']}): the fit has a pole or NaN on the held-out rows; nothing written"
        )
    if old is not None:
        _keep_better(path, old, record)
    from fitlab._io import atomic_write_many
    from fitlab.store import FitFileError

    try:
        files = fit.files(path)  # the fit and its table beside it, checked as the store reads them back
    except FitFileError as exc:  # what fitlab writes it can read back: a record it would refuse is never written
        raise RunFailure(one_line(exc)) from None
    try:
        atomic_write_many(files)
    except OSError as exc:
        raise write_failure(out, exc) from None
    record = {**record, "user_data": {**record["user_data"], "file": beside.name}}
    if fit.warning is not None:
        print(f"fitlab fit: warning: {record['target']}/{record['form']}: {fit.warning}", file=sys.stderr)
    if args.json:
        from fitlab.store import strict_json

        print(strict_json({**_summary(record, path), "warning": fit.warning, "conditioning": fit.conditioning}),
              end="")  # fmt: skip
    else:
        print(_text(record, table.name))
    say(args, f"wrote {path} and its table {beside.name}{note or ''}")
    return 0


def _existing(path: Path, prep, force: bool) -> tuple[dict | None, str | None]:
    """The fit already at ``path`` and its held-out error measured again on this table, to keep when it is
    better (:func:`_keep_better`, after the fit): (measured figures, None) when it is a fit of the same table,
    rows, split and error as this one; (None, the note the ``wrote`` line adds) when there is none, or ``force``,
    or a file that is no readable fit of this column and form, or one whose figures its table does not give
    (each replaced).  A readable fit that is not comparable (another table, domain, split or error) is kept
    unless ``force``: refused here, before the fit (exit status 1, nothing written)."""
    if force or not path.exists():
        return None, None
    from fitlab.fit.user import UserDataError, not_comparable, remeasure
    from fitlab.store import FitFileError, read_fit

    key = f"{prep.form.target}/{prep.form.name}"
    try:
        old = read_fit(path)
        if "user_data" not in old or (old["target"], old["form"]) != (prep.form.target, prep.form.name):
            raise FitFileError(f"a fit of {old['target']}/{old['form']}{'' if 'user_data' in old else ' (fitlab)'}")
    except FitFileError as exc:
        return None, f" (replacing a file that was not a readable fit of {key}: {one_line(exc)})"
    reason = not_comparable(old, prep.rows)
    if reason is not None:
        raise RunFailure(
            f"{key}: {path} holds {reason}; not comparable, so it is kept (--force replaces it); "
            "nothing fitted, nothing written"
        )
    try:
        return remeasure(old, prep.rows.table), None
    except UserDataError as exc:
        return None, f" (replacing a fit whose figures its table does not give: {one_line(exc)})"


def _keep_better(path: Path, measured: dict, record: dict) -> None:
    """Refuse (exit status 1, nothing written) when the fit ``record`` is worse than the fit at ``path``, whose
    held-out error on the same rows is ``measured`` (:func:`_existing`)."""
    from fitlab.fit.metrics import worse

    new = record["validation"]
    if not worse(new, measured):  # a figure the old fit does not give (NaN) counts as infinite
        return
    g = "{:.3e}".format
    raise RunFailure(
        f"{record['target']}/{record['form']}: the fit (max {g(new['max_rel'])}, RMS {g(new['rms_rel'])}) "
        f"is worse than the fit in {path} (max {g(measured['max_rel'])}, RMS {g(measured['rms_rel'])}, "
        "measured again on the same held-out rows), which is kept (--force replaces it); nothing written"
    )


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
    measure = f"relative, floor {user['scale_floor']:.6g}" if user["error"] == "relative" else "absolute"
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
