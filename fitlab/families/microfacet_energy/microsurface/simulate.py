r"""Driver of the microsurface walk: run every job of a scene (material x mu_i) in rounds until its
rows reach their standard-error targets (or the path budget), attach the deterministic references,
and write a CSV, a summary CSV and (when matplotlib is present) one PNG of the lobe by order per job.

Estimates from the tallies of :mod:`.walk` after N paths (a tally holds, per path, its one
contribution x_p: the weight if the path ended there, else 0):

    mean = S1 / N,  se = sqrt((S2 / N - mean^2) / (N - 1)),

* ``lobe`` rows: the bin average of f mu_o (1/sr), mean / Omega, Omega = 2 (mu_1 - mu_0)(phi_1 - phi_0);
  order "1".."K" and ">K"; reference (order 1 only): :func:`.reference.bin_average_single` (conductor
  and dielectric facets), :func:`.reference.bin_average_diffuse` (diffuse facets);
* ``lobe_transmission`` rows (dielectrics, when the scene asks): the same for the transmitted lobe,
  f_t |mu_o| in bins of |mu_o| (mu_lo, mu_hi) and |phi_o|; reference :func:`.reference.bin_average_transmission`;
* ``albedo`` rows: int f_k mu_o dw_o by order (reflection), and ``capped`` (paths stopped at
  max_bounces); reference for order 1: :func:`.reference.albedo_single`;
* ``albedo_multiple``: orders >= 2 with the capped weight (each path contributes once, so the sums of
  S1 and S2 over the tallies are that row's own); reference 1 - E_1 for lossless materials (F = 1
  conductor, albedo-1 diffuse facets) whose order 1 has a reference;
* ``albedo_total``: every order plus the capped weight; reference 1 for lossless materials;
* ``transmission``: exits through the bottom, by order for dielectrics (reference for order 1:
  :func:`.reference.transmission_single`) and in all ("all"; 0 for opaque facets);
* ``energy_total``: reflection and transmission of every order plus the capped weight; reference 1
  (energy conservation) for lossless materials and dielectrics, where it holds path by path.

z_ref = (estimate - reference) / se (NaN without a reference or with se = 0).  In bins few paths reach z
is not normal (its se comes from the few paths): :func:`count_p_value` gives the exact binomial p-value of
a bin's count under its reference, which the tests and the validation study use for the lobes.

Stopping rule, per job: after every round of ``batch`` paths, the job stops when every lobe row has
se <= target_se["lobe"] and every albedo (transmission, energy) row se <= target_se["albedo"], after at
least MIN_PATHS paths;
a bin no path reached has no error estimate and counts as done when its rule-of-three bound
3 / (N Omega) (95 % upper limit for no event of weight <= 1) is below the target; or when it has used
``max_paths`` (its rows then say converged = False: :func:`unconverged` names the job).  A job whose stop
(its target, or its budget when the target needs more paths) is projected more than an hour away at its
measured rate is named in one warning line on stderr, once (:func:`fitlab._montecarlo.slow_job_warning`).
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

from fitlab._io import FolderError, atomic_write_bytes, atomic_write_text, check_output_folder
from fitlab._montecarlo import slow_job_warning
from fitlab.families.microfacet_energy.microsurface.reference import references
from fitlab.families.microfacet_energy.microsurface.scene import Scene, SceneError, load_scene, with_overrides
from fitlab.families.microfacet_energy.microsurface.walk import (
    MaterialParams,
    WalkConfig,
    compile_walk,
    job_key,
    run_round,
)

__all__ = ["claims", "SimulationResult", "SceneError", "simulate", "simulate_file", "write_outputs", "summary_table",
           "unconverged", "check_out_dir", "count_p_value", "ROW_FIELDS", "SUMMARY_FIELDS", "MIN_PATHS",
           "job_config", "job_params"]

MIN_PATHS = 10_000
ROW_FIELDS = ("quantity", "material", "kind", "distribution", "alpha_x", "alpha_y", "fresnel", "mu_i", "order",
              "mu_lo", "mu_hi", "phi_lo", "phi_hi", "estimate", "se", "reference", "z_ref", "reference_method",
              "paths", "bounces", "seconds", "converged", "eta")
SUMMARY_FIELDS = ("material", "mu_i", "paths", "bounces", "seconds", "compile_seconds", "bounces_per_second",
                  "worst_se_ratio", "converged", "max_abs_z_ref", "albedo_total", "capped", "transmission")


@dataclass
class JobStats:
    paths: int = 0
    bounces: int = 0
    seconds: float = 0.0
    compile_seconds: float = 0.0
    rounds: int = 0
    converged: bool = False
    se_ratio: float = math.nan


@dataclass
class SimulationResult:
    scene: Scene
    tallies: dict = field(default_factory=dict)  # (material index, mu_i index) -> summed tallies
    rows: list = field(default_factory=list)
    summary: list = field(default_factory=list)
    jobs: dict = field(default_factory=dict)  # (material index, mu_i index) -> JobStats
    wall_seconds: float = 0.0


def job_config(scene: Scene, material) -> WalkConfig:
    """The compiled configuration of a material's jobs."""
    return WalkConfig(distribution=material.distribution, kind=material.kind, fresnel=material.fresnel,
                      orders=scene.orders, mu_edges=scene.mu_edges, phi_edges=scene.phi_edges, slots=scene.slots,
                      transmission_lobe=scene.transmission_lobe and material.kind == "dielectric")


def job_params(material) -> MaterialParams:
    return MaterialParams(alpha_x=material.alpha_x, alpha_y=material.alpha_y, f0=material.f0, eta=material.eta,
                          k=material.k, albedo=material.albedo)


def _mean_se(s1, s2, n):
    s1, s2 = np.asarray(s1, float), np.asarray(s2, float)
    mean = s1 / n
    var = np.maximum(s2 / n - mean * mean, 0.0) / max(n - 1, 1)
    return mean, np.sqrt(var)


def _order_labels(k: int) -> list:
    return [str(j + 1) for j in range(k)] + [f">{k}"]


def _lobe_rows(quantity, t, base, labels, mu_e, phi_e, n, reference):
    omega = 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))
    mean, se = _mean_se(t[quantity], t[quantity + "_sq"], n)
    rows = []
    for k, lab in enumerate(labels):
        for i in range(len(mu_e) - 1):
            for j in range(len(phi_e) - 1):
                r = dict(base, quantity=quantity, order=lab, mu_lo=mu_e[i], mu_hi=mu_e[i + 1], phi_lo=phi_e[j],
                         phi_hi=phi_e[j + 1], estimate=mean[k, i, j] / omega[i, j], se=se[k, i, j] / omega[i, j],
                         _norm=omega[i, j], _n=n, _s1=float(t[quantity][k, i, j]),
                         _s2=float(t[quantity + "_sq"][k, i, j]))
                if k == 0 and reference is not None:
                    r.update(reference=reference[i, j], reference_method="bin_quadrature")
                rows.append(r)
    return rows


def _order_rows(quantity, t, base, labels, n, reference):
    mean, se = _mean_se(t[quantity], t[quantity + "_sq"], n)
    rows = []
    for k, lab in enumerate(labels):
        r = dict(base, quantity=quantity, order=lab, estimate=mean[k], se=se[k], _n=n)
        if k == 0 and reference is not None:
            r.update(reference=reference[0], reference_method=reference[1])
        rows.append(r)
    return rows


def estimate_rows(scene: Scene, mi: int, ii: int, t: dict, references: dict | None = None) -> list:
    """The rows of one job from its summed tallies ``t`` (references: from :func:`_references`, or None)."""
    mat, mu_i, n = scene.materials[mi], scene.mu_i[ii], int(t["paths"])
    uses_eta = mat.kind == "dielectric" or (mat.kind == "conductor" and mat.fresnel == "conductor")
    base = dict(material=mat.label, kind=mat.kind, distribution=mat.distribution, alpha_x=mat.alpha_x,
                alpha_y=mat.alpha_y, fresnel="dielectric" if mat.kind == "dielectric" else mat.fresnel, mu_i=mu_i,
                eta=mat.eta if uses_eta else math.nan)
    ref = references or {}
    labels = _order_labels(scene.orders)
    mu_e, phi_e = np.asarray(scene.mu_edges), np.asarray(scene.phi_edges)
    rows = _lobe_rows("lobe", t, base, labels, mu_e, phi_e, n, ref.get("lobe"))
    if "lobe_transmission" in t:
        rows += _lobe_rows("lobe_transmission", t, base, labels, mu_e, phi_e, n, ref.get("lobe_transmission"))
    rows += _order_rows("albedo", t, base, labels, n, ref.get("albedo"))
    c_mean, c_se = _mean_se(t["capped"], t["capped_sq"], n)
    rows.append(dict(base, quantity="albedo", order="capped", estimate=float(c_mean), se=float(c_se), _n=n))
    ms_mean, ms_se = _mean_se(np.sum(t["albedo"][1:]) + t["capped"], np.sum(t["albedo_sq"][1:]) + t["capped_sq"], n)
    r = dict(base, quantity="albedo_multiple", order=">=2", estimate=float(ms_mean), se=float(ms_se), _n=n)
    if mat.lossless and "albedo" in ref:
        r.update(reference=1.0 - ref["albedo"][0], reference_method="1 - " + ref["albedo"][1])
    rows.append(r)
    tot_mean, tot_se = _mean_se(np.sum(t["albedo"]) + t["capped"], np.sum(t["albedo_sq"]) + t["capped_sq"], n)
    r = dict(base, quantity="albedo_total", order="all", estimate=float(tot_mean), se=float(tot_se), _n=n)
    if mat.lossless:
        r.update(reference=1.0, reference_method="energy_conservation")
    rows.append(r)
    if mat.kind == "dielectric":
        rows += _order_rows("transmission", t, base, labels, n, ref.get("transmission"))
    tr_mean, tr_se = _mean_se(np.sum(t["transmission"]), np.sum(t["transmission_sq"]), n)
    rows.append(dict(base, quantity="transmission", order="all", estimate=float(tr_mean), se=float(tr_se), _n=n))
    # every path ends once (escaped up or down, or capped): the sums of S1 and S2 are this row's own
    en_mean, en_se = _mean_se(np.sum(t["albedo"]) + np.sum(t["transmission"]) + t["capped"],
                              np.sum(t["albedo_sq"]) + np.sum(t["transmission_sq"]) + t["capped_sq"], n)
    r = dict(base, quantity="energy_total", order="all", estimate=float(en_mean), se=float(en_se), _n=n)
    if mat.conserves_energy:
        r.update(reference=1.0, reference_method="energy_conservation")
    rows.append(r)
    for r in rows:
        if "reference" in r:
            r["z_ref"] = (r["estimate"] - r["reference"]) / r["se"] if r["se"] > 0 else math.nan
        else:
            r.update(reference=math.nan, z_ref=math.nan, reference_method="")
    return rows


def count_p_value(row) -> float:
    """Two-sided p-value of a lobe row's bin under its reference (NaN without one): the bin's paths are a
    binomial count, n ~ Binomial(N, q), q = reference Omega / w, w = S2 / S1 the paths' weight (exact when
    it is the same for every path of the bin: 1 for F = 1 conductors and dielectrics, albedo^k for order k
    of diffuse facets; an approximation otherwise), n = S1 / w; p = min(1, 2 min(P(n' <= n), P(n' >= n))).
    An empty bin gives p = 2 (1 - q)^N.  Unlike z, which takes its standard error from the
    sample, p stays calibrated in bins that a few paths reach (a bin expected to hold 8 paths that holds 2
    has z = -4.4 but p = 0.02)."""
    from scipy.stats import binom

    ref = row.get("reference", math.nan)
    if not math.isfinite(ref) or "_s1" not in row:
        return math.nan
    n_paths, s1, s2 = row["_n"], row["_s1"], row["_s2"]
    w = s2 / s1 if s1 > 0.0 else 1.0
    q = min(1.0, max(0.0, ref * row["_norm"] / w))
    count = s1 / w
    below = binom.cdf(math.floor(count + 1e-9), n_paths, q)
    above = binom.sf(math.ceil(count - 1e-9) - 1, n_paths, q)
    return float(min(1.0, 2.0 * min(below, above)))


def _references(scene: Scene, mi: int, ii: int) -> dict:
    """Order-1 references of a job (:func:`.reference.references`): lobe bin averages and albedo, and for a
    dielectric the transmitted lobe and fraction."""
    return references(scene.mu_edges, scene.phi_edges, scene.mu_i[ii], scene.materials[mi])


def _job_done(scene: Scene, rows: list) -> tuple:
    worst = 0.0
    for r in rows:
        if r["quantity"] == "transmission" and r["kind"] != "dielectric":
            continue  # opaque facets transmit nothing: no error estimate, and none needed
        target = scene.target_se["lobe" if r["quantity"] in ("lobe", "lobe_transmission") else "albedo"]
        if r["se"] == 0.0:
            if r["estimate"] == 0.0 and 3.0 / (r["_n"] * r.get("_norm", 1.0)) > target:
                return False, math.inf
            continue
        worst = max(worst, r["se"] / target)
    return worst <= 1.0, worst


def _warn(line: str) -> None:
    """One warning line on stderr."""
    print(f"fitlab simulate: warning: {line}", file=sys.stderr, flush=True)


def simulate(scene: Scene, progress: bool = False) -> SimulationResult:
    """Run every job of the scene (writes nothing); see the module docstring."""
    t_start = time.perf_counter()
    out = SimulationResult(scene=scene)
    for mi, mat in enumerate(scene.materials):
        cfg, params = job_config(scene, mat), job_params(mat)
        for ii, mu_i in enumerate(scene.mu_i):
            st = JobStats(compile_seconds=compile_walk(cfg))
            key = job_key(scene.seed, mi, ii)
            acc, warned = None, False
            while st.paths < scene.max_paths:
                n = min(scene.batch, scene.max_paths - st.paths)
                t0 = time.perf_counter()
                res = run_round(cfg, key, params, mu_i, st.paths, n, scene.max_bounces)
                st.seconds += time.perf_counter() - t0
                st.rounds += 1
                acc = res if acc is None else {k: acc[k] + v for k, v in res.items()}
                st.paths, st.bounces = int(acc["paths"]), int(acc["bounces"])
                done, st.se_ratio = _job_done(scene, estimate_rows(scene, mi, ii, acc))
                if progress:
                    print(f"{scene.name}: {mat.label} mu_i={mu_i:g}: {st.paths} paths, se/target {st.se_ratio:.2f}",
                          flush=True)
                if done and st.paths >= MIN_PATHS:
                    st.converged = True
                    break
                slow = None if warned else slow_job_warning(st.paths, st.seconds, st.se_ratio, scene.max_paths)
                if slow:
                    warned = True
                    _warn(f"material {mat.label}, mu_i = {mu_i:g}: {slow}")
            out.tallies[(mi, ii)], out.jobs[(mi, ii)] = acc, st
            rows = estimate_rows(scene, mi, ii, acc, _references(scene, mi, ii))
            for r in rows:
                r.update(paths=st.paths, bounces=st.bounces, seconds=round(st.seconds, 3), converged=st.converged)
            out.rows.extend(rows)
            zs = [abs(r["z_ref"]) for r in rows if math.isfinite(r["z_ref"])]
            total = next(r for r in rows if r["quantity"] == "albedo_total")
            capped = next(r for r in rows if r["quantity"] == "albedo" and r["order"] == "capped")
            trans = next(r for r in rows if r["quantity"] == "transmission" and r["order"] == "all")
            out.summary.append(dict(
                material=mat.label, mu_i=mu_i, paths=st.paths, bounces=st.bounces, seconds=round(st.seconds, 3),
                compile_seconds=round(st.compile_seconds, 3),
                bounces_per_second=st.bounces / st.seconds if st.seconds > 0 else math.nan,
                worst_se_ratio=st.se_ratio, converged=st.converged, max_abs_z_ref=max(zs, default=math.nan),
                albedo_total=total["estimate"], capped=capped["estimate"], transmission=trans["estimate"]))
    out.wall_seconds = time.perf_counter() - t_start
    return out


def _fmt(v):
    if isinstance(v, (float, np.floating)):
        return "" if math.isnan(v) else f"{float(v):.10g}"
    return str(v)


def _csv(rows, fields):
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(fields)
    for r in rows:
        w.writerow([_fmt(r.get(f, "")) for f in fields])
    return buf.getvalue()


def _plot(result: SimulationResult, mi: int, ii: int, path: Path):
    """One panel per order: the bin averages of f mu_o over (mu_o, |phi_o|), and a second row for the
    transmitted lobe (f_t |mu_o| over (|mu_o|, |phi_o|)) when it was tallied; None without matplotlib."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # plots are optional: the CSV holds every number
        return None
    scene, t = result.scene, result.tallies[(mi, ii)]
    mu_e, phi_e = np.asarray(scene.mu_edges), np.asarray(scene.phi_edges)
    omega = 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))
    labels = _order_labels(scene.orders)
    lobes = [("lobe", "mu_o", "mirror")] + ([("lobe_transmission", "|mu_o|, transmitted", "straight through")]
                                            if "lobe_transmission" in t else [])
    fig, axes = plt.subplots(len(lobes), len(labels), figsize=(3.0 * len(labels), 3.0 * len(lobes)), squeeze=False)
    for row, (name, ylabel, pi_side) in enumerate(lobes):
        for k, lab in enumerate(labels):
            ax = axes[row, k]
            im = ax.pcolormesh(phi_e, mu_e, t[name][k] / (t["paths"] * omega), shading="flat")
            ax.set_title(f"order {lab}" + (" (transmitted)" if row else ""))
            ax.set_xlabel(f"|phi_o| (pi: {pi_side})")
            if k == 0:
                ax.set_ylabel(ylabel)
            fig.colorbar(im, ax=ax)
    fig.suptitle(f"{scene.name}: {scene.materials[mi].label}, mu_i = {scene.mu_i[ii]:g}  (f |mu_o|, 1/sr)")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    return path


def write_outputs(result: SimulationResult, out_dir, plots: bool = True) -> list:
    """<name>.csv (every row), <name>_summary.csv, and <name>_<material>_<mu_i index>.png; returns the paths."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    name = result.scene.name
    paths = [out_dir / f"{name}.csv", out_dir / f"{name}_summary.csv"]
    atomic_write_text(paths[0], _csv(result.rows, ROW_FIELDS))
    atomic_write_text(paths[1], _csv(result.summary, SUMMARY_FIELDS))
    if plots:
        for (mi, ii) in sorted(result.tallies):
            safe = "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in result.scene.materials[mi].label)
            p = _plot(result, mi, ii, out_dir / f"{name}_{safe}_{ii}.png")
            if p is not None:
                paths.append(p)
    return paths


def summary_table(result: SimulationResult) -> str:
    """A plain-text table of the summary, one line per job (total: reflected albedo of all orders with the
    capped weight; trans: transmitted fraction)."""
    lines = [f"{'material':<16}{'mu_i':>6}{'paths':>11}{'bounces':>11}{'seconds':>9}{'bounce/s':>11}"
             f"{'se/tgt':>8}{'conv':>6}{'max|z|':>8}{'total':>10}{'trans':>10}"]
    for s in result.summary:
        lines.append(f"{s['material']:<16}{s['mu_i']:>6.3g}{s['paths']:>11}{s['bounces']:>11}{s['seconds']:>9.2f}"
                     f"{s['bounces_per_second']:>11.3g}{s['worst_se_ratio']:>8.2f}"
                     f"{'yes' if s['converged'] else 'NO':>6}{s['max_abs_z_ref']:>8.2f}{s['albedo_total']:>10.6f}"
                     f"{s['transmission']:>10.6f}")
    comp = sum(st.compile_seconds for st in result.jobs.values())
    lines.append(f"wall {result.wall_seconds:.1f} s (compilation {comp:.1f} s), {len(result.jobs)} jobs")
    return "\n".join(lines)


def unconverged(result: SimulationResult) -> list:
    """One line per job that stopped on its path budget above its standard-error target (or under MIN_PATHS)."""
    lines = []
    for (mi, ii), st in sorted(result.jobs.items()):
        if st.converged:
            continue
        mat = result.scene.materials[mi]
        why = (f"standard error {st.se_ratio:.3g} x its target" if not st.se_ratio <= 1.0
               else f"fewer than the {MIN_PATHS} paths the stopping rule needs")
        lines.append(f"not converged: material {mat.label}, mu_i = {result.scene.mu_i[ii]:g}: {why} after "
                     f"{st.paths} paths (max_paths)")
    return lines


def check_out_dir(out_dir) -> None:
    """Refuse (one-line SceneError) an output location that is not, or cannot become, a writable folder."""
    out_dir = Path(out_dir)
    try:
        check_output_folder(out_dir)
    except FolderError as exc:
        if exc.kind == "file":
            raise SceneError(f"--out: {out_dir} exists and is not a folder") from None
        raise SceneError(f"--out: cannot write in {out_dir}: {exc.detail or exc.kind.replace('_', ' ')} at "
                         f"{exc.where}") from None


def simulate_file(path, out_dir=None, progress=False, plots=True, target_se=None, max_paths=None, seed=None):
    """Load and validate (scene, overrides, output folder: every error before any work), simulate, write.

    Returns (result, paths written)."""
    scene = with_overrides(load_scene(path), target_se=target_se, max_paths=max_paths, seed=seed)
    out_dir = Path(out_dir) if out_dir is not None else Path("mc_out") / scene.name
    check_out_dir(out_dir)
    result = simulate(scene, progress=progress)
    return result, write_outputs(result, out_dir, plots=plots)


def claims(raw: dict) -> bool:
    """Whether a parsed scene file (a dict, before any validation) is a microsurface walk's: its materials
    name a facet kind or a slope distribution.  ``fitlab simulate`` asks each family that simulates."""
    materials = raw.get("material") if isinstance(raw, dict) else None
    return isinstance(materials, list) and any(isinstance(m, dict) and ("kind" in m or "distribution" in m)
                                               for m in materials)  # fmt: skip
