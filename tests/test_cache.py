"""The persistent cache of exact values: hits, misses, damage, concurrency, the CLI."""

from __future__ import annotations

import json
import multiprocessing
import sys

import numpy as np
import pytest

from fitlab.cache import INPUT_PREFIX, cache_dir, cache_info, cache_key, cached_arrays, cached_at, clear_cache
from fitlab.cli import main


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("FITLAB_CACHE_DIR", str(folder))
    monkeypatch.delenv("FITLAB_NO_CACHE", raising=False)
    return folder


def _values(calls):
    def compute():
        calls.append(1)
        return {"x": np.linspace(0, 1, 5), "y": np.arange(5.0) ** 2}

    return compute


def test_second_call_is_a_hit_and_returns_the_same_arrays(cache):
    calls = []
    a = cached_arrays("demo", {"grid": "k/4"}, _values(calls), ("x", "y"))
    b = cached_arrays("demo", {"grid": "k/4"}, _values(calls), ("x", "y"))
    assert len(calls) == 1 and all(np.array_equal(a[k], b[k]) for k in "xy")
    assert cache_dir() == cache and cache_info()["entries"] == 1


def test_values_at_points_are_keyed_by_the_points_and_hold_them(cache):
    calls = []

    def at(x):
        return cached_at("demo-at", {"what": "square"}, {"x": x}, lambda: calls.append(1) or {"y": x**2}, ("y",))

    x = np.array([0.5, 2.0])
    first, again, other = at(x), at(x.copy()), at(np.array([0.5, 3.0]))
    assert len(calls) == 2 and np.array_equal(again["y"], first["y"]) and np.array_equal(other["y"], [0.25, 9.0])
    (entry,) = [p for p in cache.glob("demo-at-*.npz") if np.array_equal(np.load(p)[INPUT_PREFIX + "x"], x)]
    assert np.array_equal(np.load(entry)["y"], [0.25, 4.0])


def test_key_covers_parts_arrays_and_sources(tmp_path):
    src = tmp_path / "engine.py"
    src.write_text("x = 1\n")
    base = cache_key({"grid": "a", "s": np.array([0.0, 0.5])}, [src])
    assert cache_key({"grid": "b", "s": np.array([0.0, 0.5])}, [src]) != base
    assert cache_key({"grid": "a", "s": np.array([0.0, 0.25])}, [src]) != base
    src.write_text("x = 2\n")
    assert cache_key({"grid": "a", "s": np.array([0.0, 0.5])}, [src]) != base


@pytest.mark.parametrize("damage", [b"", b"not a zip file", "truncate", "wrong names"])
def test_a_damaged_entry_is_a_miss_and_is_rewritten(cache, damage):
    calls = []
    cached_arrays("demo", {}, _values(calls), ("x", "y"))
    (entry,) = cache.glob("*.npz")
    if damage == "truncate":
        entry.write_bytes(entry.read_bytes()[:40])
    elif damage == "wrong names":
        np.savez(entry.with_suffix(""), z=np.zeros(3))  # np.savez appends .npz
    else:
        entry.write_bytes(damage)
    again = cached_arrays("demo", {}, _values(calls), ("x", "y"))
    assert len(calls) == 2 and np.array_equal(again["y"], np.arange(5.0) ** 2)
    assert cached_arrays("demo", {}, _values(calls), ("x", "y")) and len(calls) == 2  # rewritten whole


def test_an_entry_is_never_unpickled(cache):
    calls = []
    cached_arrays("demo", {}, _values(calls), ("x", "y"))
    (entry,) = cache.glob("*.npz")
    np.savez(entry.with_suffix(""), x=np.array([object()], dtype=object), y=np.zeros(1))
    out = cached_arrays("demo", {}, _values(calls), ("x", "y"))  # object arrays need pickle: a miss
    assert len(calls) == 2 and out["x"].dtype == float


def _fill(folder: str, seed: int) -> float:
    import os

    os.environ["FITLAB_CACHE_DIR"] = folder
    out = cached_arrays("race", {"n": 200_000}, lambda: {"v": np.arange(200_000, dtype=float)}, ("v",))
    return float(out["v"].sum())


def test_concurrent_writers_leave_one_whole_entry(cache):
    cache.mkdir()
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        sums = pool.starmap(_fill, [(str(cache), k) for k in range(4)])
    assert set(sums) == {float(np.arange(200_000).sum())}
    assert len(list(cache.glob("*.npz"))) == 1 and not list(cache.glob("*.tmp"))
    with np.load(next(cache.glob("*.npz")), allow_pickle=False) as z:
        assert np.array_equal(z["v"], np.arange(200_000, dtype=float))


def _fill_slowly(folder: str, log: str, ready: str, sums: str) -> None:
    import os
    import time
    from pathlib import Path

    os.environ["FITLAB_CACHE_DIR"] = folder
    Path(ready, str(os.getpid())).touch()
    while len(os.listdir(ready)) < 2:  # both processes ask for the entry together, neither having found it
        time.sleep(0.01)

    def compute():
        with open(log, "a") as fh:
            fh.write(f"{os.getpid()}\n")
        time.sleep(1.0)  # the other process misses the entry meanwhile
        return {"v": np.arange(10.0)}

    total = float(cached_arrays("shared", {}, compute, ("v",))["v"].sum())
    Path(sums, str(os.getpid())).write_text(repr(total))


@pytest.mark.skipif(sys.platform == "win32", reason="no flock on Windows: each process computes its own")
def test_processes_missing_one_entry_at_once_compute_it_once(cache, tmp_path):
    """Two processes miss one entry at the same moment: the second waits on the first's lock, then reads its
    entry (without the lock both compute it); the lock files are cleared with the cache."""
    cache.mkdir()
    log, ready, sums = tmp_path / "computes.log", tmp_path / "ready", tmp_path / "sums"
    ready.mkdir()
    sums.mkdir()
    spawn = multiprocessing.get_context("spawn")
    procs = [spawn.Process(target=_fill_slowly, args=(str(cache), str(log), str(ready), str(sums))) for _ in range(2)]
    for proc in procs:
        proc.start()
    for proc in procs:
        proc.join(timeout=120)
    assert [proc.exitcode for proc in procs] == [0, 0]
    assert sorted(float(f.read_text()) for f in sums.iterdir()) == [45.0, 45.0]
    assert len(log.read_text().split()) == 1
    assert len(list((cache / "locks").glob("*.lock"))) == 1
    assert clear_cache() == 1 and not (cache / "locks").exists()


def test_an_entry_computed_inside_another_takes_no_lock_of_its_own(cache):
    """Only the outermost compute holds a lock: the inner entry is computed (and kept) while the outer one's lock
    is held, and a process never waits on a lock while holding one."""
    calls = []

    def outer():
        inner = cached_arrays("inner", {}, _values(calls), ("x", "y"))
        return {"z": inner["y"] + 1}

    out = cached_arrays("outer", {}, outer, ("z",))
    assert np.array_equal(out["z"], np.arange(5.0) ** 2 + 1) and len(calls) == 1
    assert [p.name.split("-")[0] for p in (cache / "locks").glob("*.lock")] == ["outer"]
    assert cached_arrays("inner", {}, _values(calls), ("x", "y"))["x"].size == 5 and len(calls) == 1


def test_no_cache_switch_and_unwritable_folder_only_cost_time(cache, monkeypatch, tmp_path):
    calls = []
    monkeypatch.setenv("FITLAB_NO_CACHE", "1")
    cached_arrays("demo", {}, _values(calls), ("x", "y"))
    assert not cache.exists()
    monkeypatch.delenv("FITLAB_NO_CACHE")
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("FITLAB_CACHE_DIR", str(blocker / "sub"))
    assert np.array_equal(cached_arrays("demo", {}, _values(calls), ("x", "y"))["x"], np.linspace(0, 1, 5))


def test_cli_info_and_clear(cache, capsys):
    cached_arrays("demo", {}, _values([]), ("x", "y"))
    assert main(["cache", "info", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["entries"] == 1 and info["folder"] == str(cache)
    assert main(["cache", "clear"]) == 0
    assert "removed 1" in capsys.readouterr().out and cache_info()["entries"] == 0
    assert clear_cache() == 0


# -- an entry is checked against its key's content hash --------------------------------------------
@pytest.mark.parametrize("wrong", ["values changed", "values changed, its hash kept", "another key's entry"])
def test_a_wrong_entry_is_a_miss_recomputed_and_overwritten(cache, wrong):
    calls = []
    right = cached_arrays("demo", {"grid": "k/4"}, _values(calls), ("x", "y"))
    (entry,) = cache.glob("*.npz")
    if wrong == "values changed":  # a whole, well-formed entry with the right names and wrong numbers
        np.savez(entry.with_suffix(""), x=np.linspace(0, 1, 5), y=2 * np.arange(5.0) ** 2)
    elif wrong == "values changed, its hash kept":
        with np.load(entry) as z:
            stated = {k: np.array(z[k]) for k in z.files if k not in ("x", "y")}
        np.savez(entry.with_suffix(""), x=np.linspace(0, 1, 5), y=2 * np.arange(5.0) ** 2, **stated)
    else:  # an entry of another key, under this key's name
        cached_arrays("demo", {"grid": "k/8"}, lambda: {"x": np.linspace(0, 1, 9), "y": np.arange(9.0)}, ("x", "y"))
        (other,) = set(cache.glob("*.npz")) - {entry}
        entry.write_bytes(other.read_bytes())
    # before: a hit, returning y = [0, 2, 8, 18, 32] (or the other key's nine values)
    again = cached_arrays("demo", {"grid": "k/4"}, _values(calls), ("x", "y"))
    assert len(calls) == 2 and again["y"].tolist() == [0.0, 1.0, 4.0, 9.0, 16.0]
    assert np.array_equal(again["x"], right["x"]) and np.array_equal(again["y"], right["y"])
    third = cached_arrays("demo", {"grid": "k/4"}, _values(calls), ("x", "y"))  # the entry was overwritten
    assert len(calls) == 2 and third["y"].tolist() == [0.0, 1.0, 4.0, 9.0, 16.0]


def test_a_fifo_entry_is_a_miss_without_blocking(cache):
    import os

    from test_input_files import finishes

    calls = []
    cached_arrays("demo", {}, _values(calls), ("x", "y"))
    (entry,) = cache.glob("*.npz")
    entry.unlink()
    os.mkfifo(entry)
    out = finishes(lambda: cached_arrays("demo", {}, _values(calls), ("x", "y")), [entry])
    assert len(calls) == 2 and out["y"].tolist() == [0.0, 1.0, 4.0, 9.0, 16.0]
    assert entry.is_file()  # replaced by a whole entry


# -- JAX's compiled programs (CACHE/xla) keep the cache's rules -------------------------------------------
def _program_cache(folder):
    from fitlab._program_cache import ProgramCache
    from fitlab.cache import MAX_ENTRY_BYTES, PROGRAM_SUFFIX

    return ProgramCache(folder, PROGRAM_SUFFIX, MAX_ENTRY_BYTES)


KEY = "jit_f-" + "ab" * 32


@pytest.mark.parametrize(
    "damage",
    ["zero bytes (a full disk)", "a byte flipped", "cut short", "another key's", "the bare program (JAX's own format)"],
)
def test_a_damaged_program_is_a_miss_removed_and_written_again(tmp_path, damage, capsys):
    store = _program_cache(tmp_path)
    program = bytes(range(256)) * 8
    store.put(KEY, program)
    (entry,) = tmp_path.iterdir()
    assert store.get(KEY) == program
    data = bytearray(entry.read_bytes())
    if damage.startswith("zero"):
        data = bytearray()
    elif damage == "a byte flipped":
        data[len(data) // 2] ^= 0x01
    elif damage == "cut short":
        data = data[: len(data) // 2]
    elif damage == "another key's":
        other = _program_cache(tmp_path / "other")
        other.put("jit_g-" + "cd" * 32, program)
        data = bytearray(next((tmp_path / "other").iterdir()).read_bytes())
    else:
        data = bytearray(program)
    entry.write_bytes(bytes(data))
    assert store.get(KEY) is None and not entry.exists()  # a miss, and the entry is gone
    store.put(KEY, program)  # JAX compiles it again and writes it
    assert store.get(KEY) == program and capsys.readouterr().err == ""


def test_a_fifo_program_is_a_miss_without_blocking(tmp_path):
    import os

    from test_input_files import finishes

    store = _program_cache(tmp_path)
    os.mkfifo(tmp_path / f"{KEY}.xla")
    assert finishes(lambda: store.get(KEY), [tmp_path / f"{KEY}.xla"]) is None
    store.put(KEY, b"program")
    assert store.get(KEY) == b"program"


@pytest.mark.parametrize("why", ["a full disk", "a read-only folder", "a file in the folder's place"])
def test_an_unusable_program_folder_costs_time_in_one_line(tmp_path, monkeypatch, capsys, why):
    import errno
    import os

    import fitlab._program_cache as program_cache

    monkeypatch.setattr(program_cache, "_reported", False)
    folder = tmp_path / "xla"
    if why == "a file in the folder's place":
        folder.write_text("")
    else:
        store = _program_cache(folder)
        store.put(KEY, b"old program")
        code = errno.ENOSPC if why == "a full disk" else errno.EROFS
        real_open = open

        def failing_open(path, mode="r", *args, **kwargs):
            if "w" in mode:
                fh = real_open(path, mode, *args, **kwargs)  # the temporary exists, then the write fails
                fh.close()
                raise OSError(code, os.strerror(code))
            return real_open(path, mode, *args, **kwargs)

        monkeypatch.setattr("builtins.open", failing_open)
    store = _program_cache(folder)
    for i in range(5):
        store.put(f"jit_f{i}-" + "ab" * 32, b"new program")
        assert store.get(f"jit_f{i}-" + "ab" * 32) is None
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("fitlab: warning: JAX's compiled programs cannot be kept in")
    if folder.is_dir():  # no temporary left, the old entry intact
        assert sorted(p.name for p in folder.iterdir()) == [f"{KEY}.xla"] and store.get(KEY) == b"old program"


_COMPILE = """
import sys
from fitlab.cache import enable_compilation_cache
enable_compilation_cache()
import jax, jax.numpy as jnp
print(float(jax.jit(lambda x: jnp.sin(x) * 3.0 + x)(jnp.float32(0.5))))
"""


@pytest.mark.e2e
def test_jax_reads_and_heals_the_program_cache_without_a_warning(tmp_path):
    """A JAX process on a cache whose programs were zeroed (what a full disk left) prints nothing and writes
    them again; before, every later run printed two UserWarning lines per program and never healed."""
    import os
    import subprocess

    env = dict(os.environ, FITLAB_CACHE_DIR=str(tmp_path / "cache"), JAX_PLATFORMS="cpu")
    env.pop("FITLAB_NO_CACHE", None)

    def run():
        return subprocess.run([sys.executable, "-c", _COMPILE], env=env, capture_output=True, text=True, timeout=120)

    first = run()
    programs = sorted((tmp_path / "cache" / "xla").glob("*.xla"))
    assert first.returncode == 0 and first.stderr == "" and programs
    written = {p: p.read_bytes() for p in programs}
    for p in programs:
        p.write_bytes(b"")
    second = run()
    assert second.returncode == 0 and second.stderr == "" and second.stdout == first.stdout
    assert {p: p.read_bytes() for p in programs} == written  # removed and written again, whole
    (tmp_path / "blocker").write_text("")
    env["FITLAB_CACHE_DIR"] = str(tmp_path / "blocker")
    third = run()
    assert third.returncode == 0 and third.stdout == first.stdout
    assert len(third.stderr.splitlines()) == 1 and "cannot be kept" in third.stderr


# -- fitlab cache info / clear touch only what fitlab wrote -------------------------------------------------
def test_clear_and_info_refuse_a_folder_holding_a_users_files(cache, capsys):
    cached_arrays("demo", {}, _values([]), ("x", "y"))
    (cache / "measurements.npz").write_bytes(b"the user's own")
    (cache / "xla" / "src").mkdir(parents=True)
    (cache / "xla" / "src" / "main.c").write_text("int main(void) { return 0; }\n")
    before = sorted(p.relative_to(cache) for p in cache.rglob("*"))
    for action in ("clear", "info"):
        assert main(["cache", action]) == 2
        out = capsys.readouterr()
        assert out.out == "" and len(out.err.splitlines()) == 1
        assert "measurements.npz" in out.err and "xla/src" in out.err and "fitlab does not write" in out.err
    assert sorted(p.relative_to(cache) for p in cache.rglob("*")) == before  # nothing removed


def test_clear_removes_entries_programs_locks_and_temporaries_only(cache, capsys):
    cached_arrays("demo", {}, _values([]), ("x", "y"))
    (entry,) = cache.glob("*.npz")
    (cache / f"{entry.name}.123.tmp").write_bytes(b"part")
    xla = cache / "xla"
    xla.mkdir()
    store = _program_cache(xla)
    store.put(KEY, b"program")
    (xla / f"jit_g-{'cd' * 32}-cache").write_bytes(b"JAX's own store")  # an earlier fitlab's
    (xla / f"jit_g-{'cd' * 32}-atime").write_bytes(b"12345678")
    info = cache_info()
    assert info["entries"] == 3 and info["by_name"]["xla (compiled JAX programs)"][0] == 2
    assert main(["cache", "clear"]) == 0 and "removed 3 entries" in capsys.readouterr().out
    assert not cache.exists() or list(cache.iterdir()) == []


def test_a_cache_path_that_is_a_file_is_refused(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("mine")
    monkeypatch.setenv("FITLAB_CACHE_DIR", str(blocker))
    assert main(["cache", "clear"]) == 2 and "is not a folder" in capsys.readouterr().err
    assert blocker.read_text() == "mine"
