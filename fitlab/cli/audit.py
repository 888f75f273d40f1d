"""``fitlab audit``: measure every published formula and the runtime model against the exact engine."""

from __future__ import annotations

import sys
import time
from pathlib import Path

from fitlab.families.lambert_sphere.audit import run_audit
from fitlab.store import TableError

__all__ = ["HELP", "add_arguments", "run"]

HELP = "measure every published formula and the runtime model against the exact engine"


def add_arguments(p) -> None:
    p.add_argument("--out", default="docs", help="folder for audit.md and audit.json (default: docs)")
    p.add_argument("--fits", default="fits", help="folder of the refits to include (default: fits)")


def run(args) -> int:
    t0 = time.perf_counter()
    try:
        result = run_audit(Path(args.out), Path(args.fits))
    except (TableError, ValueError) as exc:
        print(f"fitlab audit: error: {exc}", file=sys.stderr)
        return 2
    for r in result["runtime"]:
        print(f"{r['model']:<45} max rel* {r['max_rel_nonzero']:.3e}  RMS {r['rms_rel_nonzero']:.3e}  "
              f"away from grazing: max {r['max_rel_away']:.3e}  RMS {r['rms_rel_away']:.3e}")
    for r in result["furnace"]:
        print(f"white furnace c=1, {r['model']:<45} max |a - 1| = {r['max_abs_deviation']:.2e}")
    for m in result["missing_fits"]:
        print(f"not measured: {m}")
    print(f"wrote {Path(args.out) / 'audit.md'} and audit.json in {time.perf_counter() - t0:.1f} s")
    return 0
