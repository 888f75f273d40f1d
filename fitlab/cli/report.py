"""``fitlab report``: the command-line face of :mod:`fitlab.report` (docs/report.md, the plot, report.csv)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

from fitlab.report import FULL, QUICK, ReportError, build_report, write_outputs
from fitlab.report.write import FILES
from fitlab.store import FitFileError

__all__ = ["HELP", "add_arguments", "run", "check_out_dir"]

HELP = "accuracy vs cost of every way to evaluate the BRDF: docs/report.md and a plot"


def add_arguments(p) -> None:
    p.add_argument("--out", default="docs", help="folder for report.md, accuracy_vs_cost.png and report.csv")
    p.add_argument("--fits", default="fits", help="folder of the fits JSON, every *.json is measured (default: fits)")
    p.add_argument("--quick", action="store_true", help="reduced sizes (seconds, for tests; numbers are rougher)")
    p.add_argument("--no-cache", action="store_true", help="recompute the exact validation values (no disk cache)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def check_out_dir(out: Path) -> None:
    """Fail early (ValueError) when ``out`` cannot take the report's files: not a folder, or not writable."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a folder")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"--out {out}: {probe} is not a writable folder")
    for name in FILES:
        if (out / name).is_dir():
            raise ValueError(f"--out {out}: {out / name} is a folder")


def run(args) -> int:
    t0 = time.perf_counter()
    try:
        check_out_dir(Path(args.out))
        report = build_report(QUICK if args.quick else FULL, Path(args.fits), use_cache=not args.no_cache,
                              progress=not args.quiet)  # fmt: skip
        paths = write_outputs(report, Path(args.out))
    except (ReportError, FitFileError, ValueError, OSError) as exc:
        print(f"fitlab report: error: {exc}", file=sys.stderr)
        return 2
    for use, r in report.recommendations.items():
        print(f"{use:<10} {r['method'] if r else 'none qualifies'}")
    for p in paths:
        print(f"wrote {p}")
    print(f"fitlab report: {time.perf_counter() - t0:.0f} s")
    return 0
