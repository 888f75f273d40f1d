"""``fitlab report``: the command-line face of :mod:`fitlab.report` (docs/report.md, the plot, report.csv)."""

from __future__ import annotations

import time

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_data,
    add_fits,
    add_quiet,
    describe,
    fits_input,
    one_line,
    output_folder,
    say,
    use_data,
    write_failure,
)
from fitlab.report import FULL, QUICK, ReportError, build_report, write_outputs
from fitlab.report.write import FILES
from fitlab.store import FitFileError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Measure the error and the cost of every way to evaluate the BRDF (the exact engine, tables, the "
                "published formulas, the refits in --fits, the generated code, Monte Carlo) on one validation set, "
                "and write report.md, accuracy_vs_cost.png and report.csv into --out, all three or none.",
             "fitlab report --quick --out /tmp/report")  # fmt: skip
    p.add_argument(
        "--out",
        default=".",
        help="folder for report.md, accuracy_vs_cost.png and report.csv (default: the current folder)",
    )
    add_fits(p, "folder of the fits JSON, every *.json is measured")
    add_data(p)
    p.add_argument("--quick", action="store_true", help="reduced sizes (seconds, for tests; numbers are rougher)")
    p.add_argument("--no-cache", action="store_true", help="recompute the exact validation values (no disk cache)")
    add_quiet(p)


def run(args) -> int:
    t0 = time.perf_counter()
    fits = fits_input(args, required=False)  # a missing one: the report's own line names it
    use_data(args)

    out = output_folder(args.out, "--out", files=FILES)

    try:
        report = build_report(QUICK if args.quick else FULL, fits, use_cache=not args.no_cache,
                              progress=not args.quiet)  # fmt: skip
    except (ReportError, FitFileError) as exc:  # bad input: a missing or damaged fit, a missing table
        raise UsageError(one_line(exc)) from None
    except (ValueError, ArithmeticError) as exc:
        raise RunFailure(f"the report failed: {one_line(exc)}") from None
    try:
        paths = write_outputs(report, out)  # all three files or none
    except OSError as exc:
        raise write_failure(out, exc) from None
    for use, r in report.recommendations.items():
        print(f"{use:<10} {r['method'] if r else 'none qualifies'}")
    for p in paths:
        say(args, f"wrote {p}")
    say(args, f"fitlab report: {time.perf_counter() - t0:.0f} s")
    return 0
