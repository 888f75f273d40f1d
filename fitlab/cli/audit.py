"""``fitlab audit``: measure every published formula and the runtime model against the exact engine."""

from __future__ import annotations

import time

from fitlab._io import atomic_write_many
from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_data,
    add_family,
    add_fits,
    add_quiet,
    describe,
    family_with,
    fits_input,
    one_line,
    output_folder,
    say,
    use_data,
    write_failure,
)
from fitlab.store import FitFileError, TableError, strict_json

__all__ = ["add_arguments", "run", "FILES"]

#: what the audit writes into --out
FILES = ("audit.md", "audit.json")


def add_arguments(p) -> None:
    describe(p, "Measure every published formula, the runtime model built from the fits in --fits and its white "
                "furnace against the exact engine; write audit.md and audit.json into --out (both or neither).",
             "fitlab audit --out /tmp/audit --json")  # fmt: skip
    p.add_argument("--out", default=".", help="folder for audit.md and audit.json (default: the current folder)")
    add_fits(p, "folder of the refits to include")
    add_data(p)
    p.add_argument("--json", action="store_true", help="print a machine-readable summary (JSON) instead of the table")
    add_family(p, "audit")
    add_quiet(p)


def run(args) -> int:
    fits = fits_input(args)
    use_data(args)
    out = output_folder(args.out, "--out", files=FILES)
    from fitlab.core import HasAudit

    family = family_with(HasAudit, args.family)

    t0 = time.perf_counter()
    try:
        result, files = family.audit(fits, show_progress=not args.quiet)
    except (FitFileError, TableError) as exc:
        raise UsageError(one_line(exc)) from None
    except (ValueError, ArithmeticError) as exc:
        raise RunFailure(f"the audit failed: {one_line(exc)}") from None
    if set(files) != set(FILES):
        raise RunFailure(f"the audit gave the files {sorted(files)}, not {list(FILES)}")
    try:  # both files or neither, no temporary left in --out
        atomic_write_many({out / name: files[name] for name in FILES})
    except OSError as exc:
        raise write_failure(out, exc) from None
    if args.json:
        print(
            strict_json(
                {
                    "runtime": result["runtime"],
                    "furnace": result["furnace"],
                    "missing_fits": result["missing_fits"],
                    "files": [str(out / n) for n in FILES],
                }
            ),
            end="",
        )
        return 0
    for r in result["runtime"]:
        print(
            f"{r['model']:<45} max rel* {r['max_rel_nonzero']:.3e}  RMS {r['rms_rel_nonzero']:.3e}  "
            f"away from grazing: max {r['max_rel_away']:.3e}  RMS {r['rms_rel_away']:.3e}"
        )
    for r in result["furnace"]:
        print(f"white furnace c=1, {r['model']:<45} max |a - 1| = {r['max_abs_deviation']:.2e}")
    for m in result["missing_fits"]:
        print(f"not measured: {m}")
    say(args, f"wrote {out / 'audit.md'} and audit.json in {time.perf_counter() - t0:.1f} s")
    return 0
