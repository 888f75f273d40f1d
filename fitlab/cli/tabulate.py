"""``fitlab tabulate``: write the exact tables to data/, or check them."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from fitlab.families.lambert_sphere.tabulate import check_tables, write_tables
from fitlab.store import TableError

__all__ = ["HELP", "add_arguments", "run"]

HELP = "write the exact tables to data/ (or check them)"


def add_arguments(p) -> None:
    p.add_argument("--out", default="data", help="folder for the CSV tables (default: data)")
    p.add_argument("--check", action="store_true", help="recompute a sample of rows by independent methods")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    if args.check:
        try:
            failures = check_tables(Path(args.out), show_progress=not args.quiet)
        except TableError as exc:
            print(f"fitlab tabulate --check: {exc}", file=sys.stderr)
            return 1
        if failures:
            for f in failures:
                print(f"fitlab tabulate --check: {f}", file=sys.stderr)
            return 1
        print(f"fitlab tabulate --check: {args.out} agrees with the independent recomputation")
        return 0
    t0 = time.perf_counter()
    digests = write_tables(Path(args.out), show_progress=not args.quiet)
    dt = time.perf_counter() - t0
    for name, digest in digests.items():
        print(f"  {Path(args.out) / name}  sha256:{digest}")
    print(f"wrote {len(digests)} tables in {dt:.1f} s")
    return 0
