"""Throughput of the microsurface walk: scattering events (bounces) and paths per second on this machine."""

from __future__ import annotations

import time

from fitlab.families.microfacet_energy.microsurface.walk import (
    MaterialParams,
    WalkConfig,
    compile_walk,
    job_key,
    run_round,
)

__all__ = ["bench_walk"]


def bench_walk(n_paths: int = 400_000, alpha: float = 0.6, mu_i: float = 0.5, distribution: str = "ggx",
               kind: str = "conductor", slots: int = 1024, repeats: int = 3) -> dict:
    """Run ``n_paths`` paths ``repeats`` times after compiling; the best round's rates.

    Returns dict(compile_seconds, seconds, paths, bounces, bounces_per_second, paths_per_second)."""
    cfg = WalkConfig(distribution=distribution, kind=kind, slots=slots)
    compile_s = compile_walk(cfg)
    key = job_key(0, 0, 0)
    params = MaterialParams(alpha, alpha)
    best = None
    for r in range(repeats):
        t0 = time.perf_counter()
        res = run_round(cfg, key, params, mu_i, r * n_paths, n_paths)
        dt = time.perf_counter() - t0
        if best is None or dt < best[0]:
            best = (dt, int(res["paths"]), int(res["bounces"]))
    dt, paths, bounces = best
    return dict(compile_seconds=compile_s, seconds=dt, paths=paths, bounces=bounces,
                bounces_per_second=bounces / dt, paths_per_second=paths / dt)
