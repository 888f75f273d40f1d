"""Atomic writes: a file is either its old self or complete, never half-written; a set of files is
written as one unit (all new, or all as they were), with no temporary left behind.  And bounded reads of
input files: :func:`read_regular_file` reads only a regular file of at most a given size, so that a FIFO,
a device or a huge file named like an input can neither hang a command nor fill its memory."""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import re
import stat
import tempfile
from pathlib import Path
from types import ModuleType

from fitlab._interrupt import check, hold

__all__ = [
    "import_generated",
    "atomic_write_text",
    "atomic_write_bytes",
    "atomic_write_many",
    "temporary_name",
    "InputFileError",
    "TableError",
    "regular_file",
    "read_regular_file",
    "DECIMAL",
    "decimal",
    "text_lines",
    "unusual_character",
]


def temporary_name(path: Path) -> Path:
    """The temporary a write of ``path`` goes through: beside it, named after it and this process
    (``NAME.PID.tmp``), so two processes writing one path never share a temporary."""
    path = Path(path)
    return path.with_name(f"{path.name}.{os.getpid()}.tmp")


def _unlink_quietly(path: Path) -> None:
    try:
        path.unlink()
    except FileNotFoundError:
        pass
    except OSError:  # pragma: no cover - a temporary we cannot remove; the original error matters more
        pass


def atomic_write_text(path: Path, text: str) -> None:
    """:func:`atomic_write_bytes` of ``text`` in UTF-8."""
    atomic_write_bytes(path, text.encode())


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path`` (:func:`temporary_name`), then rename it
    over ``path``.  A failure or an interrupt (Ctrl-C included) leaves ``path`` as it was and no
    temporary behind."""
    atomic_write_many({Path(path): data})


def atomic_write_many(files: dict) -> None:
    """Write several files as one unit: {path: bytes}.

    Every temporary (``NAME.PID.tmp``, beside its target) is written first; only when
    all are complete are they renamed over their targets.  A target that is a folder is refused
    before anything is written; a failure or an interrupt (any BaseException, KeyboardInterrupt
    included) while writing leaves every target as it was and removes every temporary.  The
    renames come last, one by one, each atomic, after a last check for Ctrl-C
    (:func:`fitlab._interrupt.check`: under the ``fitlab`` command a Ctrl-C that Python could not
    raise still refuses the write); a Ctrl-C during the renames waits until all are done
    (:func:`fitlab._interrupt.hold`), so the set is never left half renamed.
    """
    items = [(Path(p), bytes(data)) for p, data in files.items()]
    folders = [p for p, _ in items if p.is_dir()]
    if folders:
        raise IsADirectoryError(f"{folders[0]} is a folder, not a file")
    tmps: list[Path] = []
    try:
        for path, data in items:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = temporary_name(path)
            tmps.append(tmp)
            with open(tmp, "wb") as fh:
                fh.write(data)
        with hold():
            check()  # Ctrl-C before this point: nothing is renamed
            for tmp, (path, _) in zip(tmps, items):
                os.replace(tmp, path)
    except BaseException:
        for tmp in tmps:
            _unlink_quietly(tmp)
        raise


class FolderError(Exception):
    """An output location that is not, or cannot become, a writable folder.

    kind: "file" (it exists and is not a folder), "below_file" (its nearest existing ancestor is not a
    folder), "read_only" (that ancestor denies writing), "unwritable" (a probe file could not be made
    there; ``detail`` says why), "file_is_folder" (a file the command writes is a folder).
    where: the path the problem is at."""

    def __init__(self, kind: str, where: Path, detail: str = ""):
        super().__init__(f"{kind}: {where}{': ' + detail if detail else ''}")
        self.kind, self.where, self.detail = kind, Path(where), detail


def _nearest_existing(path: Path) -> Path:
    probe = Path(os.path.abspath(path))
    while not os.path.lexists(probe):
        probe = probe.parent
    return probe


def check_output_folder(path, files=()) -> Path:
    """``path`` as a Path, once it is certain that a command can write its outputs there (else
    :class:`FolderError`): a folder that exists or can be created, whose nearest existing ancestor
    takes a probe file (created and removed at once, so that /proc, a read-only mount or a folder
    without write permission is refused even for root), none of ``files`` (the names to be written)
    a folder.  Nothing is created."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise FolderError("file", out)
    where = _nearest_existing(out)
    if not where.is_dir():
        raise FolderError("below_file", where)
    if not os.access(where, os.W_OK | os.X_OK):
        raise FolderError("read_only", where)
    try:
        fd, probe = tempfile.mkstemp(prefix=".fitlab-probe-", dir=where)
    except OSError as exc:
        raise FolderError("unwritable", where, str(exc.strerror or exc)) from None
    os.close(fd)
    with contextlib.suppress(OSError):  # pragma: no cover
        os.unlink(probe)
    for name in files:
        if (out / name).is_dir():
            raise FolderError("file_is_folder", out / name)
    return out


class InputFileError(Exception):
    """An input file fitlab will not read.  ``kind``: "missing", "folder", "not_regular" (a FIFO, socket or
    device), "too_large" or "unreadable"; ``reason``: one line without the path (callers name the file, each
    in its own words); ``str()`` is ``PATH: REASON``."""

    def __init__(self, path, kind: str, reason: str):
        super().__init__(f"{path}: {reason}")
        self.path, self.kind, self.reason = Path(path), kind, reason

    def refusal(self, what: str) -> str:
        """The reason as the refusal of a ``what`` ("scene", "table"): "not a regular file (a FIFO), not a
        scene", "a folder, not a scene", "cannot read: no such file"; the reason itself otherwise."""
        if self.kind == "missing":
            return "cannot read: no such file"
        if self.kind == "folder":
            return f"a folder, not a {what}"
        return f"{self.reason}, not a {what}" if self.kind == "not_regular" else self.reason


class TableError(Exception):
    """A table is missing, malformed, or disagrees with a recomputation (:func:`fitlab.store.read_table`; also
    :func:`fitlab.resources.tables_folder`, below the store, which is why it is defined here)."""


_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def _check_stat(path, info: os.stat_result, max_bytes: int) -> os.stat_result:
    if stat.S_ISDIR(info.st_mode):
        raise InputFileError(path, "folder", "a folder, not a file")
    if not stat.S_ISREG(info.st_mode):
        what = next((name for test, name in _KINDS if test(info.st_mode)), "a special file")
        raise InputFileError(path, "not_regular", f"not a regular file ({what})")
    if info.st_size > max_bytes:
        raise InputFileError(path, "too_large", f"{info.st_size} bytes, more than the {max_bytes} bytes fitlab reads")
    return info


def regular_file(path, max_bytes: int) -> os.stat_result:
    """``os.stat(path)`` once it is certain that ``path`` is a regular file (a symbolic link to one counts) of at
    most ``max_bytes`` bytes; else one :class:`InputFileError` line.  Nothing is opened, so a FIFO or a device
    is refused without blocking."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise InputFileError(path, "missing", "no such file") from None
    except OSError as exc:
        raise InputFileError(path, "unreadable", f"cannot read ({exc.strerror or exc})") from None
    return _check_stat(path, info, max_bytes)


def read_regular_file(path, max_bytes: int) -> bytes:
    """The bytes of ``path``, a regular file of at most ``max_bytes`` bytes (:func:`regular_file`, checked before
    it is opened and again on the open file, which is opened without blocking, so that a FIFO put in its place
    in between is refused too); at most ``max_bytes`` are ever read.  Every refusal is one
    :class:`InputFileError` line."""
    regular_file(path, max_bytes)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise InputFileError(path, "missing", "no such file") from None
    except OSError as exc:
        raise InputFileError(path, "unreadable", f"cannot read ({exc.strerror or exc})") from None
    try:
        _check_stat(path, os.fstat(fd), max_bytes)
        with os.fdopen(fd, "rb") as fh:
            fd = -1
            data = fh.read(max_bytes + 1)
    except OSError as exc:
        raise InputFileError(path, "unreadable", f"cannot read ({exc.strerror or exc})") from None
    finally:
        if fd >= 0:
            os.close(fd)
    if len(data) > max_bytes:
        raise InputFileError(path, "too_large", f"more than the {max_bytes} bytes fitlab reads")
    return data


def import_generated(path: Path, prefix: str = "_fitlab_generated") -> ModuleType:
    """The generated Python module (numpy, Dr.Jit) at ``path``, imported from its file, not through fitlab's
    packages: the one loader of generated modules.  Its name is ``PREFIX_HASH``, the hash of the resolved
    path, so that two files never share a module; it is not entered in ``sys.modules``.  The caller checks
    that the file exists and has the members it needs (with its own one-line error); an unreadable file
    raises ``OSError``, a file that is not Python what running it raises."""
    path = Path(path)
    tag = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:16]
    spec = importlib.util.spec_from_file_location(f"{prefix}_{tag}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path}: not a Python module file")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


# -- text of tables ------------------------------------------------------------------
#: a number as fitlab reads one from a table: an optional sign, ASCII digits with at most one point, an optional
#: exponent; or the words inf, infinity and nan (any case, signed), which a reader then takes or refuses by value.
#: Python's float() also takes 995_099, Arabic-Indic and full-width digits and surrounding whitespace: not numbers
#: a table should hold
DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?|[+-]?(?i:inf|infinity|nan)")
#: the characters a table's text may not hold: control characters other than tab and the line breaks, and the
#: characters some readers take for line breaks (U+0085, U+2028, U+2029) where text editors do not
_UNUSUAL = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f\x85\u2028\u2029]")
_LINE_BREAK = re.compile(r"\r\n|\r|\n")


def decimal(text: str) -> float:
    """``text`` as a float when it is a plain decimal number (:data:`DECIMAL`); ValueError otherwise."""
    if not DECIMAL.fullmatch(text):
        raise ValueError(f"{text[:40]!r} is not a decimal number")
    return float(text)


def text_lines(text: str) -> list[str]:
    """The lines of ``text`` as text editors number them (from 1): split at CR LF, CR and LF only (str.splitlines
    also splits at U+2028, form feeds and others, which editors do not); a line break at the end ends the last
    line."""
    lines = _LINE_BREAK.split(text)
    if lines and not lines[-1]:
        lines.pop()
    return lines


def unusual_character(text: str) -> tuple[int, str] | None:
    """(line number as :func:`text_lines` counts, description) of the first character of ``text`` a table may
    not hold (a control character, U+0085, U+2028, U+2029), or None."""
    found = _UNUSUAL.search(text)
    if found is None:
        return None
    line = len(_LINE_BREAK.findall(text, 0, found.start())) + 1
    import unicodedata

    char = found.group()
    name = unicodedata.name(char, "a control character")
    return line, f"U+{ord(char):04X} ({name.lower()})"
