"""Measure the figures docs/derivation.md quotes for the true-phase engine.

    python tools/true_phase_figures.py methods  C [C ...]    # Newton vs doubling, full degree (~5 min per c)
    python tools/true_phase_figures.py degree   C            # truncation: L = 64 .. 256 against each other
    python tools/true_phase_figures.py cost     C [C ...]    # seconds per c (Newton, all orders, cold cache)
    python tools/true_phase_figures.py gap      C [C ...]    # true vs mixed, mu in [0.01, 1], phi in [0, pi]
    python tools/true_phase_figures.py albedo                # directional albedo at c = 1
    python tools/true_phase_figures.py kd       C [C ...]    # spherical albedo of each phase, and eq. 40's
    python tools/true_phase_figures.py ms_gap   C [C ...]    # the mixed reference's multiple scattering vs true
    python tools/true_phase_figures.py runtime  C [C ...]    # the shipped runtime model vs mixed and vs true
    python tools/true_phase_figures.py report_cost           # the report's three validation sets with phase="true"

Run with one BLAS thread (OPENBLAS_NUM_THREADS=1) on a shared machine; prints plain text.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.exact import true_phase as tp

GRAZING = np.array([0.0, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.8, 1.0])


def _grid(mu):
    mi, mo = (a.ravel() for a in np.meshgrid(mu, mu, indexing="ij"))
    ok = (mi + mo) > 0
    return mi[ok], mo[ok]


def methods(cs):
    mi, mo = _grid(GRAZING)
    for c in cs:
        t0 = time.perf_counter()
        m = tp.needed_orders(c)
        a = tp.multiple_scattering_orders(mi, mo, c, method="newton", orders=m)
        t1 = time.perf_counter()
        b = tp.multiple_scattering_orders(mi, mo, c, method="doubling", orders=m)
        t2 = time.perf_counter()
        f = exact.brdf(mi, mo, np.pi, c, phase="mixed")
        d = sum(np.abs(x - y) for x, y in zip(a, b))  # bounds the difference at every phi
        print(
            f"c = {c}: {m} orders; max sum_m |newton - doubling| / f = {np.max(d / f):.2e} "
            f"(newton {t1 - t0:.0f} s, doubling {t2 - t1:.0f} s)",
            flush=True,
        )


def degree(c, degrees=(64, 96, 128, 192, 256)):
    mu = np.array([0.0, 1e-6, 1e-3, 0.01, 0.1, 0.5, 1.0])
    mi, mo = _grid(mu)
    phi = np.array([0.0, np.pi / 2, np.pi])[:, None]
    f = exact.brdf(mi, mo, phi, c, phase="mixed")
    vals = {}
    for L in degrees:
        t0 = time.perf_counter()
        vals[L] = tp.multiple_scattering_sum(mi, mo, phi, c, degree=L)
        print(
            f"L = {L}: {tp.needed_orders(c, degree=L)} orders, {tp.solve_order(0, c, degree=L).nodes.size} nodes, "
            f"{time.perf_counter() - t0:.0f} s",
            flush=True,
        )
    top = degrees[-1]
    for L in degrees[:-1]:
        d = np.abs(vals[L] - vals[top]) / f
        g = mi.reshape(1, -1).repeat(3, 0) + mo.reshape(1, -1).repeat(3, 0)
        print(
            f"|ms(L={L}) - ms(L={top})| / f: max {d.max():.2e}, max over mu_i + mu_o >= 0.02: "
            f"{d[g >= 0.02].max():.2e}, over mu_i, mu_o >= 0.1: "
            f"{d[(np.minimum(mi, mo) >= 0.1)[None, :].repeat(3, 0)].max():.2e}",
            flush=True,
        )


def cost(cs):
    for c in cs:
        tp.clear_cache()
        t0 = time.perf_counter()
        m = tp.needed_orders(c)
        t1 = time.perf_counter()
        mu = np.linspace(0.0, 1.0, 33)
        mi, mo = (a.ravel() for a in np.meshgrid(mu, mu, indexing="ij"))
        exact.brdf(mi, mo, 1.0, c, phase="true")
        t2 = time.perf_counter()
        print(f"c = {c}: solve {m} orders {t1 - t0:.1f} s, then a 33 x 33 table {t2 - t1:.1f} s", flush=True)


def _gap_grid(smallest=(0.01,)):
    """(mu_i, mu_o, phi) flat over mu in ``smallest`` and {0.05, 0.1, ..., 1}, squared, x 13 phi in [0, pi]."""
    mu = np.concatenate((smallest, np.linspace(0.05, 1.0, 20)))
    phi = np.linspace(0.0, np.pi, 13)
    return tuple(a.ravel() for a in np.meshgrid(mu, mu, phi, indexing="ij"))


def gap(cs):
    mi, mo, ph = _gap_grid()
    for c in cs:
        t = exact.brdf(mi, mo, ph, c, phase="true")
        m = exact.brdf(mi, mo, ph, c, phase="mixed")
        t3 = exact.brdf(mi, mo, ph, c, phase="three_term")
        r = (m - t) / t
        r3 = (t3 - t) / t
        k = int(np.argmax(np.abs(r)))
        big = np.minimum(mi, mo) >= 0.2
        print(
            f"c = {c}: mixed vs true max {np.max(np.abs(r)):.2e} at (mu_i, mu_o, phi) = "
            f"({mi[k]:.2f}, {mo[k]:.2f}, {ph[k]:.2f}), RMS {np.sqrt(np.mean(r * r)):.2e}, "
            f"max for mu >= 0.2 {np.max(np.abs(r[big])):.2e}; three_term vs true max {np.max(np.abs(r3)):.2e}, "
            f"RMS {np.sqrt(np.mean(r3 * r3)):.2e}",
            flush=True,
        )
        if c == 1.0:
            at = (0.01, 0.01, np.pi, 1.0)
            print(
                f"  mu_i = mu_o = 0.01, phi = pi: true {float(exact.brdf(*at, phase='true')):.6f}, "
                f"mixed {float(exact.brdf(*at, phase='mixed')):.6f}",
                flush=True,
            )


def albedo():
    mu = np.array([0.0, 1e-9, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0])
    a = exact.albedo(mu, 1.0, phase="true")
    print(f"c = 1: max |a(mu_i) - 1| over {mu.size} mu_i in [0, 1] = {np.max(np.abs(a - 1)):.2e}")
    print("  " + ", ".join(f"{x:g}: {y - 1:.1e}" for x, y in zip(mu, a)))
    print(f"c = 1: |spherical albedo - 1| = {abs(float(exact.spherical_albedo(1.0, phase='true')) - 1):.2e}")
    for phase in ("mixed", "three_term"):
        b = exact.albedo(mu, 1.0, phase=phase)
        print(f"  phase {phase}: a(mu_i) at c = 1 in [{b.min():.7f}, {b.max():.7f}]")


def ms_gap(cs):
    """The three-term multiple scattering of the mixed reference against the true one, on gap's grid:
    relative to the true multiple scattering (max, where, median) and absolute (1/sr)."""
    mi, mo, ph = _gap_grid()
    u = -(mi * mo + np.sqrt((1 - mi**2) * (1 - mo**2)) * np.cos(ph))
    for c in cs:
        t = exact.brdf(mi, mo, ph, c, phase="true")
        d = exact.brdf(mi, mo, ph, c, phase="mixed") - t  # same single scattering: the multiple's difference
        ms_true = t - c * exact.phase_function(u) / (mi + mo)
        r = np.abs(d) / ms_true
        k, ka = int(np.argmax(r)), int(np.argmax(np.abs(d)))
        print(
            f"c = {c}: multiple scattering relative max {r.max():.2e} at ({mi[k]:.2f}, {mo[k]:.2f}, {ph[k]:.2f}), "
            f"median {np.median(r):.1e}; absolute max {np.abs(d).max():.2e} 1/sr at ({mi[ka]:.2f}, {mo[ka]:.2f}, "
            f"{ph[ka]:.2f}), for mu >= 0.2 {np.abs(d[np.minimum(mi, mo) >= 0.2]).max():.1e}",
            flush=True,
        )


def runtime(cs):
    """The runtime model fitlab codegen prints (runtime_model(), packaged fits) against the mixed reference
    and against the true BRDF, relative, on gap's grid with mu from 0.01 (the runtime model's stated domain
    for its BRDF figures) and with mu_i, mu_o >= 0.2."""
    from fitlab.families.lambert_sphere.program.runtime import runtime_model

    model = runtime_model()
    mi, mo, ph = _gap_grid(smallest=(0.01, 0.02, 0.03))
    big = np.minimum(mi, mo) >= 0.2
    for c in cs:
        f = model(mi, mo, ph, c)
        row = []
        for phase in ("mixed", "true"):
            ref = exact.brdf(mi, mo, ph, c, phase=phase)
            r = (f - ref) / ref
            k = int(np.argmax(np.abs(r)))
            row.append(
                f"vs {phase}: max {np.max(np.abs(r)):.2e} at ({mi[k]:.2f}, {mo[k]:.2f}, {ph[k]:.2f}), "
                f"RMS {np.sqrt(np.mean(r * r)):.2e}, max for mu >= 0.2 {np.max(np.abs(r[big])):.2e}"
            )
        print(f"c = {c}: " + "; ".join(row), flush=True)


def kd(cs):
    from fitlab.families.lambert_sphere.mc.effects import eq40_kd as kd_of_c_eq40

    print("| c | eq. 40 | kd three_term | kd mixed | kd true | true - three_term | true - mixed | eq. 40 - true |")
    print("|---|---|---|---|---|---|---|---|")
    for c in cs:
        k = {p: float(exact.spherical_albedo(c, phase=p)) for p in ("three_term", "mixed", "true")}
        e = float(kd_of_c_eq40(c))
        print(
            f"| {c:g} | {e:.6f} | {k['three_term']:.6f} | {k['mixed']:.6f} | {k['true']:.6f} | "
            f"{k['true'] - k['three_term']:.2e} | {k['true'] - k['mixed']:.2e} | {e - k['true']:.1e} |",
            flush=True,
        )


def report_cost():
    """Seconds to evaluate the true BRDF at the points of the report's full validation sets (the Sobol set and
    the grazing set share their albedos and are evaluated in one call per c; the independent set has its own
    albedos and points), cold cache, nothing written."""
    from fitlab.families.lambert_sphere.program.report.materials import albedos
    from fitlab.families.lambert_sphere.program.report.settings import REPORT_SETTINGS
    from fitlab.report.settings import FULL
    from fitlab.report.validation import GRAZING_MU, GRAZING_PHI, sobol_points

    fam = REPORT_SETTINGS["full"]

    points = sobol_points(FULL.log2_points, FULL.seed)
    gi, go, gp = (a.ravel() for a in np.meshgrid(GRAZING_MU, GRAZING_MU, GRAZING_PHI, indexing="ij"))
    mi, mo, ph = (
        np.concatenate((points[:, 0], gi)),
        np.concatenate((points[:, 1], go)),
        np.concatenate((np.pi * points[:, 2], gp)),
    )
    cs = albedos(fam.n_c, fam.with_c1, fam.small_c)
    rng = np.random.default_rng(FULL.fresh_seed)
    fresh_c = rng.uniform(0.0, 1.0, fam.fresh_c)
    per_c = -(-FULL.fresh_points // fam.fresh_c)
    fresh = rng.uniform(0.0, 1.0, (fam.fresh_c, per_c, 3))
    tp.clear_cache()
    t0 = time.perf_counter()
    for c in cs:
        exact.brdf(mi, mo, ph, c, phase="true")
    t1 = time.perf_counter()
    print(f"Sobol + grazing sets: {cs.size} albedos x {mi.size} points in {t1 - t0:.0f} s", flush=True)
    for c, p in zip(fresh_c, fresh):
        exact.brdf(p[:, 0], p[:, 1], np.pi * p[:, 2], c, phase="true")
    t2 = time.perf_counter()
    print(
        f"independent set: {fresh_c.size} albedos x {per_c} points in {t2 - t1:.0f} s; all three {t2 - t0:.0f} s",
        flush=True,
    )


if __name__ == "__main__":
    what, args = sys.argv[1], [float(x) for x in sys.argv[2:]]
    {
        "methods": lambda: methods(args),
        "degree": lambda: degree(args[0]),
        "cost": lambda: cost(args),
        "gap": lambda: gap(args),
        "albedo": albedo,
        "kd": lambda: kd(args),
        "ms_gap": lambda: ms_gap(args),
        "runtime": lambda: runtime(args),
        "report_cost": report_cost,
    }[what]()
