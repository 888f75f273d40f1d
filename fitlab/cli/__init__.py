"""The ``fitlab`` command: one module per subcommand, one dispatch.

:data:`COMMANDS` names each command with its line in ``fitlab --help``; the module
``fitlab.cli.NAME`` has ``add_arguments(parser)`` and ``run(args) -> int`` (the exit
status).  Only the module of the command being run is imported, so ``fitlab --help``
and ``fitlab --version`` import no family, no sympy and no JAX.  A module
parses and validates every input and its output folder first (:mod:`fitlab.cli._common`),
then reads and writes the files and calls fitlab's core functions; heavy dependencies
(JAX and the Monte Carlo, pysindy, Mitsuba) are imported inside ``run``, so that
``fitlab --help`` imports none of them.

Exit status: 0 success, 1 a runtime failure, 2 a usage error (refused before any work),
130 Ctrl-C, 141 a closed stdout.  Every error is one line on stderr; a closed stdout (``fitlab refit --list | head``)
ends quietly.  ``FITLAB_TRACEBACK=1`` shows the traceback of an unexpected error.
"""

from __future__ import annotations

import importlib
import os
import sys

from fitlab import __version__
from fitlab import _interrupt as interrupt
from fitlab.cli._common import FAILURE, USAGE, Parser, RunFailure, UsageError, fail

__all__ = ["COMMANDS", "build_parser", "command_module", "main"]

#: The commands, in the order ``fitlab --help`` lists them, with their line there; a command's module
#: is ``fitlab.cli.NAME``.
COMMANDS = {
    "tabulate": "compute the exact tables into the data folder (or check them)",
    "refit": "refit a published form (or a richer one) to the exact data",
    "fit": "fit a form of your own to a column of your own table (CSV)",
    "audit": "measure every published formula and the runtime model against the exact engine",
    "codegen": "generate C, Python, GLSL, HLSL, Metal or Dr.Jit source of the runtime BRDF from the fits",
    "render": "render spheres with the generated BRDF in Mitsuba 3 beside Lambert, Oren-Nayar, Chandrasekhar",
    "simulate": "Monte Carlo: simulate only the effects a scene asks for (a file, or a packaged scene by name)",
    "discover": "symbolic regression (pysindy): a Pareto front of new forms for a target",
    "report": "accuracy vs cost of every way to evaluate the BRDF: report.md, a CSV and a plot",
    "export": "write tables as the files engines load: DFG and albedo tables, OpenEXR, 16-bit PNG, C, GLSL",
    "bench": "benchmarks (not tests): speed and accuracy",
    "cache": "show or clear the persistent cache of exact values",
}


#: the commands that run JAX: they keep its compiled programs in fitlab's cache (fitlab.cache)
JAX_COMMANDS = ("refit", "fit", "audit", "simulate", "discover", "report", "bench")
#: the commands that run the Monte Carlo walks, which JAX runs on one CPU device per core
WALK_COMMANDS = ("simulate", "bench")


def command_module(name: str):
    """The module of command ``name`` (imported on demand)."""
    return importlib.import_module(f"fitlab.cli.{name}")


def build_parser(commands=None) -> Parser:
    """The parser; ``commands``: the commands whose arguments are added (default: all; the others are listed
    with their help line only, enough for ``fitlab --help``)."""
    p = Parser(
        prog="fitlab",
        description="Fitting workbench for analytic BRDFs (Lambert-sphere BRDF).",
        epilog="exit status: 0 success, 1 a runtime failure, 2 a usage error; `fitlab COMMAND --help` for more",
    )
    p.add_argument("--version", action="version", version=f"fitlab {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for name, summary in COMMANDS.items():
        sp = sub.add_parser(name, help=summary, description=summary[:1].upper() + summary[1:] + ".")
        if commands is None or name in commands:
            module = command_module(name)
            module.add_arguments(sp)
            sp.set_defaults(func=module.run)
    return p


def _command_in(argv) -> str | None:
    """The command ``argv`` names (its first word that is not an option), or None."""
    for word in argv:
        if not word.startswith("-"):
            return word if word in COMMANDS else None
    return None


def _closed_stdout() -> None:
    """stdout's reader went away: point stdout at /dev/null so the interpreter's final flush is silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # pragma: no cover - no real stdout (pytest's capture)
        pass


def main(argv=None) -> int:
    """Run ``fitlab ARGV`` (default: sys.argv[1:], the ``fitlab`` command); returns the exit status.

    Ctrl-C is fitlab's from the first line (:mod:`fitlab._interrupt`): at any moment before a command's
    outputs are in place it ends in exit status 130, one line (``fitlab COMMAND: interrupted``), and the old
    files as they were; one after that (refit's last lines) changes nothing.  Called with ``argv`` (from
    Python), the SIGINT handler in force before is put back on return."""
    from_python = argv is not None
    interrupt.install()
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        try:
            status = _run(argv)
        except KeyboardInterrupt:  # Ctrl-C while an error line printed
            status = _interrupted(_command_in(argv) or "")
    finally:
        if from_python:
            interrupt.uninstall()
        else:
            interrupt.close(ignore=True)  # the interpreter's shutdown: a late Ctrl-C changes nothing
    return status


def _interrupted(name: str) -> int:
    interrupt.close()  # a second Ctrl-C while this line prints changes nothing
    print(f"{chr(10) if sys.stderr.isatty() else ''}fitlab{' ' + name if name else ''}: interrupted", file=sys.stderr)
    return 130


#: the commands whose ``--list`` prints what only fitlab's code determines (``listing_text()`` of the command's
#: module): ``fitlab COMMAND --list`` alone prints it from the cache (fitlab.cache.cached_text, keyed by the code)
#: without building the command's parser, whose module imports what its work needs (sympy, JAX: seconds)
LISTINGS = ("refit", "export")


def _run(argv) -> int:
    name = _command_in(argv) or ""
    try:
        if name in LISTINGS and list(argv) == [name, "--list"]:
            return _listing(name)
        args = build_parser(() if not name else (name,)).parse_args(argv)
        name = args.command
        if name in WALK_COMMANDS:
            from fitlab._montecarlo import use_every_core

            use_every_core()  # before JAX starts: one device per core for the walks' meshes
        if name in JAX_COMMANDS:
            from fitlab.cache import enable_compilation_cache

            enable_compilation_cache()
        status = args.func(args)
        sys.stdout.flush()  # a closed pipe surfaces here, not in the interpreter's final flush
        if interrupt.requested():  # a Ctrl-C Python could not raise (in a gc callback), or one it swallowed
            return _interrupted(name)
        return status
    except UsageError as exc:
        return fail(name, exc, USAGE)
    except RunFailure as exc:
        return fail(name, exc, FAILURE)
    except BrokenPipeError:
        _closed_stdout()
        return 141  # as if killed by SIGPIPE, like other tools in a pipeline
    except KeyboardInterrupt:
        return _interrupted(name)
    except MemoryError:
        return fail(name, "out of memory", FAILURE)
    except Exception as exc:  # noqa: BLE001 - no traceback reaches a user; FITLAB_TRACEBACK=1 shows it
        if os.environ.get("FITLAB_TRACEBACK"):
            raise
        if _out_of_memory(exc):
            return fail(name, f"out of memory ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})", FAILURE)
        return fail(name, f"unexpected {type(exc).__name__}: {exc} (FITLAB_TRACEBACK=1 shows where)", FAILURE)


def _listing(name: str) -> int:
    """``fitlab NAME --list`` from the cache (:func:`fitlab.cache.cached_text`, keyed by fitlab's code and the
    installed families): the listing on stdout, and what the registry said on stderr while it made it (a
    family entry point that failed to load), said again by every process that prints the listing from the
    cache (not by one whose registry has loaded already, and so has said it)."""
    import io
    import json

    from fitlab.cache import cached_text

    said = io.StringIO()

    def compute() -> str:
        stderr = sys.stderr
        sys.stderr = _Tee(stderr, said)
        try:
            out = command_module(name).listing_text()
        finally:
            sys.stderr = stderr
        return json.dumps({"out": out, "err": said.getvalue()})

    computed = []
    listing = json.loads(cached_text(f"listing-{name}", lambda: computed.append(True) or compute()))
    print(listing["out"], end="")
    registry = sys.modules.get("fitlab.core._registry")  # loaded: its lines were said in this process
    if listing["err"] and not computed and not (registry is not None and registry.loaded()):
        print(listing["err"], end="", file=sys.stderr)
    sys.stdout.flush()
    return 0


class _Tee:
    """A text stream that writes to several: what a listing's computation says on stderr, shown and kept."""

    def __init__(self, *streams):
        self.streams = streams

    def write(self, text: str) -> int:
        for stream in self.streams:
            stream.write(text)
        return len(text)

    def flush(self) -> None:
        for stream in self.streams:
            stream.flush()


def _out_of_memory(exc: BaseException) -> bool:
    """Whether ``exc`` is JAX's (XLA's) report of an allocation that failed: a runtime error whose status is
    RESOURCE_EXHAUSTED, which is no bug of fitlab's but the machine's memory."""
    return "RuntimeError" in type(exc).__name__ and "RESOURCE_EXHAUSTED" in str(exc)
