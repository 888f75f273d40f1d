"""``fitlab discover``: the command-line face of :mod:`fitlab.discover` (symbolic regression with pysindy).

pysindy is imported by the regression itself, when :func:`run` searches."""

from __future__ import annotations

from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_data,
    add_quiet,
    describe,
    fail,
    fits_input,
    input_folder,
    one_line,
    output_folder,
    require_extra,
    say,
    use_data,
    write_failure,
)
from fitlab.discover.cost import COST_REPEAT, COST_ROUNDS, routine_cost
from fitlab.discover.library import get_library, libraries_of
from fitlab.discover.output import front_table, save_from_front, write_outputs
from fitlab.discover.search import discover
from fitlab.fit.solver import FitError
from fitlab.store import FitFileError, TableError, fit_path, write_fits

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Search a library of terms (pysindy) for new forms of a target, refit each size, and write the "
                "Pareto front of error against cost as TARGET.md, .json and .png into --out; --save NAME also "
                "writes front members as fits (--fits/TARGET.NAME.json) that refit, codegen and report take.",
             "fitlab discover --target H0 --out /tmp/discover --max-terms 6")  # fmt: skip
    p.add_argument(
        "table",
        nargs="?",
        metavar="TABLE.csv",
        default=None,
        help="a table of your own (CSV with a header row, as `fitlab fit` reads it): search forms of its "
        "column --target in its other columns (or --inputs)",
    )
    p.add_argument(
        "--target",
        required=True,
        metavar="NAME",
        help=f"what to discover forms for: {', '.join(libraries_of())}; with TABLE.csv, its column to fit",
    )
    p.add_argument(
        "--inputs", metavar="X,Y", default=None, help="with TABLE.csv: the input columns (default: every other column)"
    )
    p.add_argument("--max-terms", type=int, default=12, help="largest model refitted (default 12)")
    p.add_argument("--minimax-rounds", type=int, default=20, help="Lawson rounds per refit (default 20)")
    p.add_argument("--out", default="discover", help="folder for TARGET.md, .json, .png (default: discover)")
    p.add_argument(
        "--fits",
        default=None,
        metavar="DIR",
        help="folder of saved fits: the reference points are read from it and --save writes into it "
        "(default: the fits packaged with fitlab, read only; --save needs --fits)",
    )
    p.add_argument(
        "--save",
        action="append",
        metavar="NAME",
        help="also write the front member NAME as TARGET.NAME.json into --fits (repeatable)",
    )
    add_data(p)
    p.add_argument(
        "--from-front",
        action="store_true",
        help="with --save: take the form from the front written earlier (OUT/TARGET.json), no search",
    )
    p.add_argument(
        "--cost",
        action="store_true",
        help="with --save: time the generated C of the saved forms beside the default form (a benchmark)",
    )
    add_quiet(p)


def _run_table(args) -> int:
    """``fitlab discover TABLE.csv --target COLUMN``: the search on a table of one's own (:mod:`fitlab.discover.user`);
    --save writes front members as fits of that table (FITS/COLUMN.NAME.json, the table beside each), from this
    search or, with --from-front, from the front a search wrote earlier into --out (no search)."""
    from fitlab.fit.user import UserDataError, read_csv_table

    given = [flag for flag, value in (("--cost", args.cost), ("--data", args.data)) if value]
    if given:
        raise UsageError(f"{given[0]} goes with a fitlab target, not with a table of your own")
    if args.from_front and not args.save:
        raise UsageError("--from-front goes with --save NAME")
    if args.max_terms < 1 or args.minimax_rounds < 0:
        raise UsageError("--max-terms must be >= 1 and --minimax-rounds >= 0")
    if args.save and len(set(args.save)) != len(args.save):
        raise UsageError("--save: a name given twice")
    inputs = None if args.inputs is None else [n.strip() for n in args.inputs.split(",") if n.strip()]
    if args.from_front:
        input_folder(args.out, "--out")  # the front is read from it
    else:
        out = output_folder(args.out, "--out", files=[f"{args.target}{ext}" for ext in (".md", ".json", ".png")])
    if args.save:
        if args.fits is None:
            raise UsageError("--save writes into --fits: give the folder (for example --fits fits)")
        output_folder(args.fits, "--fits")
    try:
        table = read_csv_table(args.table)
    except UserDataError as exc:
        raise UsageError(one_line(exc)) from None
    if args.from_front:
        try:
            paths = save_from_front(Path(args.out) / f"{args.target}.json", args.save, Path(args.fits), table)
        except (KeyError, ValueError, FitFileError) as exc:
            raise UsageError(one_line(exc)) from None
        except OSError as exc:
            raise write_failure(args.fits, exc) from None
        for path in paths:
            say(args, f"wrote {path}")
        return 0
    require_extra("pysindy", "discover")
    from fitlab.discover.user import prepare_table, search_rows

    try:
        rows = prepare_table(table, args.target, inputs=inputs, max_terms=args.max_terms)
    except UserDataError as exc:  # the checks of the table, before the search
        raise UsageError(one_line(exc)) from None
    try:
        disc = search_rows(rows, max_terms=args.max_terms, minimax_rounds=args.minimax_rounds, progress=not args.quiet)
    except (FitError, ValueError, ArithmeticError) as exc:
        raise RunFailure(f"the search failed: {one_line(exc)}") from None
    _print_front(disc, args.save)
    from fitlab._io import atomic_write_many
    from fitlab.fit.user import table_beside
    from fitlab.store import check_fit, strict_json

    saved = {}
    for name in args.save or ():
        path = Path(args.fits) / f"{disc.target}.{name}.json"
        record = disc.get(name).record
        record = {**record, "user_data": {**record["user_data"], "file": table_beside(path).name}}
        saved[table_beside(path)] = table.data
        saved[path] = strict_json(check_fit(record, str(path))).encode()
    try:
        written = write_outputs(disc, out)  # the front's three files as one unit
        if saved:  # every saved form, each with its table, as one unit
            atomic_write_many(saved)
            written += list(saved)
    except OSError as exc:
        raise write_failure(args.out, exc) from None
    for path in written:
        say(args, f"wrote {path}")
    say(args, f"discover {disc.target}: {disc.seconds:.1f} s")
    return 0


def _print_front(disc, save) -> None:
    """Refuse a --save NAME that is not on the front (before anything is written), then print the front."""
    for name in save or ():
        if name not in disc.front:
            raise RunFailure(f"--save {name}: {name!r} is not on the front; the front is {', '.join(disc.front)}")
    print(front_table(disc))


def run(args) -> int:
    if args.table is not None:
        return _run_table(args)
    if args.inputs is not None:
        raise UsageError("--inputs goes with a table of your own (fitlab discover TABLE.csv --target COLUMN)")
    if args.from_front and not args.save:
        raise UsageError("--from-front goes with --save NAME")
    if args.cost and not args.save:
        raise UsageError("--cost goes with --save NAME (it times the saved forms)")
    if args.max_terms < 1 or args.minimax_rounds < 0:
        raise UsageError("--max-terms must be >= 1 and --minimax-rounds >= 0")
    if args.save and len(set(args.save)) != len(args.save):
        raise UsageError("--save: a name given twice")
    try:
        get_library(args.target)
    except (KeyError, ValueError) as exc:
        raise UsageError(one_line(exc)) from None
    # a bad destination fails now, not after minutes of search
    if args.from_front:
        input_folder(args.out, "--out")  # the front is read from it
    else:
        output_folder(args.out, "--out", files=[f"{args.target}{ext}" for ext in (".md", ".json", ".png")])
    if args.save:
        if args.fits is None:
            raise UsageError("--save writes into --fits: give the folder (for example --fits fits)")
        output_folder(args.fits, "--fits")
    else:
        fits_input(args, required=False)
    use_data(args)
    if args.from_front:
        try:
            paths = save_from_front(Path(args.out) / f"{args.target}.json", args.save, Path(args.fits))
        except (KeyError, ValueError, FitFileError) as exc:
            raise UsageError(one_line(exc)) from None
        for path in paths:
            say(args, f"wrote {path}")
        return _print_cost(args)
    require_extra("pysindy", "discover")

    try:
        disc = discover(args.target, max_terms=args.max_terms, minimax_rounds=args.minimax_rounds,
                        fits_dir=args.fits, progress=not args.quiet)  # fmt: skip
    except (FitFileError, TableError, KeyError) as exc:
        raise UsageError(one_line(exc)) from None
    except (FitError, ValueError, ArithmeticError) as exc:
        raise RunFailure(f"the search failed: {one_line(exc)}") from None
    _print_front(disc, args.save)
    try:
        written = write_outputs(disc, Path(args.out))  # the front's three files as one unit
        if args.save:  # every saved form as one unit
            written += write_fits({fit_path(Path(args.fits), disc.target, n): disc.get(n).record for n in args.save})
    except OSError as exc:
        raise write_failure(args.out, exc) from None
    for path in written:
        say(args, f"wrote {path}")
    say(args, f"discover {disc.target}: {disc.seconds:.1f} s")
    return _print_cost(args)


def _print_cost(args) -> int:
    if not (args.cost and args.save):
        return 0
    try:
        ns = routine_cost(args.target, [None, *args.save], args.fits)
    except (KeyError, FitFileError) as exc:
        return fail("discover --cost", exc, 2)
    except RuntimeError as exc:  # the compiler or the timing failed
        return fail("discover --cost", exc, 1)
    print(f"generated C, double, ns per evaluation (best of {COST_ROUNDS} rounds x {COST_REPEAT}, interleaved; "
          "ratios within this run):")  # fmt: skip
    for name, t in ns.items():
        print(f"  {name:<16} {t:8.2f} ns  {t / ns['default']:5.2f} x default")
    return 0
