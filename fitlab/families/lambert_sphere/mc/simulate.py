r"""The ``fitlab simulate`` driver: run the jobs a scene's effects need, each
until its effects reach their standard-error target (or the path budget),
then compare with the exact engine and write a CSV and one PNG per effect.

Stopping rule, per job: after every round of ``batch`` photons, the job stops
when every effect that uses it has all its Monte Carlo rows at or below that
effect's ``target_se`` (absolute, in the unit of the row: 1/sr for BRDF
values, 1 for albedos), with at least 10 000 photons; a bin no photon
reached (no error estimate) must have its rule-of-three bound 3/(N x bin
measure) below the target; or when it has used ``max_paths`` photons (then
the rows say converged = False).  A job that stops on the budget has missed
its target: :func:`unconverged` names each such job, and ``fitlab simulate``
exits 1 unless ``--allow-unconverged`` is given.  A job whose stop (its target,
or its budget when the target needs more paths) is projected more than an hour
away at its measured rate is named in one warning line on stderr, once
(:func:`fitlab._montecarlo.slow_job_warning`).

Refused before any work (:class:`~fitlab.families.lambert_sphere.mc.scene.SceneError`,
one line per problem): every scene error, a bad override, an output location
that is not a writable folder, and a material whose estimator would have an
infinite variance (c > 1/N for the three-term walk; docs/montecarlo.md).

Timing: each job's wall time (compilation reported apart) is charged to every
effect that uses it; the summary lists per effect the jobs, paths and
seconds, and the seconds of the exact references.  Nothing is written until
the run and the references are complete; every file is written atomically.
"""

from __future__ import annotations

import csv
import io
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab._io import FolderError, atomic_write_text, check_output_folder
from fitlab._montecarlo import slow_job_warning
from fitlab.families.lambert_sphere.mc.effects import ROW_FIELDS, attach_reference, effect_jobs, estimate_rows, plan
from fitlab.families.lambert_sphere.mc.sampling import unbounded_reason
from fitlab.families.lambert_sphere.mc.scene import Scene, SceneError, load_scene, with_overrides
from fitlab.families.lambert_sphere.mc.transport import compile_walk, default_mesh, run_round

__all__ = ["claims", "SimulationResult", "simulate", "simulate_file", "write_outputs", "unconverged", "check_out_dir",
           "SUMMARY_FIELDS"]

MIN_PHOTONS = 10_000
SUMMARY_FIELDS = ("effect", "jobs", "paths", "collisions", "seconds", "compile_seconds", "reference_seconds",
                  "target_se", "worst_se", "converged", "max_abs_z_ref", "capped_weight")


@dataclass
class JobStats:
    paths: int = 0
    collisions: int = 0
    capped: int = 0
    seconds: float = 0.0
    compile_seconds: float = 0.0
    rounds: int = 0
    converged: bool = False
    se_ratio: float = math.nan  # worst (standard error / target) over the job's effects, last round


@dataclass
class SimulationResult:
    scene: Scene
    rows: dict = field(default_factory=dict)  # effect -> list of rows
    summary: list = field(default_factory=list)  # one dict per effect
    jobs: dict = field(default_factory=dict)  # Job -> JobStats
    wall_seconds: float = 0.0


def _accumulate(acc, new):
    if acc is None:
        return {k: np.array(v, copy=True) for k, v in new.items()}
    for k, v in new.items():
        acc[k] = acc[k] + v
    return acc


def _effect_done(effect, scene, rows, target):
    """(done, worst se) for an effect's rows of one job.

    A row no photon has reached (se = 0: an empty bin) has no error estimate;
    it counts as done when the rule-of-three bound on its mean, 3/(N norm)
    (95 % upper limit for zero events of weight <= 1), is below the target.
    """
    worst = 0.0
    for r in rows:
        if r.get("_diag"):
            continue
        if r["se"] == 0.0:
            bound = 3.0 / (r["_n"] * r.get("_norm", 1.0))
            if bound > target:
                return False, math.inf
            continue
        worst = max(worst, r["se"])
    return worst <= target, worst


def _warn(line: str, bar=None) -> None:
    """One warning line on stderr (through the progress bar when there is one)."""
    line = f"fitlab simulate: warning: {line}"
    if bar is not None:
        bar.write(line, file=sys.stderr)
    else:
        print(line, file=sys.stderr, flush=True)


def _job_name(scene: Scene, job) -> str:
    mat = scene.materials[job.material]
    where = f"mu_i = {scene.mu_i[job.incident]:g}" if job.incident >= 0 else "cosine incidence"
    return f"{job.kind} job, material {mat.label} (c = {mat.c:.6g}), {where}"


def simulate(scene: Scene, progress: bool = True, mesh=None) -> SimulationResult:
    """Run the scene; returns rows and summary (writes nothing)."""
    t_start = time.perf_counter()
    mesh = mesh or default_mesh()
    jobs = plan(scene)
    for job, cfg in jobs.items():  # scenes made in code skip parse_scene's check: refuse before any work
        why = unbounded_reason(cfg.phase, scene.materials[job.material].c)
        if why:
            raise SceneError(f"material {scene.materials[job.material].label}: {why}")
    users = {job: [e for e in scene.effects if job in effect_jobs(scene, e)] for job in jobs}
    results, stats = {}, {job: JobStats() for job in jobs}
    bar = None
    if progress:

        bar = tqdm(total=len(jobs) * scene.max_paths, unit="path", unit_scale=True, desc=scene.name,
                   disable=not jobs)
    try:
        for k, (job, cfg) in enumerate(sorted(jobs.items(), key=lambda kv: kv[0].stream)):
            st = stats[job]
            st.compile_seconds = compile_walk(cfg, mesh)
            mat = scene.materials[job.material]
            mu_i = scene.mu_i[job.incident] if job.incident >= 0 else 0.0
            warned = False
            while st.paths < scene.max_paths:
                n = min(scene.batch, scene.max_paths - st.paths)
                t0 = time.perf_counter()
                res = run_round(cfg, scene.seed, job.stream + (st.rounds,), mat.c, mu_i, n, mesh=mesh)
                st.seconds += time.perf_counter() - t0
                st.rounds += 1
                results[job] = _accumulate(results.get(job), res)
                st.paths = int(results[job]["photons"])
                st.collisions = int(results[job]["collisions"])
                st.capped = int(results[job]["n_capped"])
                done, ratio = True, 0.0
                for e in users[job]:
                    rows = estimate_rows(e, scene, {job: results[job]})
                    ok, worst = _effect_done(e, scene, rows, scene.target_se[e])
                    done &= ok
                    ratio = max(ratio, worst / scene.target_se[e])
                if bar is not None:
                    bar.update(n)
                    bar.set_postfix_str(f"job {k + 1}/{len(jobs)} ({job.kind}, {mat.label}) se/target={ratio:.2f}")
                st.se_ratio = ratio
                if done and st.paths >= MIN_PHOTONS:
                    st.converged = True
                    break
                slow = None if warned else slow_job_warning(st.paths, st.seconds, ratio, scene.max_paths)
                if slow:
                    warned = True
                    _warn(f"{_job_name(scene, job)}: {slow}", bar)
            if bar is not None and st.paths < scene.max_paths:
                bar.update(scene.max_paths - st.paths)
    finally:
        if bar is not None:
            bar.close()
    out = SimulationResult(scene=scene, jobs=stats)
    for e in scene.effects:
        t0 = time.perf_counter()
        rows = attach_reference(e, scene, estimate_rows(e, scene, results))
        ref_s = time.perf_counter() - t0
        ejobs = effect_jobs(scene, e)
        for r in rows:
            job = r.get("_job")
            if job is not None:
                st = stats[job]
                r.update(paths=st.paths, collisions=st.collisions, seconds=round(st.seconds, 3),
                         converged=st.converged)
            else:
                r.update(paths=0, collisions=0, seconds=0.0, converged=True)
        real = [r for r in rows if not r.get("_diag") and r["se"] > 0]
        zs = [abs(r["z_ref"]) for r in real if math.isfinite(r["z_ref"])]
        capped = [r["estimate"] for r in rows if r["quantity"] == "capped"]
        out.rows[e] = rows
        out.summary.append(dict(
            effect=e, jobs=len(ejobs), paths=sum(stats[j].paths for j in ejobs),
            collisions=sum(stats[j].collisions for j in ejobs),
            seconds=round(sum(stats[j].seconds for j in ejobs), 3),
            compile_seconds=round(sum(stats[j].compile_seconds for j in ejobs), 3),
            reference_seconds=round(ref_s, 3),
            target_se=scene.target_se.get(e, 0.0),
            worst_se=max((r["se"] for r in real), default=0.0),
            converged=all(stats[j].converged for j in ejobs),
            max_abs_z_ref=max(zs, default=math.nan),
            capped_weight=max(capped, default=0.0),
        ))
    out.wall_seconds = time.perf_counter() - t_start
    return out


def _fmt(v):
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.10g}"
    return str(v)


def _csv(rows, fields):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(fields)
    for r in rows:
        w.writerow([_fmt(r.get(f, "")) for f in fields])
    return buf.getvalue()


def write_outputs(result: SimulationResult, out_dir: Path, plots: bool = True) -> list:
    """CSV of all rows, summary CSV, one PNG per effect; returns the paths written."""
    from fitlab.families.lambert_sphere.mc.plots import plot_effect

    out_dir = Path(out_dir)
    name = result.scene.name
    all_rows = [r for e in result.scene.effects for r in result.rows[e]]
    paths = [out_dir / f"{name}.csv", out_dir / f"{name}_summary.csv"]
    atomic_write_text(paths[0], _csv(all_rows, ROW_FIELDS))
    atomic_write_text(paths[1], _csv(result.summary, SUMMARY_FIELDS))
    if plots:
        for e in result.scene.effects:
            paths.append(plot_effect(e, result.rows[e], out_dir / f"{name}_{e}.png", name))
    return paths


def summary_table(result: SimulationResult) -> str:
    """A plain-text table of the summary."""
    head = f"{'effect':<18}{'jobs':>5}{'paths':>12}{'collisions':>13}{'seconds':>9}{'target':>9}{'worst se':>10}" \
           f"{'conv':>6}{'max|z|':>8}"
    lines = [head]
    for s in result.summary:
        lines.append(f"{s['effect']:<18}{s['jobs']:>5}{s['paths']:>12}{s['collisions']:>13}{s['seconds']:>9.2f}"
                     f"{s['target_se']:>9.1e}{s['worst_se']:>10.2e}{'yes' if s['converged'] else 'NO':>6}"
                     f"{s['max_abs_z_ref']:>8.2f}")
    comp = sum(st.compile_seconds for st in result.jobs.values())
    lines.append(f"wall {result.wall_seconds:.1f} s (compilation {comp:.1f} s), {len(result.jobs)} jobs")
    return "\n".join(lines)


def unconverged(result: SimulationResult) -> list:
    """One line per job that stopped on its path budget without converging (above its
    standard-error target, or under the 10 000-photon minimum)."""
    lines = []
    scene = result.scene
    for job in sorted(plan(scene), key=lambda j: j.stream):
        st = result.jobs[job]
        if st.converged:
            continue
        why = (f"standard error {st.se_ratio:.3g} x its target" if not st.se_ratio <= 1.0
               else f"fewer than the {MIN_PHOTONS} photons the stopping rule needs")
        lines.append(f"not converged: {_job_name(scene, job)}: {why} after {st.paths} paths (max_paths)")
    return lines


def check_out_dir(out_dir: Path) -> None:
    """Refuse (one-line SceneError) an output location that is not, or cannot become, a writable folder
    (:func:`fitlab._io.check_output_folder`, the check every command makes; nothing is created)."""
    out_dir = Path(out_dir)
    try:
        check_output_folder(out_dir)
    except FolderError as exc:
        if exc.kind == "file":
            raise SceneError(f"--out: {out_dir} exists and is not a folder") from None
        raise SceneError(f"--out: cannot write in {out_dir}: {exc.detail or exc.kind.replace('_', ' ')} at "
                         f"{exc.where}") from None


def simulate_file(path, out_dir=None, progress=True, plots=True, target_se=None, max_paths=None, seed=None):
    """Load, validate (all errors before any work: scene, overrides, output folder), simulate, write.

    Returns (result, paths).  Overrides take the scene file's rules
    (:func:`~fitlab.families.lambert_sphere.mc.scene.check_option`); strings are parsed.
    """
    scene = with_overrides(load_scene(path), target_se=target_se, max_paths=max_paths, seed=seed)
    out_dir = Path(out_dir) if out_dir is not None else Path("mc_out") / scene.name
    check_out_dir(out_dir)
    result = simulate(scene, progress=progress)
    return result, write_outputs(result, out_dir, plots=plots)


def claims(raw: dict) -> bool:
    """Whether a parsed scene file (a dict, before any validation) is one of this Monte Carlo's: a
    three-term or true phase half space, whose materials are given by c or kd.  ``fitlab simulate`` asks
    each family that simulates, when the scene does not say and no --family is given."""
    materials = raw.get("material") if isinstance(raw, dict) else None
    scene = raw.get("scene") if isinstance(raw, dict) else None
    if isinstance(scene, dict) and "phase" in scene:
        return True
    return isinstance(materials, list) and any(isinstance(m, dict) and ("c" in m or "kd" in m) for m in materials)
