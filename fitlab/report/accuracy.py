r"""Accuracy against the exact values: max and RMS relative error on a fixed validation set.

BRDF level: e_k = |f_k - f_exact,k| / |f_exact,k| over the report's validation
set (:mod:`fitlab.report.validation`); max_rel = max_k e_k, rms_rel =
sqrt(mean_k e_k^2), and max_rel_away the max over the points with mu_i, mu_o >=
1/64 (away from the grazing pole, as in docs/audit.md); max_rel_grazing the max
over the grazing set (mu_i, mu_o down to 1e-6, :func:`fitlab.report.validation.validation_sets`),
which the uniform points never reach.  A NaN or inf value
counts as an infinite error (:func:`fitlab.fit.metrics.relative_errors`).

Part level: the target's own error measure and validation set
(:mod:`fitlab.families.lambert_sphere.targets`: |approx - exact| / scale, scale = |exact|, or
A = 69c/128 for B, C, D, F, or f^(0) for fm1), restricted to a fit's domain
where the fit declares a smaller one; max_rel* leaves out the target's exact
zeros (:func:`fitlab.fit.metrics.summary`).
"""

from __future__ import annotations

import numpy as np

from fitlab.fit.metrics import relative_errors, summary
from fitlab.fit.refit import preset_metrics
from fitlab.report.methods import brdf_report

__all__ = ["brdf_errors", "brdf_accuracy", "part_accuracy", "AWAY_MU"]

#: max_rel_away counts the points with mu_i, mu_o >= AWAY_MU
AWAY_MU = 1.0 / 64.0


def brdf_errors(method, valid) -> np.ndarray:
    """Relative errors of ``method`` at every point of the BRDF validation set."""
    approx = method.evaluate(*(valid.inputs[n] for n in brdf_report().BRDF_INPUTS))
    return relative_errors(approx, valid.y, np.abs(valid.y))


def _point(data, i: int) -> dict:
    """The validation set's point ``i``: the BRDF's inputs that name it (the report's ``BRDF_POINT``)."""
    return {k: float(data.inputs[k][i]) for k in brdf_report().BRDF_POINT}


def brdf_accuracy(method, valid, grazing=None, fresh=None, energy=None) -> dict:
    """max_rel, rms_rel, max_rel_away (mu_i, mu_o >= 1/64), points and the worst point, and max_abs_c0 (max |f|
    at c = 0 on the set's points, kd = 0); with the grazing set, max_rel_grazing and its worst point; with the
    independent set, max_rel_fresh and rms_rel_fresh; with ``energy`` = (mu, albedos, their kd, exact
    albedos (one row per albedo), directional_albedo(f, mu, c)), albedo_err = max |a - a_exact| over
    mu and the albedos."""
    err = brdf_errors(method, valid)
    hook = brdf_report()
    mu_i, mu_o = (valid.inputs[n] for n in hook.BRDF_INPUTS[:2])  # the incident and outgoing cosines
    away = (mu_i >= AWAY_MU) & (mu_o >= AWAY_MU)
    i = int(np.argmax(err))
    with np.errstate(over="ignore"):
        rms = float(np.sqrt(np.mean(err**2)))
    out = {
        "max_rel": float(err[i]),
        "rms_rel": rms,
        "max_rel_away": float(err[away].max()),
        "points": int(err.size),
        "worst": _point(valid, i),
    }
    material = set(hook.BRDF_MATERIAL)  # all 0: the black material (c = 0, kd = 0)
    with np.errstate(all="ignore"):
        at0 = method.evaluate(
            *(np.zeros_like(valid.inputs[n]) if n in material else valid.inputs[n] for n in hook.BRDF_INPUTS)
        )
    out["max_abs_c0"] = float(np.max(np.where(np.isfinite(at0), np.abs(at0), np.inf)))
    if grazing is not None:
        g = brdf_errors(method, grazing)
        j = int(np.argmax(g))
        out["max_rel_grazing"] = float(g[j])
        out["worst_grazing"] = _point(grazing, j)
    if fresh is not None:
        e = brdf_errors(method, fresh)
        with np.errstate(over="ignore"):
            out.update(max_rel_fresh=float(e.max()), rms_rel_fresh=float(np.sqrt(np.mean(e**2))))
    if energy is not None:
        mu, cs, kds, exact, directional_albedo = energy
        err = 0.0
        for cv, kd, want in zip(cs, kds, exact):

            def f(mi, mo, ph, c, kd=kd):
                return method.evaluate(mi, mo, ph, c, np.full(np.shape(c), kd))

            with np.errstate(all="ignore"):
                a = directional_albedo(f, mu, cv)
            err = max(err, float(np.max(np.where(np.isfinite(a), np.abs(a - want), np.inf))))
        out["albedo_err"] = err
    return out


def part_accuracy(method, target) -> dict:
    """The target's error measure on its validation set (restricted to the method's domain); a published
    preset is measured by :func:`fitlab.fit.refit.preset_metrics`."""
    if getattr(method, "preset", None) is not None and not method.domain:
        return preset_metrics(target, *method.preset)
    valid = target.validation()
    if method.domain:
        valid = valid.restricted(method.domain)
    approx = method.evaluate(**{n: valid.inputs[n] for n in target.inputs})
    return summary(approx, valid.y, target.scale(valid), valid.inputs)
