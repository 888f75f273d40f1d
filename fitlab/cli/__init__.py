"""The ``fitlab`` command: one module per subcommand, one dispatch.

Each command module has ``HELP`` (its line in ``fitlab --help``),
``add_arguments(parser)`` and ``run(args) -> int`` (the exit status).  A module
parses and validates, reads and writes the files, and calls fitlab's core
functions; heavy dependencies (JAX and the Monte Carlo, pysindy, Mitsuba) are
imported inside ``run``, so that ``fitlab --help`` imports none of them.
"""

from __future__ import annotations

import argparse

from fitlab.cli import audit, bench, cache, codegen, discover, refit, render, report, simulate, tabulate

__all__ = ["COMMANDS", "build_parser", "main"]

#: The commands, in the order ``fitlab --help`` lists them; a command's name is its module's.
COMMANDS = (tabulate, refit, audit, codegen, render, simulate, discover, report, bench, cache)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="fitlab", description="Fitting workbench for analytic BRDFs (Lambert-sphere BRDF).")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        sp = sub.add_parser(command.__name__.rpartition(".")[2], help=command.HELP)
        command.add_arguments(sp)
        sp.set_defaults(func=command.run)
    return p


def main(argv=None) -> int:
    """Run ``fitlab ARGV`` (default: sys.argv[1:]); returns the exit status."""
    args = build_parser().parse_args(argv)
    return args.func(args)

