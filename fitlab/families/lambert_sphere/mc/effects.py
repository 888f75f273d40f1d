r"""Effects: which walks (jobs) and tallies each one needs, its estimates from the
tallies, and the exact values it is compared with.

A *job* is one stream of photons: a material, an incident direction (or
cosine-distributed incidence) and a phase mode.  Effects that need the same
job share its paths; each job keeps only the tallies its effects need.

=================  =========================  ==========================================
effect             job (phase mode)           tallies
=================  =========================  ==========================================
single             none (closed form)         -
multiple           fixed mu_i (scene phase)   fourier and/or bins
collisions         fixed mu_i (scene phase)   coll (+ coll_f0 when mu_o bins are given)
albedo             fixed mu_i (scene phase)   escape
phase_difference   fixed mu_i ("both")        fourier and/or bins, escape
spherical_albedo   cosine mu_i (scene phase)  escape
=================  =========================  ==========================================

Details: docs/montecarlo.md, section ``fitlab.families.lambert_sphere.mc.effects``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import numpy as np

from fitlab.core import get_form
from fitlab.families.lambert_sphere.exact import (
    albedo,
    brdf_modes,
    graded_gauss,
    multiple_scattering_modes,
    phase_function,
    single_albedo_nodes,
    single_scattering_albedo,
    spherical_albedo,
    three_term_phase_function,
    three_term_single_albedo,
)
from fitlab.families.lambert_sphere.mc.scene import Scene
from fitlab.families.lambert_sphere.mc.transport import WalkConfig

__all__ = [
    "Job",
    "plan",
    "effect_jobs",
    "estimate_rows",
    "attach_reference",
    "ROW_FIELDS",
    "eq40_kd",
    "single_spherical_albedo",
]

ROW_FIELDS = (
    "effect",
    "material",
    "c",
    "mu_i",
    "quantity",
    "mu_lo",
    "mu_hi",
    "phi_lo",
    "phi_hi",
    "m",
    "n",
    "estimate",
    "se",
    "ref",
    "ref_name",
    "z_ref",
    "alt",
    "alt_name",
    "z_alt",
    "paths",
    "collisions",
    "seconds",
    "converged",
)
_KIND_ID = {"fixed": 0, "both": 1, "cosine": 2}
_N_MU, _N_PHI = 64, 192


@dataclass(frozen=True)
class Job:
    """One photon stream: kind "fixed" (one mu_i), "both" (one mu_i, true and
    three-term weights on one path) or "cosine" (mu_i ~ 2 mu dmu)."""

    kind: str
    material: int
    incident: int = -1

    @property
    def stream(self) -> tuple:
        return (_KIND_ID[self.kind], self.material, self.incident + 1)


def effect_jobs(scene: Scene, effect: str) -> list:
    """The jobs an effect needs (none for 'single')."""
    nm, ni = len(scene.materials), len(scene.mu_i)
    if effect == "single":
        return []
    if effect in ("multiple", "collisions", "albedo"):
        return [Job("fixed", m, i) for m in range(nm) for i in range(ni)]
    if effect == "phase_difference":
        return [Job("both", m, i) for m in range(nm) for i in range(ni)]
    if effect == "spherical_albedo":
        return [Job("cosine", m) for m in range(nm)]
    raise KeyError(effect)


def plan(scene: Scene) -> dict:
    """Job -> WalkConfig with only the tallies the scene's effects need."""
    jobs = {}
    for effect in scene.effects:
        for job in effect_jobs(scene, effect):
            jobs.setdefault(job, set()).add(effect)
    out = {}
    for job, effs in jobs.items():
        common = dict(max_collisions=scene.max_collisions, slots=scene.slots, precision=scene.walk_precision)
        if job.kind == "cosine":
            cfg = WalkConfig(phase=scene.phase, sampler=scene.sampler, incidence="cosine", **common)
        elif job.kind == "both":
            cfg = WalkConfig(
                phase="both", mu_edges=scene.mu_edges, orders=scene.orders, phi_edges=scene.phi_edges, **common
            )
        else:
            directional = "multiple" in effs
            coll = "collisions" in effs
            cfg = WalkConfig(
                phase=scene.phase,
                sampler=scene.sampler,
                mu_edges=scene.mu_edges if (directional or coll) else (),
                orders=scene.orders if directional else (),
                phi_edges=scene.phi_edges if directional else (),
                collision_orders=scene.collision_orders if coll else 0,
                **common,
            )
        out[job] = cfg
    return out


# ---------------------------------------------------------------- estimates
def _mean_se(total, sq, n):
    """Mean and standard error of per-photon contributions from their sum and sum of squares."""
    total, sq = np.asarray(total, float), np.asarray(sq, float)
    mean = total / n
    var = np.maximum(sq / n - mean * mean, 0.0) * n / max(n - 1, 1)
    return mean, np.sqrt(var / n)


def _row(effect, scene, mat, mu_i, quantity, estimate, se, **kw):
    m = scene.materials[mat]
    row = dict.fromkeys(ROW_FIELDS, "")
    row.update(
        effect=effect,
        material=m.label,
        c=m.c,
        mu_i=mu_i,
        quantity=quantity,
        estimate=float(estimate),
        se=float(se),
        ref=math.nan,
        z_ref=math.nan,
        alt=math.nan,
        z_alt=math.nan,
    )
    row.update(kw)
    row["_mat"] = mat
    return row


def _mu_bins(scene):
    e = scene.mu_edges
    return list(zip(e[:-1], e[1:]))


def _phi_bins(scene):
    e = scene.phi_edges
    return list(zip(e[:-1], e[1:]))


def _directional_rows(effect, scene, mat, inc, t, track, prefix, ss_fn):
    """Rows of a Fourier/bins tally: the MS estimate, and the total with single scattering."""
    rows, n = [], t["photons"]
    mu_i = scene.mu_i[inc]
    for b, (a, bb) in enumerate(_mu_bins(scene)):
        proj = (bb * bb - a * a) / 2.0
        if "fourier" in t:
            for k, m in enumerate(scene.orders):
                norm = math.pi * (2.0 if m == 0 else 1.0) * proj
                est, se = _mean_se(t["fourier"][b, track, k], t["fourier_sq"][b, track, k], n)
                ss = ss_fn(mat, inc, b, ("m", m))
                common = dict(mu_lo=a, mu_hi=bb, m=m, _key=("m", b, m), _norm=norm)
                rows.append(_row(effect, scene, mat, mu_i, prefix + "f_ms", est / norm, se / norm, **common))
                rows.append(_row(effect, scene, mat, mu_i, prefix + "f", ss + est / norm, se / norm, **common))
        if "bins" in t:
            for j, (p, q) in enumerate(_phi_bins(scene)):
                norm = 2.0 * (q - p) * proj
                est, se = _mean_se(t["bins"][b, track, j], t["bins_sq"][b, track, j], n)
                ss = ss_fn(mat, inc, b, ("phi", j))
                common = dict(mu_lo=a, mu_hi=bb, phi_lo=p, phi_hi=q, _key=("phi", b, j), _norm=norm)
                rows.append(_row(effect, scene, mat, mu_i, prefix + "f_ms", est / norm, se / norm, **common))
                rows.append(_row(effect, scene, mat, mu_i, prefix + "f", ss + est / norm, se / norm, **common))
    return rows


def _capped_row(effect, scene, mat, mu_i, t, track=0):
    est, se = _mean_se(t["capped"][track], t["capped_sq"][track], t["photons"])
    return _row(effect, scene, mat, mu_i, "capped", est, se, n=f">{scene.max_collisions}", _diag=True)


def estimate_rows(effect: str, scene: Scene, results: dict) -> list:
    """Rows (dicts, fields ROW_FIELDS plus private keys) of one effect from the
    accumulated tallies ``results[job]``; no reference values yet (cheap: used
    by the stopping rule after every round)."""
    rows = []
    if effect == "single":
        for mat in range(len(scene.materials)):
            for inc, mu_i in enumerate(scene.mu_i):
                for b, (a, bb) in enumerate(_mu_bins(scene)):
                    for m in scene.orders:
                        v = _ss_bin(scene, mat, inc, b, ("m", m))
                        rows.append(
                            _row(effect, scene, mat, mu_i, "f_ss", v, 0.0, mu_lo=a, mu_hi=bb, m=m, _key=("m", b, m))
                        )
                    for j, (p, q) in enumerate(_phi_bins(scene)):
                        v = _ss_bin(scene, mat, inc, b, ("phi", j))
                        rows.append(
                            _row(
                                effect,
                                scene,
                                mat,
                                mu_i,
                                "f_ss",
                                v,
                                0.0,
                                mu_lo=a,
                                mu_hi=bb,
                                phi_lo=p,
                                phi_hi=q,
                                _key=("phi", b, j),
                            )
                        )
        return rows
    for job in effect_jobs(scene, effect):
        t = results.get(job)
        if t is None or t["photons"] < 2:
            continue
        mat, n = job.material, t["photons"]
        c = scene.materials[mat].c
        mu_i = scene.mu_i[job.incident] if job.incident >= 0 else math.nan
        if effect == "multiple":
            rows += _directional_rows(
                effect, scene, mat, job.incident, t, 0, "", lambda mt, i, b, key: _ss_bin(scene, mt, i, b, key)
            )
            rows.append(_capped_row(effect, scene, mat, mu_i, t))
        elif effect == "phase_difference":
            rows += _directional_rows(
                effect,
                scene,
                mat,
                job.incident,
                t,
                2,
                "d_",
                lambda mt, i, b, key: (
                    _ss_bin(scene, mt, i, b, key, "true") - _ss_bin(scene, mt, i, b, key, "three_term")
                ),
            )
            est, se = _mean_se(t["escape"][2], t["escape_sq"][2], n)
            d_ss = c * (_ss_albedo(mu_i, "true") - _ss_albedo(mu_i, "three_term"))
            rows.append(_row(effect, scene, mat, mu_i, "d_a_ms", est, se))
            rows.append(_row(effect, scene, mat, mu_i, "d_a", d_ss + est, se))
            rows.append(_capped_row(effect, scene, mat, mu_i, t, 2))
        elif effect == "collisions":
            top = scene.collision_orders
            labels = [str(k) for k in range(2, top + 1)] + [f">{top}"]
            for j, lab in enumerate(labels):
                est, se = _mean_se(t["coll"][j, 0], t["coll_sq"][j, 0], n)
                rows.append(_row(effect, scene, mat, mu_i, "a_ms_n", est, se, n=lab))
                if "coll_f0" in t:
                    for b, (a, bb) in enumerate(_mu_bins(scene)):
                        norm = math.pi * (bb * bb - a * a)
                        est, se = _mean_se(t["coll_f0"][j, b, 0], t["coll_f0_sq"][j, b, 0], n)
                        rows.append(
                            _row(
                                effect,
                                scene,
                                mat,
                                mu_i,
                                "f0_ms_n",
                                est / norm,
                                se / norm,
                                n=lab,
                                mu_lo=a,
                                mu_hi=bb,
                                m=0,
                                _norm=norm,
                            )
                        )
            est, se = _mean_se(t["escape"][0], t["escape_sq"][0], n)
            rows.append(_row(effect, scene, mat, mu_i, "a_ms", est, se, n="all"))
            rows.append(_capped_row(effect, scene, mat, mu_i, t))
        elif effect == "albedo":
            est, se = _mean_se(t["escape"][0], t["escape_sq"][0], n)
            ss = c * _ss_albedo(mu_i, scene.phase)
            rows.append(_row(effect, scene, mat, mu_i, "a_ms", est, se))
            rows.append(_row(effect, scene, mat, mu_i, "a", ss + est, se))
            rows.append(_capped_row(effect, scene, mat, mu_i, t))
        elif effect == "spherical_albedo":
            est, se = _mean_se(t["escape"][0], t["escape_sq"][0], n)
            ss = c * single_spherical_albedo(scene.phase)
            rows.append(_row(effect, scene, mat, mu_i, "kd_ms", est, se))
            rows.append(_row(effect, scene, mat, mu_i, "kd", ss + est, se))
            rows.append(_capped_row(effect, scene, mat, mu_i, t))
        for r in rows:
            if r["_mat"] == mat and r.get("_job") is None:
                r["_job"], r["_n"] = job, n
    return rows


# ------------------------------------------------------- single scattering
def _p(u, phase):

    return phase_function(u) if phase == "true" else three_term_phase_function(u)


@cache
def _ss_bin_cached(c, mu_i, a, b, key, phase, phi_bin):
    """Bin average (mu_o weighted) of c p(u)/(mu_i + mu_o): order m, or over a |phi| bin."""
    x, w = np.polynomial.legendre.leggauss(_N_MU)
    mu = a + (b - a) * (x + 1.0) / 2.0
    wmu = w * (b - a) / 2.0 * mu
    y, v = np.polynomial.legendre.leggauss(_N_PHI)
    if key[0] == "m":
        lo, hi = 0.0, math.pi
    else:
        lo, hi = phi_bin
    phi = lo + (hi - lo) * (y + 1.0) / 2.0
    vphi = v * (hi - lo) / 2.0
    s = np.sqrt((1.0 - mu_i * mu_i) * (1.0 - mu * mu))[:, None]
    u = -(mu_i * mu[:, None] + s * np.cos(phi)[None, :])
    f = c * _p(u, phase) / (mu_i + mu[:, None])
    if key[0] == "m":
        m = key[1]
        # f_m = (2 - delta_m0)/(2 pi) int_0^{2 pi} f cos(m phi) dphi, f even in phi
        per_mu = (2.0 if m else 1.0) / math.pi * (f * (np.cos(m * phi) * vphi)[None, :]).sum(1)
    else:
        per_mu = (f * vphi[None, :]).sum(1) / (hi - lo)
    return float((per_mu * wmu).sum() / wmu.sum())


def _ss_bin(scene, mat, inc, b, key, phase=None):
    a, bb = scene.mu_edges[b], scene.mu_edges[b + 1]
    phi_bin = scene.phi_edges[key[1] : key[1] + 2] if key[0] == "phi" else None
    return _ss_bin_cached(
        scene.materials[mat].c, scene.mu_i[inc], a, bb, key, phase or scene.phase, tuple(phi_bin) if phi_bin else None
    )


@cache
def _ss_albedo(mu_i, phase):
    """Single-scattering directional albedo per unit c (fitlab.families.lambert_sphere.exact, adaptive quadrature)."""

    return float(single_scattering_albedo(mu_i, "true" if phase == "true" else "three_term"))


@cache
def single_spherical_albedo(phase):
    """2 int a1(mu) mu dmu per unit c (single scattering's share of kd), on the exact engine's graded rule."""

    v, w = graded_gauss(8, 0.25, 1e-14)
    a1 = single_albedo_nodes("true") if phase == "true" else three_term_single_albedo(np.asarray(v))
    return float(2.0 * np.dot(w * v, a1))


# ----------------------------------------------------------- references
def eq40_kd(c):
    """Published eq. 40, kd(c): the ``printed`` form of kd_of_c with its ``paper`` preset."""

    return float(get_form("kd_of_c", "printed")("paper", np.asarray(float(c))))


@cache
def _exact_modes_bin(c, mu_i, a, b, multiple_only, phase="three_term"):
    """mu_o-weighted bin averages of the exact modes: the three-term half space's (f0, f1, f2; multiple
    scattering only, or with its single scattering), or the true half space's multiple-scattering orders (every
    order the true-phase engine keeps at this c; the others are below its order tolerance)."""

    x, w = np.polynomial.legendre.leggauss(_N_MU)
    mu = a + (b - a) * (x + 1.0) / 2.0
    wmu = w * (b - a) / 2.0 * mu
    mu_in = np.full_like(mu, mu_i)
    if phase == "true":
        modes = np.array(multiple_scattering_modes(mu_in, mu, c, phase="true"))
    else:
        modes = np.array((multiple_scattering_modes if multiple_only else brdf_modes)(mu_in, mu, c, phase="three_term"))
    return tuple(float(v) for v in modes @ wmu / wmu.sum())


def _exact_directional(c, mu_i, row, key, scene, multiple_only, phase="three_term"):
    """Exact value of a Fourier/bins row: the three-term half space (orders > 2 vanish exactly; with
    ``multiple_only`` False, its single scattering too) or the true one's multiple scattering."""
    modes = _exact_modes_bin(c, mu_i, row["mu_lo"], row["mu_hi"], multiple_only or phase == "true", phase)
    if key[0] == "m":
        m = key[2]
        return modes[m] if m < len(modes) else 0.0
    p, q = row["phi_lo"], row["phi_hi"]
    avg = [1.0] + [(math.sin(m * q) - math.sin(m * p)) / (m * (q - p)) for m in range(1, len(modes))]
    return float(sum(f * g for f, g in zip(modes, avg)))


def attach_reference(effect: str, scene: Scene, rows: list) -> list:
    """Fill ref/ref_name/z_ref and alt/alt_name/z_alt of the rows (uses the exact engine)."""

    three = scene.phase == "three_term"
    model = "exact three-term half space" if three else "exact true-phase half space (exact.true_phase)"
    mixed = "mixed reference (true SS + three-term MS)"
    for r in rows:
        if r.get("_diag"):
            continue
        c, mu_i, q = r["c"], r["mu_i"], r["quantity"]
        ref = alt = math.nan
        alt_name = ""
        key = r.get("_key")
        if effect == "single":
            ref, r["ref_name"] = r["estimate"], "closed form eq. 10 (quadrature)"
            if key[0] == "m" and key[2] == 1 and three:
                alt, alt_name = r["estimate"] / 2.0, "printed eq. 28 (384 pi)"
        elif effect == "multiple":
            ms = q == "f_ms"
            if three:
                ref = _exact_directional(c, mu_i, r, key, scene, ms)
                r["ref_name"] = model
                if key[0] == "m" and key[2] == 1:
                    # printed f1 (6 pi) is half the exact f1; printed fm1 = f1/2 - f1_ss/2 (eq. 28, 384 pi)
                    alt = ref / 2.0
                    alt_name = "printed eq. 22 (6 pi)" if not ms else "printed eqs. 22 - 28 (6 pi, 384 pi)"
            else:
                # the true half space; alt: the mixed reference, its multiple scattering three-term
                ss = 0.0 if ms else _ss_bin_from_row(scene, r)
                ref = ss + _exact_directional(c, mu_i, r, key, scene, True, "true")
                alt = ss + _exact_directional(c, mu_i, r, key, scene, True)
                r["ref_name"] = model
                alt_name = mixed if not ms else "three-term multiple scattering"
        elif effect == "phase_difference" and key is not None:
            # true minus three-term, both exact; the single-scattering difference is the rows' closed form
            ss = 0.0 if q == "d_f_ms" else _ss_bin_from_row(scene, r, "true") - _ss_bin_from_row(scene, r, "three_term")
            ref = ss + (
                _exact_directional(c, mu_i, r, key, scene, True, "true")
                - _exact_directional(c, mu_i, r, key, scene, True)
            )
            r["ref_name"] = "exact true minus exact three-term half space"
        elif effect == "phase_difference":
            ref = float(albedo(mu_i, c, phase="true")) - float(albedo(mu_i, c, phase="three_term"))
            if q == "d_a_ms":
                ref -= c * (_ss_albedo(mu_i, "true") - _ss_albedo(mu_i, "three_term"))
            r["ref_name"] = "exact true minus exact three-term half space"
        elif effect == "albedo":
            a_ref = float(albedo(mu_i, c, phase=scene.phase))
            ss = c * _ss_albedo(mu_i, scene.phase)
            ref = a_ref if q == "a" else a_ref - ss
            r["ref_name"] = model
            if not three:
                a_mixed = float(albedo(mu_i, c, phase="mixed"))
                alt, alt_name = (a_mixed if q == "a" else a_mixed - ss), mixed
        elif effect == "spherical_albedo":
            k_ref = float(spherical_albedo(c, phase=scene.phase))
            ss = c * single_spherical_albedo(scene.phase)
            ref = k_ref if q == "kd" else k_ref - ss
            r["ref_name"] = model
            if q == "kd":
                alt, alt_name = eq40_kd(c), "published eq. 40"
        elif effect == "collisions" and q == "a_ms" and three:
            ref = float(albedo(mu_i, c, phase="three_term")) - c * _ss_albedo(mu_i, "three_term")
            r["ref_name"] = model + " (sum of all orders)"
        r["ref"], r["alt"], r["alt_name"] = ref, alt, alt_name
        se = r["se"]
        if se > 0:
            r["z_ref"] = (r["estimate"] - ref) / se if math.isfinite(ref) else math.nan
            r["z_alt"] = (r["estimate"] - alt) / se if math.isfinite(alt) else math.nan
    return rows


def _ss_bin_from_row(scene, r, phase=None):
    """The single-scattering part of a directional row, with ``phase``'s phase function (default the scene's)."""
    mat, inc = r["_mat"], scene.mu_i.index(r["mu_i"])
    b = scene.mu_edges.index(r["mu_lo"])
    key = r["_key"]
    return _ss_bin(scene, mat, inc, b, (key[0], key[2]), phase)
