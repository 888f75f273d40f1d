r"""A persistent cache of exact values: compute once per machine, share between commands.

Exact values (training and validation sets, constants on their grids, the
report's validation sets) are the slow part of every command that measures a
fit; a runtime model's energy scale (a quadrature of the model) is the slow part
of building one.  :func:`cached_arrays` keeps them on disk, keyed by everything that
determines them: a name, the caller's key (target, grid, method), the fitlab
version and the bytes of the source files that compute them, so that a change
of engine is a miss, never a stale hit.

Details: docs/reliability.md, section ``fitlab.cache``."""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager, suppress
from pathlib import Path

import numpy as np

from fitlab import __version__
from fitlab._io import atomic_write_bytes, regular_file
from fitlab.resources import packaged_exact_values

try:
    import fcntl
except ImportError:  # Windows: no flock, no lock (see docs/reliability.md)
    fcntl = None

__all__ = [
    "cache_dir",
    "cache_key",
    "cached_arrays",
    "cached_at",
    "cached_files",
    "cache_info",
    "clear_cache",
    "enabled",
    "enable_compilation_cache",
    "package_sources",
    "INPUT_PREFIX",
    "CacheFolderError",
    "PROGRAM_SUFFIX",
    "cached_text",
    "family_entry_points",
]

_SUFFIX = ".npz"
#: the array of an entry that holds its content hash (:func:`_content_hash`)
_HASH = "_fitlab_sha256"
#: the largest entry read, in bytes (the largest the commands make are a few MB)
MAX_ENTRY_BYTES = 2_000_000_000
#: the subfolder of JAX's compiled programs
_XLA = "xla"
#: the suffix of a compiled program's entry in it (:mod:`fitlab._program_cache`)
PROGRAM_SUFFIX = ".xla"
#: the subfolder of the entries' lock files (:func:`_computing`)
_LOCKS = "locks"
#: how deep this thread is in cached_arrays computes: only the outermost takes a lock
_depth = threading.local()


def cache_dir() -> Path:
    """The cache folder (see docs/reliability.md)."""
    if os.environ.get("FITLAB_CACHE_DIR"):
        return Path(os.environ["FITLAB_CACHE_DIR"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "fitlab"


def enabled() -> bool:
    return os.environ.get("FITLAB_NO_CACHE", "") in ("", "0")


def cache_key(parts: Mapping, sources: Iterable[Path] = ()) -> str:
    """sha256 (24 hex digits) of the fitlab version, ``parts`` (JSON with sorted keys; numpy arrays by
    their float64 bytes) and the names and bytes of ``sources`` (the files that compute the values)."""
    h = hashlib.sha256(__version__.encode())
    plain = {k: v for k, v in parts.items() if not isinstance(v, np.ndarray)}
    h.update(json.dumps(plain, sort_keys=True, default=str).encode())
    for k in sorted(k for k, v in parts.items() if isinstance(v, np.ndarray)):
        h.update(k.encode())
        h.update(np.ascontiguousarray(parts[k], dtype="<f8").tobytes())
    for src in sorted(Path(s) for s in sources):
        h.update(src.name.encode())
        h.update(src.read_bytes())
    return h.hexdigest()[:24]


def package_sources() -> list[Path]:
    """Every file of the installed fitlab that can change what a command computes: its Python modules, the fit
    files and schemas it ships (not the generated code, nor compiled bytecode).  A key over these is a miss after
    any change of fitlab, never a stale hit."""
    root = Path(__file__).resolve().parent
    return sorted(p for p in root.rglob("*") if p.suffix in (".py", ".json") and "__pycache__" not in p.parts
                  and "generated" not in p.relative_to(root).parts and p.is_file())  # fmt: skip


def cached_files(name: str, parts: Mapping, compute: Callable[[], Mapping[str, bytes]],
                 sources: Iterable[Path] = (), use_cache: bool = True) -> dict[str, bytes]:  # fmt: skip
    """The named byte strings ``compute()`` returns ({name: bytes}, e.g. the files a command writes), kept in the
    cache as one entry of :func:`cached_arrays` (the names, their sizes and their bytes), keyed as it keys."""

    def arrays():
        files = dict(compute())
        blobs = [np.frombuffer(bytes(v), dtype=np.uint8) for v in files.values()]
        return {"names": np.array(list(files), dtype=str), "sizes": np.array([b.size for b in blobs], dtype=np.int64),
                "blob": np.concatenate(blobs) if blobs else np.zeros(0, dtype=np.uint8)}  # fmt: skip

    got = cached_arrays(name, parts, arrays, ("names", "sizes", "blob"), sources, use_cache)
    ends = np.cumsum(got["sizes"])  # the entry's content hash holds the three arrays as compute() made them
    return {str(n): got["blob"][e - int(k) : e].tobytes() for n, k, e in zip(got["names"], got["sizes"], ends)}


def _content_hash(entry: str, arrays: Mapping[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
    """sha256 of an entry's name and key (``entry``, its file name) and of its arrays ``names`` (each one's name,
    dtype, shape and bytes), as 32 bytes."""
    h = hashlib.sha256(entry.encode())
    for n in names:
        a = np.ascontiguousarray(arrays[n])
        h.update(f"\0{n}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return np.frombuffer(h.digest(), dtype=np.uint8).copy()


def _load(path: Path, names: tuple[str, ...]) -> dict | None:
    try:
        regular_file(path, MAX_ENTRY_BYTES)  # before opening: a FIFO never blocks the read
        with np.load(path, allow_pickle=False) as z:
            out = {n: np.array(z[n]) for n in names}
            stated = np.array(z[_HASH])
    except Exception:  # noqa: BLE001 - missing, truncated or damaged (EOFError, BadZipFile, KeyError, ...): a miss
        return None
    if not np.array_equal(stated, _content_hash(path.name, out, names)):
        return None  # wrong values, or another entry's: a miss, recomputed and overwritten
    return out


def cached_arrays(
    name: str,
    parts: Mapping,
    compute: Callable[[], Mapping[str, np.ndarray]],
    names: tuple[str, ...],
    sources: Iterable[Path] = (),
    use_cache: bool = True,
) -> dict[str, np.ndarray]:
    """The arrays ``compute()`` returns (a mapping with keys ``names``), from the cache when present.

    ``name`` starts the entry's file name (``NAME-KEY.npz``); ``parts`` and ``sources`` make its key
    (:func:`cache_key`)."""
    if _HASH in names:
        raise ValueError(f"cache entry {name}: {_HASH} is the name of the entry's content hash")
    use = use_cache and enabled()
    path = cache_dir() / f"{name}-{cache_key(parts, sources)}{_SUFFIX}"
    if use:
        hit = _load(path, names)
        if hit is not None:
            return hit
    with _computing(path if use else None):
        if use:  # another process may have written it while this one waited for the lock
            hit = _load(path, names)
            if hit is not None:
                return hit
            # the seed fitlab ships (what a fresh install's commands measure against first), checked as any entry
            shipped = _load(packaged_exact_values() / path.name, names)
            if shipped is not None:
                _store(path, shipped, names)
                return shipped
        values = {n: np.asarray(v) for n, v in compute().items()}
        missing = [n for n in names if n not in values]
        if missing:
            raise KeyError(f"cache entry {name}: compute() gave no {missing}")
        if use:
            _store(path, values, names)
    return {n: values[n] for n in names}


def _store(path: Path, values: Mapping[str, np.ndarray], names: tuple[str, ...]) -> None:
    """Write an entry (its arrays and their content hash) atomically; a cache that cannot be written only costs
    time."""
    buf = io.BytesIO()
    np.savez(buf, **{n: values[n] for n in names}, **{_HASH: _content_hash(path.name, values, names)})
    with suppress(OSError):
        atomic_write_bytes(path, buf.getvalue())


def family_entry_points() -> list[str]:
    """The installed ``fitlab.families`` entry points as "name=value@distribution-version", sorted, and the families
    registered in this process by a module of their own ("name=module:class"): what, beside fitlab's own files
    (:func:`package_sources`), decides what the registry holds.  Taken from the registry's view of them where it is
    loaded (as tests set it)."""
    registry = sys.modules.get("fitlab.core._registry")
    entry_points = getattr(registry, "entry_points", None)
    if entry_points is None:
        from importlib.metadata import entry_points
    found = []
    for ep in entry_points(group="fitlab.families"):
        dist = getattr(ep, "dist", None)
        found.append(f"{ep.name}={ep.value}@{getattr(dist, 'name', '')}-{getattr(dist, 'version', '')}")
    if registry is not None:
        found += registry.registered_here()
    return sorted(found)


def cached_text(name: str, compute: Callable[[], str]) -> str:
    """The text ``compute()`` returns, from the cache when present (:func:`cached_files`), keyed by fitlab's own
    files (:func:`package_sources`) and the installed families (:func:`family_entry_points`): for a text only they
    determine, such as ``fitlab refit --list``, which otherwise imports every family (JAX and sympy, seconds) to
    say what the registry holds."""
    files = cached_files(name, {"families": family_entry_points()}, lambda: {"text": compute().encode()},
                         package_sources())  # fmt: skip
    return files["text"].decode()


#: the prefix of the arrays in which an entry of :func:`cached_at` holds its inputs
INPUT_PREFIX = "in_"


def cached_at(
    name: str,
    parts: Mapping,
    inputs: Mapping[str, np.ndarray],
    compute: Callable[[], Mapping[str, np.ndarray]],
    names: tuple[str, ...],
    sources: Iterable[Path] = (),
) -> dict[str, np.ndarray]:
    """:func:`cached_arrays` for values computed at points: ``inputs`` ({name: array}, as float64) join the key
    (``parts``) and the entry, each as the array ``in_NAME`` (:data:`INPUT_PREFIX`), so that an entry says what
    it holds the values of.  Returns the arrays ``names`` and the inputs."""
    inputs = {k: np.asarray(v, dtype=float) for k, v in inputs.items()}

    def arrays():
        return {**compute(), **{INPUT_PREFIX + k: v for k, v in inputs.items()}}

    return cached_arrays(name, {**parts, **inputs}, arrays, (*names, *(INPUT_PREFIX + k for k in inputs)), sources)


@contextmanager
def _computing(path: Path | None) -> Iterator[None]:
    """Hold the lock of the entry at ``path`` while it is computed, where this is the thread's outermost compute
    (see docs/reliability.md); None, nested computes, no flock and an unwritable folder hold nothing."""
    depth = getattr(_depth, "value", 0)
    fd = None
    if path is not None and depth == 0 and fcntl is not None:
        try:
            (path.parent / _LOCKS).mkdir(parents=True, exist_ok=True)
            fd = os.open(path.parent / _LOCKS / f"{path.name}.lock", os.O_RDWR | os.O_CREAT, 0o644)
        except OSError:
            fd = None
    _depth.value = depth + 1
    try:
        if fd is not None:
            _lock(fd, path)
        yield
    finally:
        _depth.value = depth
        if fd is not None:
            os.close(fd)


#: seconds a process waits for another's lock on an entry before it says so (one line on stderr)
WAIT_NOTICE_S = 2.0
#: seconds between two tries of a lock held by another process
_POLL_S = 0.05


def _lock(fd: int, path: Path) -> None:
    """Take the exclusive lock of ``fd`` (the lock file of the entry at ``path``) and write this process's id
    into it.  While another process holds it, try again every :data:`_POLL_S` seconds (a Ctrl-C stops the wait
    at once); after :data:`WAIT_NOTICE_S` seconds say once, on stderr, which process it waits for (the id its
    lock file holds), so that a wait on a stopped or hung process is never silent."""
    assert fcntl is not None
    start = time.monotonic()
    said = False
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # released when fd closes, or the process ends
            break
        except BlockingIOError:
            pass
        if not said and time.monotonic() - start >= WAIT_NOTICE_S:
            holder = _holder(fd)
            print(
                f"fitlab: waiting for process {holder if holder else '(unknown)'}, which is computing the cache "
                f"entry {path.name} (its lock: {path.parent / _LOCKS / (path.name + '.lock')})",
                file=sys.stderr,
            )
            said = True
        time.sleep(_POLL_S)
    with suppress(OSError):  # the holder's id, for a process that waits on this one; a lock without it still holds
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)


def _holder(fd: int) -> int | None:
    """The process id a lock file holds (written by :func:`_lock`), or None."""
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def enable_compilation_cache() -> None:
    """Keep what JAX compiles in CACHE/xla (JAX's persistent compilation cache, keyed by JAX on the program,
    its shapes, the backend and the JAX version), unless the cache is off or the user set JAX's own folder.
    Every program is kept, however fast it compiles: a command's small programs (tens of milliseconds each)
    add up to about 0.1 s a process, which a warm run then reads back instead (JAX never keeps a program with
    host callbacks).  The entries are stored by :class:`fitlab._program_cache.ProgramCache`, by the rules of
    the exact values' entries (a damaged entry is a miss, removed and written again; atomic writes; a folder
    that cannot be written only costs time, in one warning line).  A JAX without the store's hook
    (``jax._src.compilation_cache.get_file_cache``) keeps nothing.  Imports JAX."""
    if not enabled():
        return
    import jax

    if jax.config.jax_compilation_cache_dir:
        return  # the user's own setting wins
    try:
        from jax._src import compilation_cache

        from fitlab._program_cache import ProgramCache
    except ImportError:
        return
    jax_store = getattr(compilation_cache, "get_file_cache", None)
    if jax_store is None:
        return
    folder = str(cache_dir() / _XLA)
    if not getattr(jax_store, "_fitlab", False):

        def file_cache(path):
            if str(path) == folder:
                return ProgramCache(path, PROGRAM_SUFFIX, MAX_ENTRY_BYTES), path
            return jax_store(path)

        file_cache._fitlab = True  # type: ignore[attr-defined]
        compilation_cache.get_file_cache = file_cache
    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)


class CacheFolderError(Exception):
    """The cache folder is not a folder, or holds files fitlab did not write (one line)."""


#: the names fitlab writes in the cache folder: entries and their temporaries (:func:`cached_arrays`) ...
_ENTRY_NAME = re.compile(r".+-[0-9a-f]{24}\.npz(\.[0-9]+\.tmp)?")
#: ... in locks/, their locks (:func:`_computing`) ...
_LOCK_NAME = re.compile(r".+-[0-9a-f]{24}\.npz\.lock")
#: ... and in xla/, the compiled programs (:mod:`fitlab._program_cache`, and JAX's own store of earlier fitlabs)
_PROGRAM_NAME = re.compile(r"[^/]+-[0-9a-f]{64}(\.xla(\.[0-9]+\.tmp)?|-cache|-atime)|\.lockfile")


def _is_program(p: Path) -> bool:
    """Whether a file of xla/ is a program (not a temporary, nor JAX's access times or lock)."""
    return p.name.endswith((PROGRAM_SUFFIX, "-cache"))


def _cache_files() -> dict[str, list[Path]]:
    """{"entries", "locks", "programs"}: the files fitlab wrote in the cache folder (none when it does not
    exist); a :class:`CacheFolderError` when it is not a folder or holds anything else (a file or folder whose
    name fitlab does not write, a folder named like an entry), so that nothing of a user's is counted or
    removed."""
    folder = cache_dir()
    found: dict[str, list[Path]] = {"entries": [], "locks": [], "programs": []}
    if not os.path.lexists(folder):
        return found
    if not folder.is_dir():
        raise CacheFolderError(f"{folder} is not a folder")
    others: list[str] = []

    def scan(where: Path, pattern, kind: str, prefix: str = "") -> None:
        for p in sorted(where.iterdir()):
            if pattern.fullmatch(p.name) and not (p.is_dir() and not p.is_symlink()):
                found[kind].append(p)
            else:
                others.append(prefix + p.name)

    try:
        for p in sorted(folder.iterdir()):
            sub = {_LOCKS: (_LOCK_NAME, "locks"), _XLA: (_PROGRAM_NAME, "programs")}.get(p.name)
            if sub is not None and p.is_dir() and not p.is_symlink():
                scan(p, *sub, prefix=f"{p.name}/")
            elif sub is None and _ENTRY_NAME.fullmatch(p.name) and not (p.is_dir() and not p.is_symlink()):
                found["entries"].append(p)
            else:
                others.append(p.name)
    except OSError as exc:
        raise CacheFolderError(f"{folder}: cannot read ({exc.strerror or exc})") from None
    if others:
        shown = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
        raise CacheFolderError(
            f"{folder} holds {len(others)} name(s) fitlab does not write ({shown}): not a fitlab "
            "cache, left as it is (set FITLAB_CACHE_DIR to fitlab's own folder)"
        )
    return found


def cache_info() -> dict:
    """{"folder", "entries", "bytes", "by_name": {name: (entries, bytes)}} of the cache as it is now: the files
    fitlab wrote (:class:`CacheFolderError` for a folder holding anything else)."""
    folder = cache_dir()
    files = _cache_files()
    by_name: dict[str, list[int]] = {}

    def size(p: Path) -> int:
        try:
            return p.lstat().st_size
        except OSError:
            return 0

    for p in files["entries"]:
        if p.name.endswith(_SUFFIX):
            entry = by_name.setdefault(p.name[: -len(_SUFFIX)].rsplit("-", 1)[0], [0, 0])
            entry[0] += 1
            entry[1] += size(p)
    programs = [p for p in files["programs"] if _is_program(p)]
    if programs:
        by_name["xla (compiled JAX programs)"] = [len(programs), sum(size(p) for p in programs)]
    return {
        "folder": str(folder),
        "entries": sum(e[0] for e in by_name.values()),
        "bytes": sum(e[1] for e in by_name.values()),
        "by_name": {k: tuple(v) for k, v in by_name.items()},
    }


def clear_cache() -> int:
    """Remove every entry, compiled program, lock and stray temporary fitlab wrote; returns the number of entries
    and programs removed.  A folder holding anything else is refused whole, before anything is removed
    (:class:`CacheFolderError`)."""
    folder = cache_dir()
    files = _cache_files()
    removed = 0
    for p in [*files["entries"], *files["programs"], *files["locks"]]:
        try:
            p.unlink()  # a process waiting on a lock still holds its file: at worst it computes its entry twice
        except FileNotFoundError:
            continue
        removed += (p.parent == folder and p.name.endswith(_SUFFIX)) or (p.parent.name == _XLA and _is_program(p))
    for d in (folder / _XLA, folder / _LOCKS):
        with suppress(OSError):
            d.rmdir()
    return removed
