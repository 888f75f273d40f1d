r"""Throughput of the microsurface walk (``fitlab bench mc --family microfacet_energy``): scattering events
(bounces) and paths per second on this machine, for GGX and Beckmann microsurfaces of conductor (F = 1),
diffuse (albedo 1) and dielectric (eta = 1.5) facets; the time the blog's job would take here; and the
walk sharded over several host devices against one; and a plain C reference of the GGX conductor walk
(:mod:`.native`: one thread, the same paths) with the ratio of the JAX walk's bounces per second to it.

The blog's job (seeds, "A blog article on multiple-scattering BRDFs"): "500 million rays" on "a tiny patch
of rough micro-surface", "accounting for 4 orders of scattering", "about 1/2 a second per simulation" with
compute shaders on a GPU (:data:`BLOG_RAYS`, :data:`BLOG_ORDERS`, :data:`BLOG_SECONDS`).  The walk's
equivalent is a path stopped after 4 scattering events (``max_bounces = 4``, the rest tallied as capped);
the time here for 5e8 of them is 5e8 / (paths per second of that walk).  The blog traces rays through an
explicit height field, the walk samples the Smith statistics instead: the jobs are alike in what they
tally (the lobe by order), not in the work per ray.

Timings are wall-clock, compilation apart (reported), the shortest of ``repeat`` interleaved rounds
(:func:`fitlab.timing.interleaved_best`); only ratios measured in one run carry meaning.  The sharding
check runs in a fresh process with ``XLA_FLAGS=--xla_force_host_platform_device_count=N`` (N = the CPU
cores) and times one round on a mesh of one of those host devices against the mesh of all N, same ids.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

__all__ = ["bench_mc", "bench_sharding", "bench_native", "CASES", "BLOG_RAYS", "BLOG_ORDERS", "BLOG_SECONDS"]

#: the blog's simulation: 5e8 rays, 4 orders of scattering, about 0.5 s on a GPU (source: module docstring)
BLOG_RAYS, BLOG_ORDERS, BLOG_SECONDS = 500_000_000, 4, 0.5
#: (distribution, kind) of the benchmark; alpha 0.6, mu_i 0.5, F = 1, albedo 1, eta 1.5
CASES = tuple((d, k) for d in ("ggx", "beckmann") for k in ("conductor", "diffuse", "dielectric"))


def _config(distribution, kind, slots):
    from fitlab.families.microfacet_energy.mc.walk import WalkConfig

    return WalkConfig(distribution=distribution, kind=kind, slots=slots)


def _sharding_child(n: int, repeat: int) -> dict:
    """What :func:`bench_sharding`'s fresh process runs (``python -m fitlab.families.microfacet_energy.mc.bench N
    REPEAT``, with the host devices forced): the GGX dielectric walk on one device against all."""
    import jax
    import numpy as np
    from jax.sharding import Mesh

    from fitlab.families.microfacet_energy.mc.walk import MaterialParams, compile_walk, default_mesh, job_key, run_round
    from fitlab.timing import interleaved_best

    cfg = _config("ggx", "dielectric", 1024)
    meshes = {"one device": Mesh(np.array(jax.devices()[:1]), ("paths",)), "all devices": default_mesh()}
    params = MaterialParams(0.6, 0.6, eta=1.5)
    for m in meshes.values():
        compile_walk(cfg, m)
    out = {k: run_round(cfg, job_key(0, 0, 0), params, 0.5, 0, n, mesh=m) for k, m in meshes.items()}
    same = all(np.array_equal(out["one device"][k], out["all devices"][k]) for k in out["one device"])
    best = interleaved_best({k: (lambda m=m: run_round(cfg, job_key(0, 0, 0), params, 0.5, 0, n, mesh=m))
                             for k, m in meshes.items()}, repeat)  # fmt: skip
    return {"devices": jax.device_count(), "paths": n, "bounces": int(out["one device"]["bounces"]),
            "seconds": best, "identical_tallies": bool(same)}  # fmt: skip


def bench_sharding(devices: int | None = None, n_paths: int = 200_000, repeat: int = 3) -> dict:
    """The GGX dielectric walk on one of ``devices`` forced host devices against all of them (module
    docstring), in a fresh process: dict(devices, paths, bounces, seconds={mesh: s}, identical_tallies)."""
    devices = devices or os.cpu_count() or 1
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}", JAX_PLATFORMS="cpu")
    out = subprocess.run(
        [sys.executable, "-m", __name__, str(n_paths), str(repeat)],
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    if out.returncode != 0:
        raise RuntimeError(f"sharding benchmark failed: {out.stderr.strip().splitlines()[-1:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_native(n_paths: int = 400_000, repeat: int = 3, alpha: float = 0.6, mu_i: float = 0.5) -> dict:
    """The C reference of the GGX conductor walk (:mod:`.native`) on the bench's paths (job key (0, 0, 0)):
    dict(seconds, bounces, bounces_per_second, paths_per_second), the best of ``repeat``."""
    from fitlab.families.microfacet_energy.mc.native import native_walk
    from fitlab.families.microfacet_energy.mc.walk import job_key

    key = tuple(int(k) for k in job_key(0, 0, 0))
    best = min((native_walk(key, alpha, mu_i, n_paths) for _ in range(repeat)), key=lambda r: r["seconds"])
    return dict(
        seconds=best["seconds"],
        bounces=best["bounces"],
        bounces_per_second=best["bounces"] / best["seconds"],
        paths_per_second=n_paths / best["seconds"],
    )


def bench_mc(quick: bool = False) -> dict:
    """The family's ``fitlab bench mc``: prints the tables, returns every figure."""
    import jax

    from fitlab.families.microfacet_energy.mc.walk import (
        MaterialParams,
        compile_walk,
        default_mesh,
        job_key,
        run_round,
    )
    from fitlab.timing import interleaved_best

    n = 50_000 if quick else 400_000
    repeat = 2 if quick else 3
    dev = jax.devices()
    mesh = default_mesh()
    print(
        f"fitlab bench mc (microsurface walk): {len(dev)} device(s) ({dev[0].platform}), {n} paths per timing, "
        f"alpha 0.6, mu_i 0.5, 1024 lanes per device, best of {repeat} interleaved rounds, compilation apart\n"
    )
    key = job_key(0, 0, 0)
    results, runs = {}, {}
    for dist, kind in CASES:
        cfg = _config(dist, kind, 1024)
        params = MaterialParams(0.6, 0.6, eta=1.5)
        comp = compile_walk(cfg, mesh)
        for cap in (1000, BLOG_ORDERS):
            runs[(dist, kind, cap)] = lambda cfg=cfg, params=params, cap=cap: run_round(
                cfg, key, params, 0.5, 0, n, cap, mesh=mesh
            )
        results[(dist, kind)] = dict(compile_seconds=comp)
    counts = {k: f() for k, f in runs.items()}  # the work of each timing (deterministic: same ids every round)
    best = interleaved_best(runs, repeat)
    print(
        f"{'walk':<22}{'bounces/s':>11}{'paths/s':>11}{'bounce/path':>12}{'paths/s (4)':>13}"
        f"{'5e8 x 4 (s)':>13}{'x blog':>8}{'compile s':>11}"
    )
    for dist, kind in CASES:
        full, four = (dist, kind, 1000), (dist, kind, BLOG_ORDERS)
        r = results[(dist, kind)]
        r.update(
            bounces_per_second=int(counts[full]["bounces"]) / best[full],
            paths_per_second=n / best[full],
            bounces_per_path=int(counts[full]["bounces"]) / n,
            paths_per_second_4_orders=n / best[four],
            bounces_per_second_4_orders=int(counts[four]["bounces"]) / best[four],
        )
        r["blog_job_seconds"] = BLOG_RAYS / r["paths_per_second_4_orders"]
        r["times_blog"] = r["blog_job_seconds"] / BLOG_SECONDS
        print(
            f"{dist + ' ' + kind:<22}{r['bounces_per_second']:>11.3g}{r['paths_per_second']:>11.3g}"
            f"{r['bounces_per_path']:>12.2f}{r['paths_per_second_4_orders']:>13.3g}{r['blog_job_seconds']:>13.0f}"
            f"{r['times_blog']:>8.0f}{r['compile_seconds']:>11.1f}"
        )
    print(
        f"\n5e8 x 4: seconds for the blog's job ({BLOG_RAYS:.0e} rays, {BLOG_ORDERS} orders) here, from the paths/s "
        f"of the walk capped at {BLOG_ORDERS} events; x blog: against its {BLOG_SECONDS} s on a GPU."
    )
    results["native"] = native = bench_native(n, repeat)
    jax_rate = results[("ggx", "conductor")]["bounces_per_second"]
    native["jax_over_native"] = jax_rate / native["bounces_per_second"]
    print(
        f"\nnative reference: the GGX conductor walk in plain C, one thread, the same paths (no angular tallies): "
        f"{native['bounces_per_second']:.3g} bounces/s; the JAX walk on {len(dev)} device(s): {jax_rate:.3g}, "
        f"JAX / native {native['jax_over_native']:.3g}"
    )
    if not quick:
        cores = os.cpu_count() or 1
        s = bench_sharding(cores)
        results["sharding"] = s
        one, every = s["seconds"]["one device"], s["seconds"]["all devices"]
        print(
            f"\nsharded (GGX dielectric, {s['paths']} paths, {s['devices']} forced host devices in a fresh process): "
            f"one device {s['bounces'] / one:.3g} bounces/s, all {s['devices']} {s['bounces'] / every:.3g} "
            f"(x{one / every:.2f}); tallies identical: {'yes' if s['identical_tallies'] else 'NO'}"
        )
    return results


if __name__ == "__main__":  # bench_sharding's fresh process: N REPEAT, the figures as one JSON line
    print(json.dumps(_sharding_child(int(sys.argv[1]), int(sys.argv[2]))))
