"""``fitlab tabulate``: compute the exact tables into the data folder (where every command reads them), or
check them; for every family that offers tables, or the one ``--family`` names."""

from __future__ import annotations

import time
from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_data,
    add_family,
    add_quiet,
    describe,
    fail,
    family_with,
    input_folder,
    output_folder,
    say,
    write_failure,
)
from fitlab.resources import data_root, tables_folder
from fitlab.store import TableError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Compute the exact tables every refit reads, family by family (or the one --family names), and "
                "write each family's tables as one unit into the data folder, DATA/FAMILY/ (nothing of a family is "
                "written on its failure); every command then reads them there instead of the tables packaged with "
                "fitlab. With --check, recompute a sample of the rows of the tables in force by independent methods.",
             "fitlab tabulate --data /tmp/fitlab-data --quiet")  # fmt: skip
    add_data(p, output=True)
    add_family(p, "tables", "every family with tables")
    p.add_argument(
        "--check",
        action="store_true",
        help="recompute a sample of rows of the tables in force (DATA/FAMILY/ with --data)",
    )
    add_quiet(p)


def run(args) -> int:
    from fitlab.core import HasTables, offering

    names = list(offering(HasTables))
    if args.family is not None and args.family not in names:
        raise UsageError(f"--family {args.family}: no such family with tables; choose one of {', '.join(names)}")
    chosen = [args.family] if args.family is not None else names
    root = data_root() if args.data is None else Path(args.data)
    if args.check:
        return _check(args, chosen, root)
    services = {name: family_with(HasTables, name).tables() for name in chosen}
    # every destination is checked before any family's work starts
    outs = {name: output_folder(root / tables.FAMILY_NAME, "--data", files=tables.TABLE_FILES)
            for name, tables in services.items()}  # fmt: skip
    for name, out in outs.items():
        tables = services[name]
        t0 = time.perf_counter()
        try:
            digests = tables.write_tables(out, show_progress=not args.quiet)
        except (ArithmeticError, ValueError) as exc:
            raise RunFailure(f"the tables of {name} could not be computed: {exc}") from None
        except OSError as exc:
            raise write_failure(out, exc) from None
        dt = time.perf_counter() - t0
        for file, digest in digests.items():
            print(f"  {out / file}  sha256:{digest}")
        say(args, f"{name}: wrote {len(digests)} tables in {dt:.1f} s")
    return 0


def _check(args, chosen, root) -> int:
    from fitlab.core import HasTables

    failed = 0
    for name in chosen:
        tables = family_with(HasTables, name).tables()
        if args.data is not None:  # exactly the tables there, no fallback
            folder = input_folder(Path(args.data) / tables.FAMILY_NAME, "--data")
        try:
            if args.data is None:  # an incomplete data folder is refused, naming the table it lacks
                folder = tables_folder(tables.FAMILY_NAME, tuple(tables.TABLE_FILES), root)
            failures = tables.check_tables(folder, show_progress=not args.quiet)
        except TableError as exc:
            fail("tabulate --check", exc, 1)
            failed += 1
            continue
        for f in failures:
            fail("tabulate --check", f, 1)
        if failures:
            failed += 1
            continue
        say(args, f"fitlab tabulate --check: {folder} agrees with the independent recomputation")
    return 1 if failed else 0
