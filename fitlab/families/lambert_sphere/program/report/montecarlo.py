r"""Monte Carlo as an evaluation method of ``fitlab report``: error and time at several path counts.

One scene (built here, run by :func:`fitlab.families.lambert_sphere.mc.simulate.simulate`): the
materials ``mc_c``, incident cosines ``mc_mu_i``, mu_o bins ``mc_mu_edges`` and
``mc_phi_bins`` equal |phi| bins; multiple scattering simulated with the
three-term phase function (as the exact engine has it), single scattering in
closed form.  Each BRDF value is a bin average; its error is
|estimate - exact| / exact against the exact three-term bin average that
:mod:`fitlab.families.lambert_sphere.mc.effects` computes (so Monte Carlo is measured on its own points,
not on the report's validation set).  Every path count is a separate run with
the same seed (deterministic: counter-based random numbers).

Cost: simulation seconds per run (after an untimed warm-up run: compilation and first-call
overheads excluded), and
per BRDF value = seconds / values.  Time to reach an RMS relative error eps is
extrapolated from the largest run by the 1/sqrt(N) law of the standard error:
t(eps) = t(N) (se_rms(N) / eps)^2, se_rms the RMS of se/exact over the values.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mc_scene", "mc_study", "mc_time_to_error"]


def mc_scene(c_values, mu_i, mu_edges, phi_bins: int, paths: int, seed: int):
    """The scene of one run (a :class:`fitlab.families.lambert_sphere.mc.Scene`)."""
    from fitlab.families.lambert_sphere.mc import parse_scene

    materials = "\n".join(f"[[material]]\nc = {c!r}" for c in c_values)
    text = f"""
[scene]
name = "report_{paths}"
seed = {seed}
phase = "three_term"
{materials}
[incident]
mu_i = {list(mu_i)!r}
[outgoing]
mu_o = {list(mu_edges)!r}
phi = {phi_bins}
[effects]
list = ["multiple"]
[precision]
target_se = 1e-30
max_paths = {paths}
batch = {min(paths, 200_000)}
"""
    return parse_scene(text, "<fitlab report Monte Carlo scene>")


def mc_study(settings, tick=None, seed: int = 2021) -> list[dict]:
    """One dict per path count: values, max_rel, rms_rel, se_rms, seconds, compile_seconds, ns_per_value.
    ``settings``: the family's report settings (:class:`.settings.EngineSettings`); ``seed``: the
    report's (:attr:`fitlab.report.Settings.seed`)."""
    from fitlab.families.lambert_sphere.mc.simulate import simulate

    def scene(paths):
        return mc_scene(settings.mc_c, settings.mc_mu_i, settings.mc_mu_edges, settings.mc_phi_bins, paths,
                        seed)  # fmt: skip

    simulate(scene(min(settings.mc_paths)), progress=False)  # warm-up: compilation and first-call overheads
    out = []
    for paths in settings.mc_paths:
        res = simulate(scene(paths), progress=False)
        rows = [r for r in res.rows["multiple"] if r["quantity"] == "f"]
        est = np.array([r["estimate"] for r in rows])
        ref = np.array([r["ref"] for r in rows])
        se = np.array([r["se"] for r in rows])
        err = np.abs(est - ref) / np.abs(ref)
        seconds = sum(st.seconds for st in res.jobs.values())
        out.append({
            "paths": paths, "values": len(rows), "jobs": len(res.jobs),
            "max_rel": float(err.max()), "rms_rel": float(np.sqrt(np.mean(err**2))),
            "se_rms": float(np.sqrt(np.mean((se / np.abs(ref)) ** 2))),
            "seconds": seconds, "compile_seconds": sum(st.compile_seconds for st in res.jobs.values()),
            "ns_per_value": seconds / len(rows) * 1e9,
        })  # fmt: skip
        if tick:
            tick()
    return out


def mc_time_to_error(study: list[dict], eps: float) -> dict:
    """Extrapolated seconds (for all the run's values, and per value) to an RMS relative error ``eps``."""
    last = study[-1]
    factor = (last["se_rms"] / eps) ** 2
    return {"target": eps, "paths": last["paths"] * factor, "seconds": last["seconds"] * factor,
            "seconds_per_value": last["seconds"] * factor / last["values"]}  # fmt: skip
