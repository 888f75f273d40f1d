"""``fitlab tabulate``: write the exact tables to data/, or check them."""

from __future__ import annotations

import time
from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    add_quiet,
    describe,
    fail,
    input_folder,
    output_folder,
    say,
    service,
    write_failure,
)
from fitlab.store import TableError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Compute the exact tables (H-functions, constants) every refit reads, and write them all as one "
                "unit into --out (nothing is written on a failure); or, with --check, recompute a sample of the "
                "rows of the tables in --out by independent methods.",
             "fitlab tabulate --out /tmp/data --quiet")  # fmt: skip
    p.add_argument("--out", default="data", help="folder for the CSV tables (default: data)")
    p.add_argument("--check", action="store_true", help="recompute a sample of rows by independent methods")
    add_quiet(p)


def run(args) -> int:
    if args.check:
        folder = input_folder(args.out, "--out")

        try:
            failures = service("tables").check_tables(folder, show_progress=not args.quiet)
        except TableError as exc:
            return fail("tabulate --check", exc, 1)
        for f in failures:
            fail("tabulate --check", f, 1)
        if failures:
            return 1
        say(args, f"fitlab tabulate --check: {args.out} agrees with the independent recomputation")
        return 0
    tables = service("tables")
    out = output_folder(args.out, "--out", files=tables.TABLE_FILES)  # the names written

    t0 = time.perf_counter()
    try:
        digests = tables.write_tables(out, show_progress=not args.quiet)
    except (ArithmeticError, ValueError) as exc:
        raise RunFailure(f"the tables could not be computed: {exc}") from None
    except OSError as exc:
        raise write_failure(out, exc) from None
    dt = time.perf_counter() - t0
    for name, digest in digests.items():
        print(f"  {out / name}  sha256:{digest}")
    say(args, f"wrote {len(digests)} tables in {dt:.1f} s")
    return 0
