r"""The microsurface walk for the shared simulate runner (:mod:`fitlab.scenes`): every job of a scene
(material x mu_i) run in rounds until its rows reach their standard-error targets (or the path budget),
the deterministic references attached; a CSV row per estimate, a summary row and (when matplotlib is
present) one PNG of the lobe by order per job.  The family's Monte Carlo is :data:`SIMULATE` (the
schema of :mod:`.scene` and :class:`MicrosurfaceWalk`).

Estimates from the tallies of :mod:`.walk` after N paths (a tally holds, per path, its one
contribution x_p: the weight if the path ended there, else 0):

    mean = S1 / N,  se = sqrt((S2 / N - mean^2) / (N - 1)),

Details: docs/microsurface.md, section ``fitlab.families.microfacet_energy.mc.simulate``."""

from __future__ import annotations

import io
import math
from typing import cast

import numpy as np

from fitlab import scenes
from fitlab.families.microfacet_energy.mc.reference import references
from fitlab.families.microfacet_energy.mc.scene import SCHEMA, Scene, SceneError
from fitlab.families.microfacet_energy.mc.walk import (
    MaterialParams,
    WalkConfig,
    compile_walk,
    job_key,
    start_round,
)
from fitlab.scenes import SimulationResult, check_out_dir, summary_table, unconverged, write_outputs

__all__ = [
    "claims",
    "SIMULATE",
    "MicrosurfaceWalk",
    "SimulationResult",
    "SceneError",
    "simulate",
    "simulate_file",
    "write_outputs",
    "summary_table",
    "unconverged",
    "check_out_dir",
    "count_p_value",
    "ROW_FIELDS",
    "SUMMARY_FIELDS",
    "MIN_PATHS",
    "job_config",
    "job_params",
]

MIN_PATHS = 10_000
ROW_FIELDS = (
    "quantity",
    "material",
    "kind",
    "distribution",
    "alpha_x",
    "alpha_y",
    "fresnel",
    "mu_i",
    "order",
    "mu_lo",
    "mu_hi",
    "phi_lo",
    "phi_hi",
    "estimate",
    "se",
    "reference",
    "z_ref",
    "reference_method",
    "paths",
    "bounces",
    "seconds",
    "converged",
    "eta",
)
SUMMARY_FIELDS = (
    "material",
    "mu_i",
    "paths",
    "bounces",
    "seconds",
    "compile_seconds",
    "bounces_per_second",
    "worst_se_ratio",
    "converged",
    "max_abs_z_ref",
    "albedo_total",
    "capped",
    "transmission",
    "failed",
)


def job_config(scene: Scene, material) -> WalkConfig:
    """The compiled configuration of a material's jobs."""
    return WalkConfig(
        distribution=material.distribution,
        kind=material.kind,
        fresnel=material.fresnel,
        orders=scene.orders,
        mu_edges=scene.mu_edges,
        phi_edges=scene.phi_edges,
        slots=scene.slots,
        transmission_lobe=scene.transmission_lobe and material.kind == "dielectric",
        precision=scene.walk_precision,
    )


def job_params(material) -> MaterialParams:
    return MaterialParams(
        alpha_x=material.alpha_x,
        alpha_y=material.alpha_y,
        f0=material.f0,
        eta=material.eta,
        k=material.k,
        albedo=material.albedo,
    )


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
                r = dict(
                    base,
                    quantity=quantity,
                    order=lab,
                    mu_lo=mu_e[i],
                    mu_hi=mu_e[i + 1],
                    phi_lo=phi_e[j],
                    phi_hi=phi_e[j + 1],
                    estimate=mean[k, i, j] / omega[i, j],
                    se=se[k, i, j] / omega[i, j],
                    _norm=omega[i, j],
                    _n=n,
                    _s1=float(t[quantity][k, i, j]),
                    _s2=float(t[quantity + "_sq"][k, i, j]),
                )
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
    base = dict(
        material=mat.label,
        kind=mat.kind,
        distribution=mat.distribution,
        alpha_x=mat.alpha_x,
        alpha_y=mat.alpha_y,
        fresnel="dielectric" if mat.kind == "dielectric" else mat.fresnel,
        mu_i=mu_i,
        eta=mat.eta if uses_eta else math.nan,
    )
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
    en_mean, en_se = _mean_se(
        np.sum(t["albedo"]) + np.sum(t["transmission"]) + t["capped"],
        np.sum(t["albedo_sq"]) + np.sum(t["transmission_sq"]) + t["capped_sq"],
        n,
    )
    r = dict(base, quantity="energy_total", order="all", estimate=float(en_mean), se=float(en_se), _n=n)
    if mat.conserves_energy:
        r.update(reference=1.0, reference_method="energy_conservation")
    rows.append(r)
    failed = int(t.get("failed", 0))
    f_mean, f_se = _mean_se(failed, failed, n)
    rows.append(
        dict(
            base,
            quantity="failed",
            order="all",
            estimate=float(f_mean),
            se=float(f_se),
            _n=n,
            reference=0.0,
            reference_method="none: a walk error",
        )
    )
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
        if r["quantity"] == "failed":
            continue  # a count of errors, not an estimate
        target = scene.target_se["lobe" if r["quantity"] in ("lobe", "lobe_transmission") else "albedo"]
        if r["se"] == 0.0:
            if r["estimate"] == 0.0 and 3.0 / (r["_n"] * r.get("_norm", 1.0)) > target:
                return False, math.inf
            continue
        worst = max(worst, r["se"] / target)
    return worst <= 1.0, worst


def _plot(result: SimulationResult, mi: int, ii: int) -> bytes | None:
    """The PNG of one job: one panel per order, the bin averages of f mu_o over (mu_o, |phi_o|), and a
    second row for the transmitted lobe (f_t |mu_o| over (|mu_o|, |phi_o|)) when it was tallied; None
    without matplotlib."""
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
    lobes = [("lobe", "mu_o", "mirror")] + (
        [("lobe_transmission", "|mu_o|, transmitted", "straight through")] if "lobe_transmission" in t else []
    )
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
    return buf.getvalue()


class MicrosurfaceWalk:
    """The microsurface walk (:mod:`.walk`) as a :class:`fitlab.scenes.Walk`: a job is a material and an
    incident direction, its key (material index, mu_i index)."""

    unit = "paths"
    min_paths = MIN_PATHS
    row_fields = ROW_FIELDS
    summary_fields = SUMMARY_FIELDS
    summary_columns = (
        ("material", "material", "<16"),
        ("mu_i", "mu_i", ">6.3g"),
        ("paths", "paths", ">11"),
        ("bounces", "bounces", ">11"),
        ("seconds", "seconds", ">9.2f"),
        ("bounce/s", "bounces_per_second", ">11.3g"),
        ("se/tgt", "worst_se_ratio", ">8.2f"),
        ("conv", "converged", ">6"),
        ("max|z|", "max_abs_z_ref", ">8.2f"),
        ("total", "albedo_total", ">10.6f"),
        ("trans", "transmission", ">10.6f"),
    )

    def jobs(self, scene: Scene) -> list:
        out = []
        for mi, mat in enumerate(scene.materials):
            cfg, params = job_config(scene, mat), job_params(mat)
            for ii, mu_i in enumerate(scene.mu_i):
                name = f"material {mat.label}, mu_i = {mu_i:g}"
                out.append(
                    scenes.Job(
                        key=(mi, ii),
                        name=name,
                        label=f"{mat.label}, mu_i={mu_i:g}",
                        data=(cfg, params, job_key(scene.seed, mi, ii)),
                    )
                )
        return out

    def compile(self, scene, job) -> float:
        return compile_walk(job.data[0])

    def run_round(self, scene, job, rounds, paths, n):
        return self.start_round(scene, job, rounds, paths, n).run()

    def start_round(self, scene, job, rounds, paths, n):
        cfg, params, key = job.data
        return start_round(cfg, key, params, scene.mu_i[job.key[1]], paths, n, scene.max_bounces)

    def count(self, tallies):
        return int(tallies["paths"]), int(tallies["bounces"])

    def failed(self, tallies) -> int:
        """The paths that ended on a non-finite height, direction or weight (the walk's ``failed`` tally)."""
        return int(tallies.get("failed", 0))

    def converged(self, scene, job, tallies):
        mi, ii = cast("tuple[int, int]", job.key)  # (material, incidence): the key jobs() gives
        return _job_done(scene, estimate_rows(scene, mi, ii, tallies))

    def finish(self, scene, jobs, tallies, stats):
        """Every job's rows (references attached, the job's statistics on each row), one summary row per job."""
        rows_all, summary = [], []
        for job in jobs:
            (mi, ii), st, acc = job.key, stats[job.key], tallies[job.key]
            rows = estimate_rows(scene, mi, ii, acc, _references(scene, mi, ii))
            for r in rows:
                r.update(paths=st.paths, bounces=st.events, seconds=round(st.seconds, 3), converged=st.converged)
            rows_all.extend(rows)
            zs = [abs(r["z_ref"]) for r in rows if math.isfinite(r["z_ref"])]
            total = next(r for r in rows if r["quantity"] == "albedo_total")
            capped = next(r for r in rows if r["quantity"] == "albedo" and r["order"] == "capped")
            trans = next(r for r in rows if r["quantity"] == "transmission" and r["order"] == "all")
            summary.append(
                dict(
                    material=scene.materials[mi].label,
                    mu_i=scene.mu_i[ii],
                    paths=st.paths,
                    bounces=st.events,
                    seconds=round(st.seconds, 3),
                    compile_seconds=round(st.compile_seconds, 3),
                    bounces_per_second=st.events / st.seconds if st.seconds > 0 else math.nan,
                    worst_se_ratio=st.se_ratio,
                    converged=st.converged,
                    max_abs_z_ref=max(zs, default=math.nan),
                    albedo_total=total["estimate"],
                    capped=capped["estimate"],
                    transmission=trans["estimate"],
                    failed=int(acc.get("failed", 0)),
                )
            )
        return rows_all, summary

    def csv_rows(self, result):
        return result.rows

    def plots(self, result):
        """<name>_<material>_<mu_i index>.png of each job (none without matplotlib)."""
        out = []
        for mi, ii in result.tallies:
            png = _plot(result, mi, ii)
            if png is not None:
                safe = "".join(ch if ch.isalnum() or ch in "_-" else "_" for ch in result.scene.materials[mi].label)
                out.append((f"{result.scene.name}_{safe}_{ii}.png", png))
        return out


def simulate(scene: Scene, progress: bool = False) -> SimulationResult:
    """Run every job of the scene (:func:`fitlab.scenes.simulate`; writes nothing); see docs/microsurface.md."""
    return scenes.simulate(SIMULATE.walk, scene, progress=progress)


def simulate_file(path, out_dir=None, progress=False, plots=True, target_se=None, max_paths=None, seed=None):
    """Load and validate (scene, overrides, output folder: every error before any work), simulate, write
    (:func:`fitlab.scenes.simulate_file`).  Returns (result, paths written)."""
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
    """Whether a parsed scene file (a dict, before any validation) that names no family is a microsurface
    walk's: its materials name a facet kind or a slope distribution.  ``fitlab simulate`` asks each family
    that simulates, for the scenes written before a scene named its family."""
    materials = raw.get("material") if isinstance(raw, dict) else None
    return isinstance(materials, list) and any(isinstance(m, dict) and ("kind" in m or "distribution" in m)
                                               for m in materials)  # fmt: skip


#: the family's Monte Carlo (``MicrofacetEnergy.simulation()``)
SIMULATE = scenes.Simulation(schema=SCHEMA, walk=MicrosurfaceWalk(), claims=claims)
