"""The ``fitlab`` command."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def _cmd_tabulate(args) -> int:
    from .tabulate import TableError, check_tables, write_tables

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


def _cmd_bench(args) -> int:
    from .bench import bench_exact

    if args.what == "exact":
        bench_exact(quick=args.quick)
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fitlab", description="Fitting workbench for analytic BRDFs (Lambert-sphere BRDF).")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("tabulate", help="write the exact tables to data/ (or check them)")
    t.add_argument("--out", default="data", help="folder for the CSV tables (default: data)")
    t.add_argument("--check", action="store_true", help="recompute a sample of rows by independent methods")
    t.add_argument("--quiet", action="store_true", help="no progress bar")
    t.set_defaults(func=_cmd_tabulate)
    b = sub.add_parser("bench", help="benchmarks (not tests): speed and accuracy")
    b.add_argument("what", choices=["exact"], help="what to benchmark")
    b.add_argument("--quick", action="store_true", help="smaller sizes")
    b.set_defaults(func=_cmd_bench)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
