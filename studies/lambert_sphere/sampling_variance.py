r"""The runtime sampler measured: the variance of the one-sample albedo estimator against cosine sampling.

The generated ``sample``/``pdf`` routines draw from the mixture of
:mod:`fitlab.families.lambert_sphere.exact.sampling` with the fitted weight and exponent (the targets
``sample_weight`` and ``sample_exponent``).  For an incidence mu_i and albedo c, the estimator
f_r cos(theta_o) / p of the directional albedo has the relative variance V (``relative_variance``); this
module compares V of the fitted mixture with cosine sampling (w = 0) and with the variance-optimal mixture,
two ways:

* quadrature (:func:`variance_rows`): V with the exact BRDF, at the study's points (c in {0.3, 0.9, 1},
  mu_i in {0.1, 0.5, 1}) and on a fresh random set (:func:`fresh_summary`: uniform c and s, the edges
  c = 0 and mu_i in {0, 1} included; seeded);
* Monte Carlo (:func:`monte_carlo_rows`): the generated Python routines themselves, ``n`` samples of each
  strategy with the runtime BRDF: the sample variance of the estimator, its mean against the exact albedo,
  and the fraction of lost samples (directions below the surface).

``python -m studies.lambert_sphere.sampling_variance --out docs`` writes docs/sampling.md and .json.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from fitlab._io import atomic_write_many
from fitlab.core import get_target
from fitlab.families.lambert_sphere.exact import albedo
from fitlab.families.lambert_sphere.exact.sampling import MU_MIN, optimal_mixture, relative_variance
from fitlab.families.lambert_sphere.program.spec import SAMPLER
from fitlab.store import fit_path, load

__all__ = ["ISSUE_C", "ISSUE_MU", "fitted_mixture", "variance_rows", "fresh_summary", "monte_carlo_rows"]

#: the study's points: albedos and incidences
ISSUE_C = (0.3, 0.9, 1.0)
ISSUE_MU = (0.1, 0.5, 1.0)


def fitted_mixture(fits_dir: Path):
    """(w, n) of the fits in ``fits_dir`` (each target's default form, as the generated code takes them) as a
    function of (mu_i, c) (numpy arrays)."""
    weight, exponent = (load(fit_path(Path(fits_dir), t, get_target(t).default_form)) for t in SAMPLER)

    def mixture(mu_i, c):
        mu_i, c = np.broadcast_arrays(np.asarray(mu_i, dtype=float), np.asarray(c, dtype=float))
        return weight(mu_i=mu_i, c=c), exponent(mu_i=mu_i, c=c)

    return mixture


def variance_rows(fits_dir: Path, c_values=ISSUE_C, mu_values=ISSUE_MU) -> list[dict]:
    """By quadrature, for every (c, mu_i): V of cosine sampling, of the fitted mixture and of the optimal one."""
    mixture, rows = fitted_mixture(fits_dir), []
    mu = np.asarray(mu_values, dtype=float)
    for c in c_values:
        w, n = mixture(mu, c)
        fitted = relative_variance(mu, c, w, n)
        cosine = relative_variance(mu, c, 0.0, 1.0)
        best = optimal_mixture(mu, c)["relvar_optimal"]
        for k, m in enumerate(mu):
            rows.append({"c": float(c), "mu_i": float(m), "weight": float(w[k]), "exponent": float(n[k]),
                         "relvar_cosine": float(cosine[k]), "relvar_fitted": float(fitted[k]),
                         "relvar_optimal": float(best[k]), "ratio": float(fitted[k] / cosine[k])})  # fmt: skip
    return rows


def fresh_summary(fits_dir: Path, seed: int = 20261202, n_c: int = 8, n_mu: int = 12) -> dict:
    """Over a fresh set (``n_c`` albedos uniform in c and as many uniform in s = sqrt(1 - c), plus 0, 1e-4 and 1;
    for each ``n_mu`` incidences uniform in [MU_MIN, 1] plus MU_MIN = 1e-3, 2e-3, 1 - 1e-6 and 1: the sampler's
    domain, exact.sampling): the largest and the mean ratio V_fitted / V_cosine, and the largest excess
    V_fitted / V_optimal - 1 where V_optimal > 1e-3."""
    rng = np.random.default_rng(seed)
    c_values = np.concatenate(([0.0, 1e-4, 1.0], rng.uniform(0, 1, n_c), 1.0 - rng.uniform(0, 1, n_c) ** 2))
    mixture = fitted_mixture(fits_dir)
    ratios, excess = [], []
    for c in c_values:
        mu = np.concatenate(([MU_MIN, 2e-3, 1.0 - 1e-6, 1.0], rng.uniform(MU_MIN, 1, n_mu)))
        w, n = mixture(mu, c)
        fitted = relative_variance(mu, c, w, n)
        ratios.append(fitted / relative_variance(mu, c, 0.0, 1.0))
        best = optimal_mixture(mu, c)["relvar_optimal"]
        keep = best > 1e-3
        excess.append(fitted[keep] / best[keep] - 1.0)
    ratios, excess = np.concatenate(ratios), np.concatenate(excess)
    return {"points": int(ratios.size), "seed": seed, "ratio_max": float(ratios.max()), "ratio_mean": float(ratios.mean()),
            "excess_over_optimal_max": float(excess.max())}  # fmt: skip


def monte_carlo_rows(module, n: int = 200_000, seed: int = 19, c_values=ISSUE_C, mu_values=ISSUE_MU) -> list[dict]:
    """The generated Python ``module`` (lambert_sphere.py) sampled: for every (c, mu_i), ``n`` directions by its
    ``sample`` and ``n`` cosine-weighted, each weighted f_r cos(theta_o) / pdf with its ``eval_local``: mean and
    relative sample variance of both, the exact albedo, and the fraction of lost samples (pdf 0)."""
    rng, rows = np.random.default_rng(seed), []
    for c in c_values:
        material = module.prepare_c(c)
        for mu in mu_values:
            wi = np.array([np.sqrt(1.0 - mu * mu), 0.0, mu])
            u1, u2 = rng.random(n), rng.random(n)
            wo, pdf = module.sample(material, wi, u1, u2)
            lost = pdf <= 0.0
            weight = np.where(lost, 0.0, module.eval_local(material, wi, wo) * wo[:, 2] / np.where(lost, 1.0, pdf))
            r, phi = np.sqrt(u1), 2.0 * np.pi * u2  # cosine sampling from the same numbers
            cosine_wo = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u1)], axis=-1)
            cosine = module.eval_local(material, wi, cosine_wo) * np.pi
            rows.append({"c": float(c), "mu_i": float(mu), "samples": n, "mean_fitted": float(weight.mean()),
                         "mean_cosine": float(cosine.mean()), "albedo_exact": float(albedo(mu, c)),
                         "relvar_fitted": float(weight.var() / weight.mean() ** 2),
                         "relvar_cosine": float(cosine.var() / cosine.mean() ** 2), "lost": float(lost.mean())})  # fmt: skip
    return rows


def _markdown(rows, fresh, mc, command: str) -> str:
    out = ["# Importance sampling of the runtime BRDF", "",
           f"Generated by `{command}` (studies.lambert_sphere.sampling_variance); do not edit, regenerate.", "",
           "V is the relative variance of the one-sample estimator f_r cos(theta_o) / p of the directional albedo "
           "(docs/model.md, 'Importance sampling'). By quadrature with the exact BRDF:", "",
           "| c | mu_i | w | n | V cosine | V fitted | V optimal | fitted / cosine |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        out.append(
            f"| {r['c']:g} | {r['mu_i']:g} | {r['weight']:.3f} | {r['exponent']:.2f} | {r['relvar_cosine']:.4g} | "
            f"{r['relvar_fitted']:.4g} | {r['relvar_optimal']:.4g} | {r['ratio']:.3f} |"
        )
    out += ["", f"On a fresh set of {fresh['points']} points (seed {fresh['seed']}; c = 0, 1e-4 and 1, mu_i = 1e-3, 2e-3, "
                f"1 - 1e-6 and 1 among them): V fitted / V cosine is at most {fresh['ratio_max']:.3f} (mean "
                f"{fresh['ratio_mean']:.3f}), and the fitted mixture's V exceeds the optimal one's by at most "
                f"{100 * fresh['excess_over_optimal_max']:.2f} % (where V optimal > 1e-3).", "",
            "By Monte Carlo, the generated Python `sample` and `eval_local` (the runtime BRDF), "
            f"{mc[0]['samples']} samples per strategy (same uniform numbers):", "",
            "| c | mu_i | mean, fitted | mean, cosine | exact albedo | V fitted | V cosine | lost |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for r in mc:
        out.append(
            f"| {r['c']:g} | {r['mu_i']:g} | {r['mean_fitted']:.5f} | {r['mean_cosine']:.5f} | {r['albedo_exact']:.5f} | "
            f"{r['relvar_fitted']:.4g} | {r['relvar_cosine']:.4g} | {r['lost']:.4f} |"
        )
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m studies.lambert_sphere.sampling_variance", description=(__doc__ or "").partition("\n")[0]
    )
    p.add_argument("--fits", default=None, help="fits folder (default: the packaged fits)")
    p.add_argument("--out", default="docs", help="folder for sampling.md and sampling.json (default: docs)")
    args = p.parse_args(argv)
    from fitlab.families.lambert_sphere.mitsuba.render import load_generated
    from fitlab.resources import packaged_fits

    fits = Path(args.fits) if args.fits else packaged_fits()
    rows = variance_rows(fits)
    fresh = fresh_summary(fits)
    mc = monte_carlo_rows(load_generated(fits / "generated" / "lambert_sphere.py"))
    command = "python -m studies.lambert_sphere.sampling_variance --out " + args.out
    text = _markdown(rows, fresh, mc, command)
    out = Path(args.out)
    record = {"quadrature": rows, "fresh": fresh, "monte_carlo": mc}
    atomic_write_many(
        {out / "sampling.md": text.encode(), out / "sampling.json": (json.dumps(record, indent=1) + "\n").encode()}
    )
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
