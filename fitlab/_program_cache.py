"""The store behind JAX's persistent compilation cache in fitlab's cache folder (``CACHE/xla``): the rules
of :mod:`fitlab.cache` for compiled programs.

JAX's own file store (``jax._src.lru_cache.LRUCache``) writes an entry in place and never replaces one: a
write cut short (a full disk leaves zero-byte files) or a damaged file stays a failed read, with a
``UserWarning`` per program, in every later run.  :class:`ProgramCache` takes its place (JAX's
``CacheInterface``; :func:`fitlab.cache.enable_compilation_cache` installs it):

* an entry (``KEY.xla``, :data:`fitlab.cache.PROGRAM_SUFFIX`) holds a magic line, the sha256 of its key
  and of the program's bytes, then those bytes; one that is missing, short, damaged, another key's, not a
  regular file (a FIFO never blocks the read) or larger than :data:`fitlab.cache.MAX_ENTRY_BYTES` is a
  miss, and is removed, so that JAX compiles the program and writes it again;
* writes are atomic (a temporary named with the process id, then a rename): a failed write leaves the
  old entry or none, and no temporary;
* nothing it meets raises: a folder that cannot be made (a file in its way), read or written (read only,
  a full disk) only costs compile time, and is named in one warning line on stderr, once per process.

JAX's size bound (``jax_compilation_cache_max_size``) is not applied: fitlab's programs take a few MB.
Imports JAX's internals: import this module only where JAX runs.
"""

from __future__ import annotations

import hashlib
import os
import sys
from contextlib import suppress
from pathlib import Path

from jax._src.compilation_cache_interface import CacheInterface

from fitlab._io import InputFileError, read_regular_file, temporary_name

__all__ = ["ProgramCache", "MAGIC", "entry_bytes"]

#: the first bytes of an entry
MAGIC = b"fitlab-xla-program/1\n"
_DIGEST = 32
#: whether this process has printed its one line about the folder
_reported = False


def _digest(key: str, program: bytes) -> bytes:
    h = hashlib.sha256(key.encode())
    h.update(b"\0")
    h.update(program)
    return h.digest()


def entry_bytes(key: str, program: bytes) -> bytes:
    """The bytes of the entry of ``program`` under ``key``: :data:`MAGIC`, the sha256 of the key and the program,
    the program."""
    return MAGIC + _digest(key, program) + program


def _report(folder: Path, exc: OSError) -> None:
    global _reported
    if _reported:
        return
    _reported = True
    why = exc.strerror or type(exc).__name__
    print(
        f"fitlab: warning: JAX's compiled programs cannot be kept in {folder} ({why}): each run compiles them again",
        file=sys.stderr,
        flush=True,
    )


def _remove(path: Path) -> None:
    with suppress(OSError):  # a read-only folder keeps it: a miss each time, never a wrong program
        os.unlink(path)


class ProgramCache(CacheInterface):
    """JAX's ``CacheInterface`` on the folder ``path`` (module docstring)."""

    def __init__(self, path, suffix: str, max_bytes: int):
        self._path = Path(path)
        self._suffix, self._max_bytes = suffix, max_bytes
        try:
            self._path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            _report(self._path, exc)

    def _entry(self, key: str) -> Path | None:
        if not key or os.sep in key or "/" in key or key.startswith("."):
            return None  # JAX's keys are MODULE-HASH; anything else is never a file name here
        return self._path / f"{key}{self._suffix}"

    def get(self, key: str) -> bytes | None:
        path = self._entry(key)
        if path is None:
            return None
        try:
            data = read_regular_file(path, self._max_bytes)
        except InputFileError as exc:
            if exc.kind in ("not_regular", "too_large"):
                _remove(path)
            return None
        head = len(MAGIC) + _DIGEST
        program = data[head:]
        if len(data) <= head or not data.startswith(MAGIC) or data[len(MAGIC) : head] != _digest(key, program):
            _remove(path)  # damaged, cut short or another key's: a miss, compiled and written again
            return None
        return program

    def put(self, key: str, value: bytes) -> None:
        path = self._entry(key)
        if path is None:
            return
        tmp = temporary_name(path)
        try:
            with open(tmp, "wb") as fh:
                fh.write(entry_bytes(key, bytes(value)))
            os.replace(tmp, path)
        except OSError as exc:
            _remove(tmp)
            _report(self._path, exc)
        except BaseException:
            _remove(tmp)
            raise
