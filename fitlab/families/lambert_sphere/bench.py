"""Benchmarks (not tests): speed and accuracy of the exact engine.

Timings are wall-clock on this machine and are reported side by side in one
run, so only their ratios carry meaning.
"""

from __future__ import annotations

import tempfile

import numpy as np

from fitlab.families.lambert_sphere.exact import brdf_modes, doubling_reflection, solve_h
from fitlab.families.lambert_sphere.exact.characteristic import lambert_sphere_characteristic
from fitlab.families.lambert_sphere.exact.hfunction import _solve_cached, h_fock
from fitlab.families.lambert_sphere.tabulate import write_tables
from fitlab.timing import best_of


def bench_exact(quick: bool = False) -> dict:
    n = 2_000 if quick else 20_000
    rng = np.random.default_rng(0)
    mu = rng.uniform(0, 1, n)
    results = {}
    print(f"fitlab bench exact: {n} random mu per albedo, orders 0-2\n")
    print(f"{'method':<34}{'points/s':>14}{'max rel diff':>16}")
    for c in (0.5, 0.99, 1.0):
        for m in range(3):
            char = lambert_sphere_characteristic(m, c)
            _solve_cached.cache_clear()
            t_solve, sol = best_of(lambda: solve_h(char), 1)
            t_ny, a = best_of(lambda: sol(mu), 3)
            t_fo, b = best_of(lambda: h_fock(char, mu), 1)
            diff = float(np.max(np.abs(a / b - 1)))
            results[(m, c)] = dict(solve_s=t_solve, nystrom_pps=n / t_ny, fock_pps=n / t_fo, max_rel_diff=diff)
            print(f"H{m} c={c:<5} Nystrom (solve {t_solve * 1e3:5.1f} ms){n / t_ny:>12.3g}{diff:>16.2e}")
            print(f"H{m} c={c:<5} Fock{'':<22}{n / t_fo:>12.3g}")
    k = 50 if quick else 200
    mi, mo = rng.uniform(0, 1, (2, k * k))
    t_modes, _ = best_of(lambda: brdf_modes(mi, mo, 0.8), 3)
    print(f"\nbrdf_modes (c fixed, solved): {k * k / t_modes:.3g} points/s")
    t_dbl, d = best_of(lambda: doubling_reflection.__wrapped__(0, 0.8), 1)
    print(f"doubling (order 0, {d.nodes.size} ordinates, {d.doublings} doublings): {t_dbl:.2f} s "
          f"for {d.nodes.size ** 2} node pairs")
    if not quick:
        with tempfile.TemporaryDirectory() as tmp:
            t_tab, _ = best_of(lambda: write_tables(tmp, show_progress=False), 1)
        print(f"writing all tables: {t_tab:.1f} s")
        results["tabulate_s"] = t_tab
    return results
