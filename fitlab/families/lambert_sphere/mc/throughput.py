"""``fitlab bench mc``: photons and collisions per second of the random walk,
and what each effect costs (alone, and all together at the same precision).

Timings are wall-clock on this machine, compilation excluded (reported
apart), best of ``repeat``; only ratios measured in one run carry meaning.
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import jax

from fitlab.families.lambert_sphere.mc.scene import parse_scene
from fitlab.families.lambert_sphere.mc.simulate import simulate
from fitlab.families.lambert_sphere.mc.transport import WalkConfig, compile_walk, default_mesh, default_slots, run_round
from fitlab.timing import best_of

__all__ = ["bench_mc", "throughput", "native_throughput", "effect_costs", "BENCH_SCENE"]

#: The scene of the cost-per-effect study (one material, one incident direction).
BENCH_SCENE = """
[scene]
name = "bench"
seed = 2024
[[material]]
c = 0.9
[incident]
mu_i = [0.5]
[outgoing]
mu_o = 4
fourier = [0, 1, 2]
[effects]
list = ["single", "multiple", "collisions", "phase_difference", "albedo", "spherical_albedo"]
collision_orders = 6
[precision]
target_se = {multiple = 1e-3, collisions = 1e-3, phase_difference = 5e-5, albedo = 3e-4, spherical_albedo = 3e-4}
max_paths = 4000000
batch = 50000
"""


def throughput(cfg: WalkConfig, c: float, mu_i: float, n: int, repeat: int = 3) -> dict:
    """Best-of-``repeat`` photons/s and collisions/s of one round of n photons."""
    mesh = default_mesh()
    compile_s = compile_walk(cfg, mesh)
    rounds = itertools.count()  # each timing walks its own photons (key r = 0, 1, ...)
    dt, res = best_of(lambda: run_round(cfg, 1, (next(rounds),), c, mu_i, n, mesh=mesh), repeat)
    return dict(
        seconds=dt,
        compile_seconds=compile_s,
        photons_per_s=n / dt,
        collisions_per_s=float(res["collisions"]) / dt,
        collisions_per_photon=float(res["collisions"]) / n,
        steps=int(res["steps"]),
    )


def native_throughput(c: float, mu_i: float, n: int, repeat: int = 3) -> dict:
    """Best-of-``repeat`` photons/s and collisions/s of the C reference walk (:mod:`.native`: the walk of
    ``phase="true", sampler="exact"``, the same random numbers, one thread, no tallies) on n photons."""
    import numpy as np

    from fitlab.families.lambert_sphere.mc.native import native_walk
    from fitlab.families.lambert_sphere.mc.transport import round_key

    key = tuple(int(k) for k in np.asarray(round_key(1, 0)))
    best = min((native_walk(key, c, mu_i, n) for _ in range(repeat)), key=lambda r: r["seconds"])
    return dict(
        seconds=best["seconds"],
        photons_per_s=n / best["seconds"],
        collisions_per_s=best["collisions"] / best["seconds"],
        collisions_per_photon=best["collisions"] / n,
    )


def effect_costs(quick: bool = False) -> list:
    """Seconds and paths of each effect alone and of all of them, at the same targets."""
    scene = parse_scene(BENCH_SCENE, "<bench scene>")
    if quick:
        scene = replace(scene, target_se={k: 2.0 * v for k, v in scene.target_se.items()})
    out = []
    variants = [(e,) for e in scene.effects] + [scene.effects]
    for effects in variants:
        sub = replace(scene, effects=effects, target_se={e: scene.target_se[e] for e in effects if e != "single"})
        res = simulate(sub, progress=False)
        sim_s = sum(st.seconds for st in res.jobs.values())
        out.append(
            dict(
                effects="all" if len(effects) > 1 else effects[0],
                jobs=len(res.jobs),
                paths=sum(st.paths for st in res.jobs.values()),
                collisions=sum(st.collisions for st in res.jobs.values()),
                seconds=sim_s,
                wall=res.wall_seconds,
                converged=all(s["converged"] for s in res.summary),
            )
        )
    return out


def bench_mc(quick: bool = False) -> dict:
    n = 50_000 if quick else 400_000
    dev = jax.devices()
    print(
        f"fitlab bench mc: {len(dev)} device(s) ({dev[0].platform}), {n} photons per timing, "
        f"mu_i = 0.5, 4 mu_o bins x orders 0-2 tallied; best of 3, compilation apart\n"
    )
    print(
        f"{'phase / sampler':<24}{'c':>6}{'slots':>7}{'photons/s':>12}{'collisions/s':>14}{'coll/photon':>13}"
        f"{'compile s':>11}"
    )
    results = {}
    auto = default_slots(dev[0].platform)
    edges = (0.0, 0.25, 0.5, 0.75, 1.0)
    cases = [("true", "exact"), ("true", "approx"), ("three_term", "exact"), ("both", "exact")]
    for c in (0.5, 0.99):
        for phase, sampler in cases:
            cfg = WalkConfig(phase=phase, sampler=sampler, mu_edges=edges, orders=(0, 1, 2))
            r = throughput(cfg, c, 0.5, n)
            results[(phase, sampler, c, auto)] = r
            print(
                f"{phase + ' / ' + sampler:<24}{c:>6}{auto:>7}{r['photons_per_s']:>12.3g}"
                f"{r['collisions_per_s']:>14.3g}{r['collisions_per_photon']:>13.1f}{r['compile_seconds']:>11.1f}"
            )
    for slots in (128, 2048, 8192):
        cfg = WalkConfig(phase="three_term", mu_edges=edges, orders=(0, 1, 2), slots=slots)
        r = throughput(cfg, 0.99, 0.5, n)
        results[("three_term", "exact", 0.99, slots)] = r
        print(
            f"{'three_term / exact':<24}{0.99:>6}{slots:>7}{r['photons_per_s']:>12.3g}"
            f"{r['collisions_per_s']:>14.3g}{r['collisions_per_photon']:>13.1f}{r['compile_seconds']:>11.1f}"
        )
    print(
        f"\nnative reference: the same walk (true / exact) in plain C, one thread, no tallies (the JAX walk runs on "
        f"{len(dev)} device(s); the ratio is collisions/s of the JAX walk over the C walk's)\n"
    )
    for c in (0.5, 0.99):
        r = native_throughput(c, 0.5, n)
        ratio = results[("true", "exact", c, auto)]["collisions_per_s"] / r["collisions_per_s"]
        r["jax_over_native"] = ratio
        results[("native", "exact", c)] = r
        print(
            f"{'native C / exact':<24}{c:>6}{'-':>7}{r['photons_per_s']:>12.3g}{r['collisions_per_s']:>14.3g}"
            f"{r['collisions_per_photon']:>13.1f}   JAX / native {ratio:.3g}"
        )
    print(
        "\ncost per effect at the same precision (bench scene: c = 0.9, mu_i = 0.5, 4 mu_o bins, orders 0-2;"
        " targets in fitlab/families/lambert_sphere/mc/throughput.py; simulation seconds, compilation excluded)\n"
    )
    print(f"{'effects':<20}{'jobs':>5}{'paths':>11}{'collisions':>13}{'seconds':>9}{'converged':>11}")
    costs = effect_costs(quick)
    for r in costs:
        print(
            f"{r['effects']:<20}{r['jobs']:>5}{r['paths']:>11}{r['collisions']:>13}{r['seconds']:>9.2f}"
            f"{'yes' if r['converged'] else 'NO':>11}"
        )
    results["effects"] = costs
    return results
