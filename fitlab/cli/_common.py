"""What every ``fitlab`` command shares: checking its inputs and output folder before any work, one-line
errors with the conventional exit status, the ``--quiet`` flag, the one-line argparse parser.

Exit status: 0 success; 1 a runtime failure (a computation that failed, a refit worse than its start);
2 a usage error (a bad option or value, an input that is missing or not what it should be, an output
location that cannot take the outputs), always refused before any computation starts.

A command raises :class:`UsageError` (exit 2) or :class:`RunFailure` (exit 1) with a one-line message,
or returns :func:`fail`'s status; :func:`fitlab.cli.main` prints ``fitlab COMMAND: error: MESSAGE``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from fitlab._io import FolderError, check_output_folder

if TYPE_CHECKING:
    from fitlab.core import Capability

C = TypeVar("C", bound="Capability")

__all__ = [
    "USAGE",
    "FAILURE",
    "UsageError",
    "RunFailure",
    "Parser",
    "fail",
    "one_line",
    "output_folder",
    "input_file",
    "input_folder",
    "write_failure",
    "write_files",
    "number",
    "integer",
    "add_quiet",
    "say",
    "describe",
    "add_fits",
    "fits_input",
    "add_data",
    "use_data",
    "add_family",
    "family_with",
    "Once",
]

#: exit status of a runtime failure and of a usage error
FAILURE, USAGE = 1, 2


class UsageError(Exception):
    """A bad option, value, input or output location: one line, exit status 2, nothing computed."""


class RunFailure(Exception):
    """A computation that failed (or ended in a result fitlab refuses to keep): one line, exit status 1."""


def one_line(message) -> str:
    """``message`` (an exception or text) as one line: a KeyError without its quotes, newlines folded."""
    if isinstance(message, KeyError) and message.args:
        message = message.args[0]
    text = str(message) if str(message) else type(message).__name__
    return "; ".join(part.strip() for part in text.splitlines() if part.strip())


def fail(command: str, message, status: int = USAGE) -> int:
    """Print ``fitlab COMMAND: error: MESSAGE`` (one line; ``fitlab: error: ...`` when no command is named)
    on stderr; returns ``status``."""
    print(f"fitlab{' ' + command if command else ''}: error: {one_line(message)}", file=sys.stderr)
    return status


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error (``fitlab refit: error: argument --kd: ...``), still exit status 2."""

    def error(self, message):  # noqa: D401 - argparse's hook
        self.exit(USAGE, f"{self.prog}: error: {one_line(message)} (see {self.prog} --help)\n")


class Once(argparse.Action):
    """An option that takes one value: given twice, a usage error (argparse would keep the last silently)."""

    def __call__(self, parser, namespace, values, option_string=None):
        before = getattr(namespace, self.dest, None)
        if before is not None and before != self.default:
            parser.error(f"argument {option_string}: given twice ({before}, then {values}); it takes one value")
        setattr(namespace, self.dest, values)


# -- values ------------------------------------------------------------------------
def number(lo: float | None = None, hi: float | None = None, *, open_lo: bool = False, open_hi: bool = False):
    """An argparse ``type``: a finite float within [lo, hi] (or an open end); anything else is a usage error."""

    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(x):
            raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
        if lo is not None and (x < lo or (open_lo and x == lo)):
            raise argparse.ArgumentTypeError(f"{text} must be {'>' if open_lo else '>='} {lo:g}")
        if hi is not None and (x > hi or (open_hi and x == hi)):
            raise argparse.ArgumentTypeError(f"{text} must be {'<' if open_hi else '<='} {hi:g}")
        return x

    parse.__name__ = "number"
    return parse


def integer(lo: int | None = None, hi: int | None = None):
    """An argparse ``type``: an integer within [lo, hi]."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if (lo is not None and n < lo) or (hi is not None and n > hi):
            bounds = (
                f"between {lo} and {hi}"
                if lo is not None and hi is not None
                else (f">= {lo}" if lo is not None else f"<= {hi}")
            )
            raise argparse.ArgumentTypeError(f"{text} must be {bounds}")
        return n

    parse.__name__ = "integer"
    return parse


# -- files and folders -------------------------------------------------------------
def output_folder(path, flag: str = "--out", files=()) -> Path:
    """Check that ``path`` can take a command's outputs before any work starts; returns it as a Path
    (:func:`fitlab._io.check_output_folder`: a folder that exists or can be made, writable, none of
    ``files`` a folder; nothing is created).  Refusals are :class:`UsageError`."""
    if path is None or str(path).strip() == "":
        raise UsageError(f"{flag}: give a folder")
    out = Path(path)
    try:
        return check_output_folder(out, files)
    except FolderError as exc:
        message = {
            "file": "exists and is not a folder",
            "below_file": f"{exc.where} is not a folder",
            "read_only": f"{exc.where} is not writable",
            "unwritable": f"cannot write in {exc.where} ({exc.detail})",
            "file_is_folder": f"{exc.where} is a folder, where a file will be written",
        }[exc.kind]
        raise UsageError(f"{flag} {out}: {message}") from None


def write_failure(out, exc: OSError) -> RunFailure:
    """The one-line failure of a write into ``out`` that the checks could not foresee (a full disk)."""
    return RunFailure(f"cannot write into {out}: {exc.strerror or one_line(exc)}; nothing written")


def write_files(args, out: Path, files: dict[str, bytes]) -> int:
    """Every file ({name: bytes}) into ``out`` as one unit (:func:`fitlab._io.atomic_write_many`: all new, or all
    as they were, no stray temporary), each named unless --quiet; 0, the exit status."""
    from fitlab._io import atomic_write_many

    paths = {Path(out) / name: data for name, data in files.items()}
    try:
        atomic_write_many(paths)
    except OSError as exc:
        raise write_failure(out, exc) from None
    for path in paths:
        say(args, f"wrote {path}")
    return 0


def input_file(path, flag: str, hint: str = "") -> Path:
    """An input file that must exist, be a file and be readable (:class:`UsageError` otherwise)."""
    p = Path(path)
    if not p.exists():
        raise UsageError(f"{flag} {p}: no such file{hint}")
    if not p.is_file():
        raise UsageError(f"{flag} {p}: not a file")
    if not os.access(p, os.R_OK):
        raise UsageError(f"{flag} {p}: not readable")
    return p


def input_folder(path, flag: str, required: bool = True) -> Path:
    """An input folder: it must be a folder (and exist, unless ``required`` is false)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise UsageError(f"{flag} {p}: not a folder")
    if required and not p.exists():
        raise UsageError(f"{flag} {p}: no such folder")
    return p


# -- conventions --------------------------------------------------------------------
def add_quiet(p) -> None:
    """``--quiet``: no progress bar and no status lines (results and errors still print)."""
    p.add_argument(
        "--quiet", action="store_true", help="no progress bar or status lines (results and errors still print)"
    )


def add_fits(p, what: str = "folder of the fits JSON") -> None:
    """``--fits DIR``: where fits are read from (default: the fits packaged with fitlab)."""
    p.add_argument("--fits", default=None, metavar="DIR", help=f"{what} (default: the fits packaged with fitlab)")


def fits_input(args, required: bool = True) -> Path | None:
    """``--fits`` checked as an input folder (None: the packaged fits, :func:`fitlab.store.fits_folder`)."""
    return None if args.fits is None else input_folder(args.fits, "--fits", required=required)


def add_data(p, output: bool = False) -> None:
    """``--data DIR``: the user's data folder, where ``fitlab tabulate`` writes the exact tables and every
    command reads them (default: $FITLAB_DATA, else ~/.local/share/fitlab; the packaged tables are the
    fallback)."""
    from fitlab.resources import DATA_ENV

    verb = "write the exact tables into DIR/FAMILY/" if output else "read the exact tables from DIR/FAMILY/ when there"
    p.add_argument(
        "--data",
        default=None,
        metavar="DIR",
        help=f"the data folder: {verb} (default: ${DATA_ENV}, else ~/.local/share/fitlab"
        f"{'' if output else '; else the tables packaged with fitlab'})",
    )


def use_data(args, required: bool = True) -> Path:
    """Apply ``--data`` for this process (it sets $FITLAB_DATA, which :mod:`fitlab.resources` reads) after
    checking it is a folder; returns the data folder in force."""
    from fitlab.resources import DATA_ENV, data_root

    if getattr(args, "data", None) is not None:
        folder = input_folder(args.data, "--data", required=required)
        os.environ[DATA_ENV] = str(folder)
    return data_root()


def say(args, message: str) -> None:
    """A status line (``wrote PATH``): on stdout, on stderr with ``--json`` (stdout holds only the JSON),
    nowhere with ``--quiet``."""
    if not getattr(args, "quiet", False):
        print(message, file=sys.stderr if getattr(args, "json", False) else sys.stdout)


def describe(p, description: str, example: str) -> None:
    """A subcommand's ``--help``: its description and an example."""
    p.description = description
    p.epilog = f"example: {example}"


def require_extra(module: str, extra: str) -> None:
    """Refuse (usage error, one line) when an optional dependency is missing: name the extra that brings it."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise UsageError(f"this command needs {module}, which is not installed: pip install 'fitlab-brdf[{extra}]'")


def add_family(p, what: str, default: str = "the one family that has it") -> None:
    """``--family NAME``: which family's ``what`` a command uses (needed when several have it)."""
    p.add_argument(
        "--family", metavar="NAME", default=None, help=f"the family whose {what} to use (default: {default})"
    )


def family_with(capability: type[C], family: str | None = None) -> C:
    """The family ``family`` when it has ``capability`` (:func:`fitlab.core.family_with`), or the one family that
    has it; a usage error (one line) otherwise."""
    from fitlab.core import family_with as having

    try:
        return having(capability, family)
    except KeyError as exc:
        raise UsageError(one_line(exc.args[0] if exc.args else exc)) from None
