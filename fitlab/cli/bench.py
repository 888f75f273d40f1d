"""``fitlab bench``: benchmarks (not tests) of the exact engine, the generated code, the Monte Carlo, and
of the commands themselves as a user waits for them."""

from __future__ import annotations

import contextlib
import io
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from fitlab.cli._common import (
    UsageError,
    add_family,
    add_fits,
    add_quiet,
    describe,
    fits_input,
    require_extra,
)
from fitlab.store import strict_json

if TYPE_CHECKING:
    from fitlab.core import Benchmarks

__all__ = ["add_arguments", "run"]

T = TypeVar("T")


def add_arguments(p) -> None:
    describe(p, "Benchmarks, not tests: the exact engine's speed and agreement between its methods, the generated "
                "C against a baseline (and the wall time of `fitlab codegen` itself, cold and warm), the Monte Carlo's photons (or the microsurface walk's paths and bounces) per "
                "second and cost per effect, Mitsuba's samples "
                "per second with the lambert_sphere plugin (render), and (commands) "
                "the seconds of `fitlab --help` and of every single-target refit, cold and warm, in fresh "
                "processes. Prints a table, or with --json a machine-readable summary; writes nothing.",
             "fitlab bench codegen --quick --json")  # fmt: skip
    p.add_argument(
        "what",
        choices=["exact", "codegen", "mc", "render", "commands"],
        help="what to benchmark: exact, codegen, mc, render (Mitsuba samples per second of the "
        "lambert_sphere plugin, llvm_ad_rgb against scalar_rgb) or commands",
    )
    p.add_argument("--quick", action="store_true", help="smaller sizes (commands: the refits of H0 and m only)")
    add_fits(p, "folder of the fits the generated code is built from (codegen)")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary (JSON) instead of the table")
    add_family(p, "bench")
    add_quiet(p)


def _jsonable(obj):
    """The results with tuple keys joined ("H0/0.5") so that they are JSON object keys."""
    if isinstance(obj, dict):
        return {("/".join(str(x) for x in k) if isinstance(k, tuple) else str(k)): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    return obj


def _bench_function(what: str, pick: Callable[[Benchmarks], T | None], family: str | None, quiet: bool) -> T:
    """The benchmark ``what`` (``pick`` of a family's :class:`fitlab.core.Benchmarks`) of --family; without it, of
    the families that have one: the one, else the first (a line on stderr names the others and --family)."""
    from fitlab.core import HasBenchmarks, offering

    having = {name: pick(f.benchmarks()) for name, f in offering(HasBenchmarks).items()}
    having = {name: function for name, function in having.items() if function is not None}
    if family is not None:
        if family not in having:
            raise UsageError(
                f"family {family!r} has no {what!r} benchmark; families that have one: {', '.join(having) or 'none'}"
            )
        return having[family]
    if not having:
        raise UsageError(f"no family has a {what!r} benchmark")
    names = list(having)
    if len(names) > 1 and not quiet:
        print(
            f"fitlab bench {what}: family {names[0]} (also {', '.join(names[1:])}: choose with --family)",
            file=sys.stderr,
        )
    return having[names[0]]


def run(args) -> int:
    fits = fits_input(args) if args.what == "codegen" else None
    # with --json the tables go to stderr (or nowhere with --quiet) and stdout holds only the JSON
    sink = io.StringIO() if args.quiet else sys.stderr
    with contextlib.redirect_stdout(sink) if args.json else contextlib.nullcontext():
        if args.what == "commands":  # generic: fresh processes over every registered target
            from fitlab.cli._bench_commands import QUICK_TARGETS, bench_commands, table
            from fitlab.core import targets

            results = bench_commands(QUICK_TARGETS if args.quick else tuple(targets()), show_progress=not args.quiet)
            print(table(results))
        elif args.what == "exact":
            results = _bench_function("exact", lambda b: b.exact, args.family, args.quiet)(quick=args.quick)
        elif args.what == "codegen":
            from fitlab.cli._bench_commands import codegen_walls

            bench = _bench_function("codegen", lambda b: b.codegen, args.family, args.quiet)
            results = bench(fits, n=100_000 if args.quick else 1_000_000, repeat=3 if args.quick else 5)
            walls = codegen_walls(args.family, fits)
            print(f"fitlab codegen --lang c wall: cold (empty cache) {walls['cold']:.1f} s, warm {walls['warm']:.2f} s "
                  f"(exit status {walls['status']})")  # fmt: skip
            results = {**results, "codegen_wall": walls}
        elif args.what == "render":
            require_extra("mitsuba", "render")
            bench = _bench_function("render", lambda b: b.render, args.family, args.quiet)
            results = bench(quick=args.quick, show_progress=not args.quiet)
        else:
            results = _bench_function("mc", lambda b: b.mc, args.family, args.quiet)(quick=args.quick)  # JAX
    if args.json:
        print(strict_json({"what": args.what, "quick": args.quick, "results": _jsonable(results)}), end="")
    return 0
