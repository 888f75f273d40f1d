"""``fitlab cache {info,clear}``: the persistent cache of exact values and compiled programs (fitlab.cache).

Exit status: 0; 2 when the cache folder is not a folder or holds names fitlab does not write (one line;
nothing is counted or removed)."""

from __future__ import annotations

import json

from fitlab.cache import CacheFolderError, cache_info, clear_cache
from fitlab.cli._common import USAGE, add_quiet, describe, fail

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(
        p,
        "fitlab keeps the exact values its commands measure against (training and validation sets, the report's "
        "validation sets) in a cache folder ($FITLAB_CACHE_DIR, else $XDG_CACHE_HOME/fitlab, else ~/.cache/fitlab), "
        "keyed by target, grid, method, fitlab version and the exact engine's source, and the programs JAX compiles "
        "(xla/). Only the names fitlab writes are counted and removed: a folder holding anything else is refused.",
        "fitlab cache info --json",
    )
    p.add_argument("action", choices=("info", "clear"), help="info: what the cache holds; clear: remove every entry")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary")
    add_quiet(p)


def run(args) -> int:
    try:
        return _run(args)
    except CacheFolderError as exc:
        return fail("cache", exc, USAGE)


def _run(args) -> int:
    if args.action == "clear":
        removed = clear_cache()
        summary = {"removed": removed, **cache_info()}
        if args.json:
            print(json.dumps(summary))
        else:
            print(f"removed {removed} entries from {summary['folder']}")
        return 0
    info = cache_info()
    if args.json:
        print(json.dumps(info))
        return 0
    print(f"{info['folder']}: {info['entries']} entries, {info['bytes'] / 1e6:.1f} MB")
    for name, (n, size) in sorted(info["by_name"].items()):
        print(f"  {name:<40} {n:>3} entries  {size / 1e6:8.2f} MB")
    return 0
