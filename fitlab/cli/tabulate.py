"""``fitlab tabulate``: compute the exact tables into the data folder (where every command reads them), or
check them."""

from __future__ import annotations

import time
from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    add_data,
    add_quiet,
    describe,
    fail,
    input_folder,
    output_folder,
    say,
    service,
    write_failure,
)
from fitlab.resources import data_root, tables_folder
from fitlab.store import TableError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Compute the exact tables (H-functions, constants) every refit reads, and write them all as one "
                "unit into the data folder, DATA/FAMILY/ (nothing is written on a failure); every command then reads "
                "them there instead of the tables packaged with fitlab. With --check, recompute a sample of the rows "
                "of the tables in force by independent methods.",
             "fitlab tabulate --data /tmp/fitlab-data --quiet")  # fmt: skip
    add_data(p, output=True)
    p.add_argument("--check", action="store_true",
                   help="recompute a sample of rows of the tables in force (DATA/FAMILY/ with --data)")
    add_quiet(p)


def run(args) -> int:
    tables = service("tables")
    root = data_root() if args.data is None else Path(args.data)
    if args.check:
        if args.data is not None:  # exactly the tables there, no fallback
            folder = input_folder(Path(args.data) / tables.FAMILY_NAME, "--data")
        else:
            folder = tables_folder(tables.FAMILY_NAME, tuple(tables.TABLE_FILES), root)
        try:
            failures = tables.check_tables(folder, show_progress=not args.quiet)
        except TableError as exc:
            return fail("tabulate --check", exc, 1)
        for f in failures:
            fail("tabulate --check", f, 1)
        if failures:
            return 1
        say(args, f"fitlab tabulate --check: {folder} agrees with the independent recomputation")
        return 0
    out = output_folder(root / tables.FAMILY_NAME, "--data", files=tables.TABLE_FILES)  # the names written

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
