"""Benchmarks (not tests) of the Lambert-sphere family: the exact engine, the generated code, the Monte Carlo.

``bench_exact``: points per second and agreement of each exact method.  ``bench_codegen``: the
generated C (full runtime model, fast variant) against two baselines compiled the same way (Lambert
kd/pi; qualitative Oren-Nayar, sigma = 0.5), each printed from one sympy expression, on the same
random inputs (:func:`fitlab.codegen.bench.time_routines`), and the generated numpy module.
``bench_mc`` (:mod:`..mc.throughput`): photons and collisions per second.  ``bench_render``: Mitsuba 3 samples per
second of the registered ``lambert_sphere`` plugin in scalar_rgb and llvm_ad_rgb, beside Mitsuba's own
``diffuse``.  Timings are wall-clock on this machine, side by side in one run: only their ratios carry meaning.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from fitlab._io import import_generated
from fitlab.codegen import build_program, emit, load_program
from fitlab.codegen.bench import time_routines
from fitlab.codegen.native import build
from fitlab.families.lambert_sphere.exact import (
    brdf_modes,
    clear_h_cache,
    doubling_reflection,
    h_fock,
    lambert_sphere_characteristic,
    solve_h,
)
from fitlab.families.lambert_sphere.program.baselines import baseline_program
from fitlab.families.lambert_sphere.targets.tabulate import write_tables
from fitlab.timing import best_of, best_seconds

__all__ = ["bench_exact", "bench_codegen", "bench_mc", "bench_render", "random_inputs"]


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
            clear_h_cache()
            t_solve, sol = best_of(lambda char=char: solve_h(char), 1)
            t_ny, a = best_of(lambda sol=sol: sol(mu), 3)
            t_fo, b = best_of(lambda char=char: h_fock(char, mu), 1)
            diff = float(np.max(np.abs(a / b - 1)))
            results[(m, c)] = dict(solve_s=t_solve, nystrom_pps=n / t_ny, fock_pps=n / t_fo, max_rel_diff=diff)
            print(f"H{m} c={c:<5} Nystrom (solve {t_solve * 1e3:5.1f} ms){n / t_ny:>12.3g}{diff:>16.2e}")
            print(f"H{m} c={c:<5} Fock{'':<22}{n / t_fo:>12.3g}")
    k = 50 if quick else 200
    mi, mo = rng.uniform(0, 1, (2, k * k))
    t_modes, _ = best_of(lambda: brdf_modes(mi, mo, 0.8), 3)
    print(f"\nbrdf_modes (c fixed, solved): {k * k / t_modes:.3g} points/s")
    t_dbl, d = best_of(lambda: doubling_reflection.__wrapped__(0, 0.8), 1)
    print(
        f"doubling (order 0, {d.nodes.size} ordinates, {d.doublings} doublings): {t_dbl:.2f} s "
        f"for {d.nodes.size**2} node pairs"
    )
    if not quick:
        with tempfile.TemporaryDirectory() as tmp:
            t_tab, _ = best_of(lambda: write_tables(tmp, show_progress=False), 1)
        print(f"writing all tables: {t_tab:.1f} s")
        results["tabulate_s"] = t_tab
    return results


# -- generated code: the runtime model and the fast variant against Lambert and Oren-Nayar ----------
def random_inputs(n: int, seed: int = 0) -> dict:
    """The benchmark's inputs: mu_i, mu_o, c uniform on [0, 1), cos_phi uniform on [-1, 1) (numpy, seeded)."""
    rng = np.random.default_rng(seed)
    mu_i, mu_o, c = rng.random(n), rng.random(n), rng.random(n)
    return {"mu_i": mu_i, "mu_o": mu_o, "c": c, "cos_phi": rng.uniform(-1, 1, n)}


#: materials of the hoisted benchmark: each point takes one of this many, prepared once (a scene's materials)
BENCH_MATERIALS = 64


def bench_codegen(fits_dir: Path | None = None, n: int = 1_000_000, repeat: int = 5) -> dict:
    """ns per evaluation of the generated C, every case in one interleaved run (:func:`time_routines`):

    * per call: ``brdf(mu_i, mu_o, cos_phi, c)`` with a random c at every point (every c-only quantity
      computed at every call), for the shipped model and the published one (``paper`` preset, orders 0
      and 1 as the paper has them), the fast variant, and Lambert and Oren-Nayar;
    * set-up hoisted: ``eval(&material, mu_i, mu_o, cos_phi)`` with :data:`BENCH_MATERIALS` materials
      prepared once, point i taking a random one (as a renderer does: a material is prepared when the
      scene loads), for the same models; and ``prepare`` itself, per material;
    * the exported tables (``fitlab codegen --tables``, the shipped default: bicubic, 33 nodes), per call,
      hoisted and prepare;
    * the generated numpy module, per call.
    """
    from fitlab.families.lambert_sphere.program import table_export
    from fitlab.report.methods import preset_records

    prog = load_program(fits_dir)
    records = preset_records("paper")
    published = build_program({t: r for (t, _), r in records.items()}, terms=("single", "m0", "m1"))
    base = baseline_program()
    x = random_inputs(n)
    mu_i, mu_o, c, cos_phi = x["mu_i"], x["mu_o"], x["c"], x["cos_phi"]
    rng = np.random.default_rng(1)
    which = rng.integers(0, BENCH_MATERIALS, n)
    mat_c = rng.random(BENCH_MATERIALS)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        model = build(emit(prog, "c"), prog, Path(tmp) / "model")
        paper = build(emit(published, "c"), published, Path(tmp) / "paper")
        baselines = build(emit(base, "c"), base, Path(tmp) / "base")
        tables_prog = table_export.program()
        tables = build({name: data.decode() for name, data in table_export.generate("c").items()}, tables_prog,
                       Path(tmp) / "tables")  # fmt: skip
        module = Path(tmp) / f"{prog.name}.py"
        module.write_text(emit(prog, "python")[module.name])
        py = import_generated(module, "_fitlab_bench")
        kd = py.kd_of_c(c)
        mat_kd = py.kd_of_c(mat_c)
        cases = {
            "lambert (baseline)": (baselines, "baseline_lambert", (mu_i, mu_o, cos_phi, kd)),
            "oren_nayar (baseline)": (baselines, "baseline_oren_nayar", (mu_i, mu_o, cos_phi, kd)),
            "brdf_fast (eq. 41)": (model, "brdf_fast", (mu_i, mu_o, cos_phi, c, kd)),
            "brdf (published: paper)": (paper, "brdf", (mu_i, mu_o, cos_phi, c)),
            "brdf (shipped model)": (model, "brdf", (mu_i, mu_o, cos_phi, c)),
            "brdf (exported tables)": (tables, "brdf", (mu_i, mu_o, cos_phi, c)),
        }
        hoisted = {
            "lambert (baseline)": (baselines, "eval_lambert", mat_kd),
            "oren_nayar (baseline)": (baselines, "eval_oren_nayar", mat_kd),
            "brdf (published: paper)": (paper, "eval", mat_c),
            "brdf (shipped model)": (model, "eval", mat_c),
            "brdf (exported tables)": (tables, "eval", mat_c),
        }
        timed = {}
        for dt in (np.float64, np.float32):
            how = "C " + np.dtype(dt).name
            timed.update({(label, how): (lib, name, args, dt) for label, (lib, name, args) in cases.items()})
            for label, (lib, name, params) in hoisted.items():
                setup = lib.material.prepare_name
                timed[(label, how + ", hoisted")] = (
                    lib,
                    name,
                    (lib(setup, params, dtype=dt), which, mu_i, mu_o, cos_phi),
                    dt,
                )
            for label, lib in (("prepare (published: paper)", paper), ("prepare (shipped model)", model),
                               ("prepare (exported tables)", tables)):  # fmt: skip
                timed[(label, how)] = (lib, lib.material.prepare_name, (c[: n // 16],), dt)
        rows.update(time_routines(timed, repeat))
        for label, fn, args in (("brdf (shipped model)", py.brdf, (mu_i, mu_o, cos_phi, c)),
                                ("brdf_fast (eq. 41)", py.brdf_fast, (mu_i, mu_o, cos_phi, c, kd))):  # fmt: skip
            rows[(label, "numpy float64")] = (
                best_seconds(lambda fn=fn, args=args: fn(*args), max(1, repeat // 2)) / n * 1e9
            )
    ref = rows[("lambert (baseline)", "C float64")]
    print(
        f"generated BRDF cost, {n} random inputs, best of {repeat} (ns per evaluation; x = / Lambert C double, per call)"
    )
    print(
        f"  hoisted: {BENCH_MATERIALS} materials prepared once, each point takes one at random; prepare: ns per material"
    )
    for (label, how), ns in sorted(rows.items(), key=lambda kv: (kv[0][1], kv[1])):
        print(f"  {label:<28} {how:<24} {ns:8.2f} ns  {ns / ref:7.1f} x")
    return {f"{label} / {how}": ns for (label, how), ns in rows.items()}


def bench_mc(quick: bool = False) -> dict:
    """Photons and collisions per second of the Monte Carlo (:func:`..mc.throughput.bench_mc`; imports JAX)."""
    from fitlab.families.lambert_sphere.mc.throughput import bench_mc as run

    return run(quick=quick)


#: the scene of :func:`bench_render`: an RGB reflectance (a material per channel) in a white furnace
RENDER_KD = (0.8, 0.5, 0.2)


def bench_render(quick: bool = False, size: int | None = None, spp: int = 4, repeat: int = 3,
                 show_progress: bool = True) -> dict:  # fmt: skip
    """Samples (camera rays) per second of a Mitsuba render: a sphere of reflectance :data:`RENDER_KD` in a white
    furnace (path tracing: every sample calls the BSDF's sample and eval_pdf), size x size pixels (256; quick:
    64) at ``spp`` samples per pixel, with the ``lambert_sphere`` plugin and with Mitsuba's ``diffuse`` (the
    same reflectance), in scalar_rgb and, where Dr.Jit's LLVM backend runs, llvm_ad_rgb, one variant after the
    other in this process.  llvm: the first render (tracing the Python plugin and compiling the kernel, or
    reading it from Dr.Jit's kernel cache) apart from the best of ``repeat`` later ones; scalar: one render each
    (it has nothing to compile, and the plugin's render takes seconds)."""
    from tqdm import tqdm

    from fitlab.families.lambert_sphere.mitsuba.render import llvm_problem, sphere_scene, use_variant

    size = size or (64 if quick else 256)
    problem = llvm_problem()
    variants = ("scalar_rgb",) if problem else ("scalar_rgb", "llvm_ad_rgb")
    bsdfs = {"lambert_sphere (plugin)": "lambert_sphere", "diffuse (Mitsuba)": "diffuse"}
    samples = size * size * spp
    rows = {}
    bar = tqdm(total=len(variants) * len(bsdfs), desc="bench render", unit="scene", disable=not show_progress)
    for variant in variants:
        mi, _ = use_variant(variant)
        scenes = {label: sphere_scene({"type": kind, "reflectance": {"type": "rgb", "value": list(RENDER_KD)}}, None,
                                      size, spp, mi) for label, kind in bsdfs.items()}  # fmt: skip
        for label, scene in scenes.items():
            render = lambda seed=0, scene=scene, mi=mi: np.array(mi.render(scene, seed=seed))  # noqa: E731
            first = best_seconds(render, 1)
            later = best_seconds(lambda render=render: render(seed=1), repeat) if variant != "scalar_rgb" else first
            rows[(label, variant)] = {"first_s": first, "best_s": later, "samples_per_s": samples / later}
            bar.update()
    bar.close()
    print(f"Mitsuba render, {size} x {size} pixels, {spp} spp, white furnace, reflectance {RENDER_KD}: samples per "
          "second (best of later renders; llvm's first render traces and compiles)")  # fmt: skip
    if problem:
        print(f"  llvm_ad_rgb not run here: {problem}")
    for (label, variant), r in rows.items():
        print(f"  {label:<26} {variant:<12} {r['samples_per_s']:12.4g} samples/s  first render {r['first_s']:7.2f} s")
    plugin, diffuse = bsdfs
    if not problem:
        ratio = rows[(plugin, "llvm_ad_rgb")]["samples_per_s"] / rows[(plugin, "scalar_rgb")]["samples_per_s"]
        print(f"  plugin, llvm_ad_rgb / scalar_rgb: {ratio:.3g} x")
    for variant in variants:
        ratio = rows[(diffuse, variant)]["samples_per_s"] / rows[(plugin, variant)]["samples_per_s"]
        print(f"  {variant}: diffuse is {ratio:.3g} x as fast as the plugin")
    return {"size": size, "spp": spp, "llvm_problem": problem, "rows": rows}
