"""Atomic text writes: a file is either its old self or complete, never half-written."""

from __future__ import annotations

import os
from pathlib import Path


def atomic_write_text(path: Path, text: str) -> None:
    """:func:`atomic_write_bytes` of ``text`` in UTF-8."""
    atomic_write_bytes(path, text.encode())


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it over ``path``.

    The temporary's name carries the process id, so two processes writing one path (two runs
    filling one cache) never interleave their bytes in one file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def atomic_write_many(files: dict) -> None:
    """Write several files as one unit: {path: bytes}.

    Every temporary file is written first; only when all are complete are they
    renamed over their targets.  A target that is a folder, or a failure while
    writing, leaves every target as it was (and no temporary behind).  The
    renames themselves are atomic one by one.
    """
    paths = [Path(p) for p in files]
    folders = [p for p in paths if p.is_dir()]
    if folders:
        raise IsADirectoryError(f"{folders[0]} is a folder, not a file")
    tmps = []
    try:
        for path, data in zip(paths, files.values()):
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".tmp")
            tmps.append(tmp)
            tmp.write_bytes(data)
    except BaseException:
        for tmp in tmps:
            if tmp.is_file():
                tmp.unlink()
        raise
    for tmp, path in zip(tmps, paths):
        os.replace(tmp, path)
