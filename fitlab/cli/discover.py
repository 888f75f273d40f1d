"""``fitlab discover``: the command-line face of :mod:`fitlab.discover` (symbolic regression with pysindy).

pysindy is imported by the regression itself, when :func:`run` searches."""

from __future__ import annotations

import sys
from pathlib import Path

from fitlab.discover.cost import COST_REPEAT, COST_ROUNDS, routine_cost
from fitlab.discover.library import get_library, libraries_of
from fitlab.discover.output import front_table, save, save_from_front, write_outputs
from fitlab.discover.search import discover
from fitlab.store import FitFileError, TableError

__all__ = ["HELP", "add_arguments", "run"]

HELP = "symbolic regression (pysindy): a Pareto front of new forms for a target"


def add_arguments(p) -> None:
    p.add_argument("--target", required=True, help=f"what to discover forms for: {', '.join(libraries_of())}")
    p.add_argument("--max-terms", type=int, default=12, help="largest model refitted (default 12)")
    p.add_argument("--minimax-rounds", type=int, default=20, help="Lawson rounds per refit (default 20)")
    p.add_argument("--out", default="docs/discover", help="folder for TARGET.md, .json, .png (default docs/discover)")
    p.add_argument("--fits", default="fits", help="folder of the saved fits (reference points; --save writes here)")
    p.add_argument("--save", action="append", metavar="NAME",
                   help="also write the front member NAME as fits/TARGET.NAME.json (repeatable)")
    p.add_argument("--from-front", action="store_true",
                   help="with --save: take the form from the front written earlier (OUT/TARGET.json), no search")
    p.add_argument("--cost", action="store_true",
                   help="with --save: time the generated C of the saved forms beside the default form (a benchmark)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _message(exc: Exception) -> str:
    """A KeyError's message without the quotes str() adds."""
    return exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)


def _error(msg: str) -> int:
    print(f"fitlab discover: error: {msg}", file=sys.stderr)
    return 2


def run(args) -> int:
    if args.from_front and not args.save:
        return _error("--from-front goes with --save NAME")
    if args.cost and not args.save:
        return _error("--cost goes with --save NAME (it times the saved forms)")
    # a bad destination fails now, not after minutes of search
    for flag, folder in (("--out", Path(args.out)), ("--fits", Path(args.fits))):
        if folder.exists() and not folder.is_dir():
            return _error(f"{flag} {folder}: not a folder")
    if args.from_front:
        try:
            paths = save_from_front(Path(args.out) / f"{args.target}.json", args.save, Path(args.fits))
        except (KeyError, ValueError, OSError) as exc:
            return _error(_message(exc))
        for path in paths:
            print(f"wrote {path}")
        return _print_cost(args)
    try:
        get_library(args.target)
        if args.max_terms < 1 or args.minimax_rounds < 0:
            raise ValueError("--max-terms must be >= 1 and --minimax-rounds >= 0")
        disc = discover(args.target, max_terms=args.max_terms, minimax_rounds=args.minimax_rounds,
                        fits_dir=Path(args.fits), progress=not args.quiet)  # fmt: skip
        for name in args.save or ():
            if name not in disc.front:
                raise KeyError(f"--save {name}: {name!r} is not on the front; the front is {', '.join(disc.front)}")
    except (KeyError, ValueError, FitFileError, TableError) as exc:
        return _error(_message(exc))
    print(front_table(disc))
    for path in write_outputs(disc, Path(args.out)):
        print(f"wrote {path}")
    for name in args.save or ():
        print(f"wrote {save(disc, name, Path(args.fits))}")
    print(f"discover {disc.target}: {disc.seconds:.1f} s")
    return _print_cost(args)


def _print_cost(args) -> int:
    if not (args.cost and args.save):
        return 0
    try:
        ns = routine_cost(args.target, [None, *args.save], Path(args.fits))
    except (KeyError, RuntimeError, FitFileError) as exc:
        print(f"fitlab discover: --cost: {exc.args[0] if exc.args else exc}", file=sys.stderr)
        return 2
    print(f"generated C, double, ns per evaluation (best of {COST_ROUNDS} rounds x {COST_REPEAT}, interleaved; "
          "ratios within this run):")  # fmt: skip
    for name, t in ns.items():
        print(f"  {name:<16} {t:8.2f} ns  {t / ns['default']:5.2f} x default")
    return 0
