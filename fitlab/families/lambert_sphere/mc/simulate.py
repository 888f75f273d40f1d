r"""The Lambert sphere's walk for the shared simulate runner (:mod:`fitlab.scenes`): the jobs a scene's
effects need, each run until its effects reach their standard-error target (or the path budget), then
compared with the exact engine; a CSV row per estimate and one PNG per effect.  The family's
Monte Carlo is :data:`SIMULATE` (the schema of :mod:`.scene` and :class:`SphereWalk`).

Stopping rule, per job: after every round of ``batch`` photons, the job stops
when every effect that uses it has all its Monte Carlo rows at or below that
effect's ``target_se`` (absolute, in the unit of the row: 1/sr for BRDF
values, 1 for albedos), with at least 10 000 photons; a bin no photon
reached (no error estimate) must have its rule-of-three bound 3/(N x bin
measure) below the target; or when it has used ``max_paths`` photons (then
the rows say converged = False).  A job that stops on the budget has missed
its target: :func:`fitlab.scenes.unconverged` names each such job, and ``fitlab simulate``
exits 1 unless ``--allow-unconverged`` is given.  A job whose stop (its target,
or its budget when the target needs more paths) is projected more than an hour
away at its measured rate is named in one warning line on stderr, once
(:func:`fitlab._montecarlo.slow_job_warning`).

Refused before any work (:class:`fitlab.scenes.SceneError`,
one line per problem): every scene error, a bad override, an output location
that is not a writable folder, and a material whose estimator would have an
infinite variance (c > 1/N for the three-term walk; docs/montecarlo.md).

Timing: each job's wall time (compilation reported apart) is charged to every
effect that uses it; the summary lists per effect the jobs, paths and
seconds, and the seconds of the exact references.  Nothing is written until
the run and the references are complete; the files are written as one unit.
"""

from __future__ import annotations

import math
import time

from fitlab import scenes
from fitlab.families.lambert_sphere.mc.effects import ROW_FIELDS, attach_reference, effect_jobs, estimate_rows, plan
from fitlab.families.lambert_sphere.mc.phase_sampling import unbounded_reason
from fitlab.families.lambert_sphere.mc.scene import SCHEMA, Scene, SceneError
from fitlab.families.lambert_sphere.mc.transport import compile_walk, default_mesh, start_round
from fitlab.scenes import SimulationResult, check_out_dir, summary_table, unconverged, write_outputs

__all__ = [
    "claims",
    "SIMULATE",
    "SphereWalk",
    "SimulationResult",
    "simulate",
    "simulate_file",
    "write_outputs",
    "unconverged",
    "check_out_dir",
    "summary_table",
    "SUMMARY_FIELDS",
    "MIN_PHOTONS",
]

MIN_PHOTONS = 10_000
SUMMARY_FIELDS = (
    "effect",
    "jobs",
    "paths",
    "collisions",
    "seconds",
    "compile_seconds",
    "reference_seconds",
    "target_se",
    "worst_se",
    "converged",
    "max_abs_z_ref",
    "capped_weight",
)


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


def _job_name(scene: Scene, job) -> str:
    mat = scene.materials[job.material]
    where = f"mu_i = {scene.mu_i[job.incident]:g}" if job.incident >= 0 else "cosine incidence"
    return f"{job.kind} job, material {mat.label} (c = {mat.c:.6g}), {where}"


class SphereWalk:
    """The half space's photon walk (:mod:`.transport`) as a :class:`fitlab.scenes.Walk`; a job is one
    photon stream of :func:`.effects.plan` (its key an :class:`.effects.Job`)."""

    unit = "photons"
    min_paths = MIN_PHOTONS
    row_fields = ROW_FIELDS
    summary_fields = SUMMARY_FIELDS
    summary_columns = (
        ("effect", "effect", "<18"),
        ("jobs", "jobs", ">5"),
        ("paths", "paths", ">12"),
        ("collisions", "collisions", ">13"),
        ("seconds", "seconds", ">9.2f"),
        ("target", "target_se", ">9.1e"),
        ("worst se", "worst_se", ">10.2e"),
        ("conv", "converged", ">6"),
        ("max|z|", "max_abs_z_ref", ">8.2f"),
    )

    def __init__(self, mesh=None):
        self.mesh = mesh

    def jobs(self, scene: Scene) -> list:
        mesh = self.mesh or default_mesh()
        planned = plan(scene)
        for job, cfg in planned.items():  # scenes made in code skip parse_scene's check: refuse before any work
            why = unbounded_reason(cfg.phase, scene.materials[job.material].c)
            if why:
                raise SceneError(f"material {scene.materials[job.material].label}: {why}")
        out = []
        for job, cfg in sorted(planned.items(), key=lambda kv: kv[0].stream):
            users = [e for e in scene.effects if job in effect_jobs(scene, e)]
            label = f"{job.kind}, {scene.materials[job.material].label}"
            out.append(scenes.Job(key=job, name=_job_name(scene, job), label=label, data=(cfg, mesh, users)))
        return out

    def compile(self, scene, job) -> float:
        cfg, mesh, _ = job.data
        return compile_walk(cfg, mesh)

    def run_round(self, scene, job, rounds, paths, n):
        return self.start_round(scene, job, rounds, paths, n).run()

    def start_round(self, scene, job, rounds, paths, n):
        cfg, mesh, _ = job.data
        mu_i = scene.mu_i[job.key.incident] if job.key.incident >= 0 else 0.0
        return start_round(
            cfg, scene.seed, job.key.stream + (rounds,), scene.materials[job.key.material].c, mu_i, n, mesh=mesh
        )

    def count(self, tallies):
        return int(tallies["photons"]), int(tallies["collisions"])

    def converged(self, scene, job, tallies):
        done, ratio = True, 0.0
        for e in job.data[2]:
            rows = estimate_rows(e, scene, {job.key: tallies})
            ok, worst = _effect_done(e, scene, rows, scene.target_se[e])
            done &= ok
            ratio = max(ratio, worst / scene.target_se[e])
        return done, ratio

    def finish(self, scene, jobs, tallies, stats):
        """Rows by effect (references attached, the job's statistics on each row) and one summary row per
        effect."""
        rows_by, summary = {}, []
        for e in scene.effects:
            t0 = time.perf_counter()
            rows = attach_reference(e, scene, estimate_rows(e, scene, tallies))
            ref_s = time.perf_counter() - t0
            ejobs = effect_jobs(scene, e)
            for r in rows:
                job = r.get("_job")
                if job is not None:
                    st = stats[job]
                    r.update(paths=st.paths, collisions=st.events, seconds=round(st.seconds, 3), converged=st.converged)
                else:
                    r.update(paths=0, collisions=0, seconds=0.0, converged=True)
            real = [r for r in rows if not r.get("_diag") and r["se"] > 0]
            zs = [abs(r["z_ref"]) for r in real if math.isfinite(r["z_ref"])]
            capped = [r["estimate"] for r in rows if r["quantity"] == "capped"]
            rows_by[e] = rows
            summary.append(
                dict(
                    effect=e,
                    jobs=len(ejobs),
                    paths=sum(stats[j].paths for j in ejobs),
                    collisions=sum(stats[j].events for j in ejobs),
                    seconds=round(sum(stats[j].seconds for j in ejobs), 3),
                    compile_seconds=round(sum(stats[j].compile_seconds for j in ejobs), 3),
                    reference_seconds=round(ref_s, 3),
                    target_se=scene.target_se.get(e, 0.0),
                    worst_se=max((r["se"] for r in real), default=0.0),
                    converged=all(stats[j].converged for j in ejobs),
                    max_abs_z_ref=max(zs, default=math.nan),
                    capped_weight=max(capped, default=0.0),
                )
            )
        return rows_by, summary

    def csv_rows(self, result):
        return [r for e in result.scene.effects for r in result.rows[e]]

    def plots(self, result):
        from fitlab.families.lambert_sphere.mc.plots import effect_png

        name = result.scene.name
        return [(f"{name}_{e}.png", effect_png(e, result.rows[e], name)) for e in result.scene.effects]


def simulate(scene: Scene, progress: bool = False, mesh=None) -> SimulationResult:
    """Run the scene (:func:`fitlab.scenes.simulate`); returns rows (by effect) and summary; writes nothing."""
    return scenes.simulate(SphereWalk(mesh), scene, progress=progress)


def simulate_file(path, out_dir=None, progress=False, plots=True, target_se=None, max_paths=None, seed=None):
    """Load, validate (all errors before any work: scene, overrides, output folder), simulate, write
    (:func:`fitlab.scenes.simulate_file`).  Returns (result, paths).  Overrides take the scene file's rules
    (:func:`~fitlab.families.lambert_sphere.mc.scene.check_option`); strings are parsed."""
    return scenes.simulate_file(
        SIMULATE,
        path,
        out_dir=out_dir,
        progress=progress,
        plots=plots,
        target_se=target_se,
        max_paths=max_paths,
        seed=seed,
    )


def claims(raw: dict) -> bool:
    """Whether a parsed scene file (a dict, before any validation) that names no family is one of this
    Monte Carlo's: a three-term or true phase half space, whose materials are given by c or kd.  ``fitlab
    simulate`` asks each family that simulates, for the scenes written before a scene named its family."""
    materials = raw.get("material") if isinstance(raw, dict) else None
    scene = raw.get("scene") if isinstance(raw, dict) else None
    if isinstance(scene, dict) and "phase" in scene:
        return True
    return isinstance(materials, list) and any(isinstance(m, dict) and ("c" in m or "kd" in m) for m in materials)


#: the family's Monte Carlo (``LambertSphere.simulation()``)
SIMULATE = scenes.Simulation(schema=SCHEMA, walk=SphereWalk(), claims=claims)
