r"""The exact engine as an evaluation method of ``fitlab report``: its cost, its error, and time to reach an error.

* H-functions, both methods of :func:`fitlab.families.lambert_sphere.exact.h_function` at coarser and
  finer resolution: Nystrom/Newton ("chandrasekhar") with n nodes per graded
  panel, and the Fock/Krein integral with trapezoidal step h.  Each is measured
  against the *other* method at its default resolution (16 nodes, h = 0.1),
  which it shares nothing with but the characteristic function; the error
  therefore bottoms out at their mutual agreement (~1e-13).  The time is one
  solve plus the evaluation at the mu points, per (order, c), uncached.
* The BRDF (:func:`fitlab.families.lambert_sphere.exact.brdf`, the whole phase function): seconds of the
  set-up at a new c (the Fourier orders of the half space, :mod:`...exact.true_phase`) and then ns per point.
* Its error (:func:`engine_agreement`): its two methods, Newton on the Riccati equation and doubling-adding,
  Fourier orders 0-2 of the multiple scattering at points with mu_i, mu_o >= 1e-3, each order's difference
  relative to the whole BRDF at the point (phi = 0 and pi): max and RMS.
* The three-term engine (the paper's model, :func:`doubling_agreement`): the H route against the
  independent discrete ordinates + doubling (:func:`fitlab.families.lambert_sphere.exact.doubling_reflection`)
  at the doubling rule's node pairs with mu_i, mu_o >= 1e-3, Fourier orders 0-2: max and RMS relative
  difference.
"""

from __future__ import annotations

import itertools
import time

import numpy as np

from fitlab.families.lambert_sphere.exact import (
    brdf,
    brdf_modes,
    doubling_reflection,
    h_fock,
    lambert_sphere_characteristic,
    solve_h,
    solve_h_uncached,
    true_phase,
)
from fitlab.timing import best_seconds

__all__ = ["h_convergence", "exact_brdf_cost", "doubling_agreement", "engine_agreement", "time_to_error"]

_FRESH = itertools.count()


def _nystrom(char, n: int, mu):
    """H at mu from a fresh (uncached) Nystrom solve with n nodes per panel."""
    return solve_h_uncached(char, n, 0.25)(mu)


def h_convergence(orders, albedos, mu_points: int, nodes, steps, repeat: int = 2, tick=None) -> list[dict]:
    """One row per (method, resolution): max and RMS relative error against the other method, seconds per
    (order, c) (mean over them, each the best of ``repeat``)."""
    mu = (np.arange(mu_points) + 0.5) / mu_points
    cases = [(m, c, lambert_sphere_characteristic(m, c)) for m in orders for c in albedos]
    ref_fock = {(m, c): h_fock(ch, mu) for m, c, ch in cases}
    ref_nys = {(m, c): solve_h(ch)(mu) for m, c, ch in cases}
    settings = [("Nystrom", f"{n} nodes/panel", lambda ch, n=n: _nystrom(ch, n, mu), ref_fock) for n in nodes]
    settings += [("Fock", f"h = {h:g}", lambda ch, h=h: h_fock(ch, mu, h=h), ref_nys) for h in steps]
    rows = []
    for method, resolution, f, ref in settings:
        errs, secs = [], []
        for m, c, ch in cases:
            errs.append(np.abs(f(ch) / ref[(m, c)] - 1.0))
            secs.append(best_seconds(lambda f=f, ch=ch: f(ch), repeat))
        e = np.concatenate(errs)
        rows.append({"method": method, "resolution": resolution, "max_rel": float(e.max()),
                     "rms_rel": float(np.sqrt(np.mean(e**2))), "seconds": float(np.mean(secs)),
                     "points": int(e.size)})  # fmt: skip
        if tick:
            tick()
    return rows


def exact_brdf_cost(inputs: dict, repeat: int, points: int = 8192) -> dict:
    """Set-up seconds at a c not seen before in this process, then ns per point (best of ``repeat``, on the
    first ``points`` inputs, not all of the numpy methods' inputs: the engine takes about a millisecond a point).
    Each call also pays a cost per Fourier order that does not grow with the points (the Nystrom rows at the
    interpolation points), so fewer points give a higher figure per point; the result states how many."""
    c = 0.7 - 1e-9 * next(_FRESH)  # s > 1/2: no continuation ladder; fresh, so nothing is cached
    mi, mo, ph = (inputs[k][:points] for k in ("mu_i", "mu_o", "phi"))
    t0 = time.perf_counter()
    brdf(mi[:1], mo[:1], ph[:1], c)
    setup = time.perf_counter() - t0
    warm = best_seconds(lambda: brdf(mi, mo, ph, c), repeat)
    return {"setup_seconds": setup, "ns_per_point": warm / mi.size * 1e9, "c": c, "points": int(mi.size)}


def engine_agreement(c: float, orders, points: int = 24) -> dict:
    """The exact engine's two methods (:mod:`...exact.true_phase`: Newton and doubling) at ``points`` x
    ``points`` cosines (Gauss-Legendre on [1e-3, 1]): max and RMS over the orders of |fm_m(newton) -
    fm_m(doubling)| / min(|f(phi = 0)|, |f(phi = pi)|), and the doubling method's seconds per order
    (its solve, uncached)."""
    x, _ = np.polynomial.legendre.leggauss(points)
    mu = 1e-3 + (1.0 - 1e-3) * (x + 1.0) / 2.0
    mi, mo = (a.ravel() for a in np.meshgrid(mu, mu, indexing="ij"))
    f = np.minimum(*(np.abs(brdf(mi, mo, phi, c)) for phi in (0.0, np.pi)))
    n = max(orders) + 1
    true_phase.clear_cache()
    t0 = time.perf_counter()
    dbl = true_phase.multiple_scattering_orders(mi, mo, c, method="doubling", orders=n)
    seconds = (time.perf_counter() - t0) / n
    new = true_phase.multiple_scattering_orders(mi, mo, c, method="newton", orders=n)
    e = np.concatenate([np.abs(new[m] - dbl[m]) / f for m in orders])
    return {
        "max_rel": float(e.max()),
        "rms_rel": float(np.sqrt(np.mean(e**2))),
        "points": int(e.size),
        "seconds_per_order": seconds,
        "node_pairs": int(mi.size),
        "c": c,
        "orders": tuple(orders),
    }


def doubling_agreement(c: float, orders) -> dict:
    """The three-term engine (the paper's model): the H route (brdf_modes) against discrete ordinates +
    doubling at node pairs with mu >= 1e-3."""
    errs, secs, pairs = [], [], 0
    for m in orders:
        t0 = time.perf_counter()
        d = doubling_reflection.__wrapped__(m, c)
        secs.append(time.perf_counter() - t0)
        mi, mo = np.meshgrid(d.nodes, d.nodes, indexing="ij")
        keep = (mi >= 1e-3) & (mo >= 1e-3)
        ref = brdf_modes(mi[keep], mo[keep], c, phase="three_term")[m]
        errs.append(np.abs(d.brdf[keep] - ref) / np.abs(ref))
        pairs = d.nodes.size**2
    e = np.concatenate(errs)
    return {
        "max_rel": float(e.max()),
        "rms_rel": float(np.sqrt(np.mean(e**2))),
        "points": int(e.size),
        "seconds_per_order": float(np.mean(secs)),
        "node_pairs": pairs,
        "c": c,
        "orders": tuple(orders),
    }


def time_to_error(rows: list[dict], targets) -> list[dict]:
    """Per method and target error: the coarsest resolution (rows run coarse to fine) whose max error is
    within the target, and its seconds; chosen by error, not by time, so the choice is reproducible."""
    out = []
    for method in dict.fromkeys(r["method"] for r in rows):
        for eps in targets:
            best = next((r for r in rows if r["method"] == method and r["max_rel"] <= eps), None)
            out.append({"method": method, "target": eps, "resolution": best["resolution"] if best else "not reached",
                        "max_rel": best["max_rel"] if best else float("nan"),
                        "seconds": best["seconds"] if best else float("nan")})  # fmt: skip
    return out
