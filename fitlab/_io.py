"""Atomic writes: a file is either its old self or complete, never half-written; a set of files is
written as one unit (all new, or all as they were), with no temporary left behind."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from fitlab._interrupt import check, hold

__all__ = ["atomic_write_text", "atomic_write_bytes", "atomic_write_many", "temporary_name"]


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
    try:
        os.unlink(probe)
    except OSError:  # pragma: no cover
        pass
    for name in files:
        if (out / name).is_dir():
            raise FolderError("file_is_folder", out / name)
    return out
