"""``fitlab bench commands``: what a user waits for, command by command, measured in fresh processes.

Each measurement runs ``python -m fitlab ...`` in a subprocess, so it includes the interpreter's start
and every import, as a user sees it (``fitlab bench codegen`` adds the wall time of ``fitlab codegen`` itself,
cold and warm: :func:`codegen_walls`).  A refit is run twice against one fresh, empty cache folder: cold
(exact values computed, JAX programs compiled) and then warm (both read from the cache).  Nothing here is
a test: the figures depend on the machine and its load, and only ratios within one run carry meaning.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tqdm import tqdm

__all__ = ["bench_commands", "codegen_walls", "QUICK_TARGETS"]

#: the refits of ``--quick``: the README's first command and a constant (its validation set is the slowest)
QUICK_TARGETS = ("H0", "m")


def _timed(argv, env, cwd) -> tuple[float, int]:
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "fitlab", *argv], env=env, cwd=cwd, capture_output=True)
    return time.perf_counter() - t0, done.returncode


def bench_commands(targets, show_progress: bool = True) -> dict:
    """{"help": seconds, "refit": {target: {"cold": s, "warm": s, "status": (rc_cold, rc_warm)}}} for
    ``fitlab --help`` and a single-target refit of each of ``targets``, cold then warm."""
    out = {"refit": {}}
    with tempfile.TemporaryDirectory(prefix="fitlab-bench-") as tmp:
        env = {**os.environ, "FITLAB_CACHE_DIR": str(Path(tmp) / "cache")}
        out["help"], _ = _timed(["--help"], env, tmp)
        for target in tqdm(targets, desc="bench commands", unit="target", disable=not show_progress):
            argv = ["refit", "--target", target, "--out", str(Path(tmp) / "fits"), "--quiet"]
            cold, rc_cold = _timed(argv, env, tmp)
            warm, rc_warm = _timed(argv, env, tmp)
            out["refit"][target] = {"cold": cold, "warm": warm, "status": [rc_cold, rc_warm]}
    return out


def codegen_walls(family: str | None = None, fits: Path | None = None) -> dict:
    """{"cold": s, "warm": s, "status": (rc_cold, rc_warm)}: ``fitlab codegen --lang c`` (of ``family``, from
    ``fits``) in a fresh process against a fresh, empty cache (a first run: every fit and the model measured, the
    program built and printed; the exact values fitlab ships read), then again (a second run: the files read back)."""
    with tempfile.TemporaryDirectory(prefix="fitlab-bench-") as tmp:
        env = {**os.environ, "FITLAB_CACHE_DIR": str(Path(tmp) / "cache")}
        argv = ["codegen", "--lang", "c", "--out", str(Path(tmp) / "generated"), "--quiet",
                *(["--family", family] if family else []), *(["--fits", str(fits)] if fits else [])]  # fmt: skip
        cold, rc_cold = _timed(argv, env, tmp)
        warm, rc_warm = _timed(argv, env, tmp)
    return {"cold": cold, "warm": warm, "status": [rc_cold, rc_warm]}


def table(results) -> str:
    lines = [f"fitlab --help: {results['help']:.2f} s", f"{'refit --target':<16} {'cold s':>8} {'warm s':>8}  status"]
    for target, r in results["refit"].items():
        lines.append(f"{target:<16} {r['cold']:>8.1f} {r['warm']:>8.1f}  {r['status']}")
    return "\n".join(lines)
