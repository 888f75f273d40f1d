r"""The study behind docs/microsurface_lobes.md: the simulated multiple-scattering lobes against every way to
model them, with accuracy, energy and cost (``python -m studies.microfacet_energy.microsurface_lobes --out
docs``, about 5 minutes on 2 cores).

Measures, on the validation grid of the lobe tables (jobs the fits never saw, the domain's edges at
interleaved points):

* per-lobe fits (the blog's step 3) of every shape of
  :data:`fitlab.families.microfacet_energy.lobes.shapes.PER_LOBE_FORMS` to every lobe of the training grid:
  Levenberg-Marquardt steps and seconds per lobe (the blog: "sometimes a hundred iterations" of BFGS per lobe), and the
  best each shape can do lobe by lobe (its floor);
* every model of the multiple-scattering lobe (:mod:`fitlab.families.microfacet_energy.program.runtime`, with ``none``
  and ``kulla_conti``) against the simulated lobes, per order (2, 3, 4, the tail above 4) and summed: the max and RMS
  relative error over the bins with meaningful values (a bin average at least 5 standard errors above 0), beside the
  noise of those bins (the RMS of se/value: what the exact lobe itself would show), the albedo error per order
  (relative, over the lobes of albedo >= 1e-3) and of the sum (relative, and absolute in units of the incident energy),
  and the relative error of the whole BRDF, single scattering (exact, the simulated order 1) plus the model, where that
  sum is meaningful;
* Kulla-Conti's f_ms against the simulated lobe of F = 1 conductors (orders >= 2 summed; the same energy by
  construction, 1 - E(mu_i)) and against each order's lobe scaled to that order's albedo (the shape alone);
* ns per evaluation of the generated C of each model (double), in one interleaved run
  (:func:`fitlab.codegen.bench.time_routines`): only ratios carry meaning.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from fitlab.families.microfacet_energy.lobes import tables as lt
from fitlab.families.microfacet_energy.lobes.fitting import bin_averages_numpy, fit_lobes, quadrature
from fitlab.families.microfacet_energy.lobes.params import lobe_inputs
from fitlab.families.microfacet_energy.lobes.shapes import PER_LOBE_FORMS, per_lobe_form
from fitlab.families.microfacet_energy.program.runtime import MODELS, ORDERS, lobe_functions
from fitlab.families.microfacet_energy.targets.lobes import MIN_ALBEDO

__all__ = [
    "model_bins",
    "kulla_conti_bins",
    "accuracy",
    "per_lobe_study",
    "cost_ns",
    "markdown",
    "main",
    "SNR",
    "STUDY_MODELS",
    "FIGURE_POINTS",
]

#: a bin is meaningful where its value is at least SNR standard errors
SNR = 5.0
#: the models of the study, by kind, in table order
STUDY_MODELS = {
    "diffuse": ("none", "blog_text", "blog_code", "blog_refit", "blog_rich", "tilted"),
    "conductor": ("none", "kulla_conti", "blog_refit", "blog_rich", "tilted"),
}
#: (alpha, mu_i) of the figure's columns (validation jobs)
FIGURE_POINTS = ((0.275, 0.1), (0.6, 0.5), (0.85, 0.9))
_LABELS = {
    "none": "none (single scattering only)",
    "kulla_conti": "Kulla-Conti f_ms (exact E)",
    **{m: MODELS[m][3] for m in MODELS},
}


def _tables(data_dir=None):
    from fitlab.families.microfacet_energy.targets.datasets import tables_dir

    folder = tables_dir(data_dir)
    return {(k, w): lt.read_lobes(folder, k, w) for k in lt.KINDS for w in lt.SETS}


def model_bins(model: str, kind: str, t: lt.LobeTable, fits_dir=None) -> np.ndarray:
    """The model's bin averages of f_S mu_o, shape (J, 4, 10, 8) for orders 2..5 (weights 1: rho = 1, F = 1)."""
    out = np.zeros((len(t), len(ORDERS), len(lt.MU_EDGES) - 1, len(lt.PHI_EDGES) - 1))
    if model == "none":
        return out
    fs = lobe_functions(model, kind, fits_dir)
    for j in range(len(t)):
        for k, s in enumerate(ORDERS):
            out[j, k] = bin_averages_numpy(fs[s], float(t.mu_i[j]), float(t.alpha[j]))
    return out


def kulla_conti_bins(t: lt.LobeTable) -> np.ndarray:
    """Bin averages (J, 10, 8) of Kulla-Conti's f_ms mu_o, height-correlated GGX, exact E (the exact engine)."""
    from fitlab.families.microfacet_energy.exact import multiple_scattering_brdf

    mu, c, wm, wp = quadrature()
    out = np.zeros((len(t), len(lt.MU_EDGES) - 1, len(lt.PHI_EDGES) - 1))
    for j in range(len(t)):
        f = multiple_scattering_brdf(mu, float(t.mu_i[j]), float(t.alpha[j]), "ggx_correlated")
        out[j] = bin_averages_numpy(lambda mo, cp, mi, a, f=f: f[:, None] * np.ones_like(cp), t.mu_i[j], t.alpha[j])
    return out


def _where(t, j, i, p) -> str:
    return (
        f"alpha {t.alpha[j]:g}, mu_i {t.mu_i[j]:g}, mu_o in [{lt.MU_EDGES[i]:.1f}, {lt.MU_EDGES[i + 1]:.1f}], "
        f"|phi_o| in [{np.degrees(lt.PHI_EDGES[p]):.1f}, {np.degrees(lt.PHI_EDGES[p + 1]):.1f}] deg"
    )


def _errors(t, model, y, se, albedo, where_ok=None) -> dict:
    """Max and RMS relative error of ``model`` against ``y`` on meaningful bins (J, 10, 8), the noise there,
    the worst bin, and the albedo errors."""
    ok = (y > 0) & (y >= SNR * se)
    if where_ok is not None:
        ok &= where_ok
    rel = np.where(ok, np.abs(model - y) / np.where(ok, y, 1.0), 0.0)
    j, i, p = np.unravel_index(int(np.argmax(rel)), rel.shape)
    a_model = np.einsum("jsp,sp->j", model, lt.solid_angles())
    keep = albedo >= MIN_ALBEDO
    e_rel = np.abs(a_model / np.where(keep, albedo, 1.0) - 1.0)[keep]
    return {
        "max_rel": float(rel.max()),
        "rms_rel": float(np.sqrt(np.mean(rel[ok] ** 2))) if ok.any() else 0.0,
        "noise_rms": float(np.sqrt(np.mean((se[ok] / y[ok]) ** 2))) if ok.any() else 0.0,
        "bins": int(ok.sum()),
        "worst": _where(t, j, i, p),
        "energy_max_rel": float(e_rel.max()) if e_rel.size else 0.0,
        "energy_rms_rel": float(np.sqrt(np.mean(e_rel**2))) if e_rel.size else 0.0,
        "energy_max_abs": float(np.max(np.abs(a_model - albedo))),
        "lobes": int(keep.sum()),
    }


def accuracy(kind: str, t: lt.LobeTable, models=None, fits_dir=None) -> dict:
    """{model: {"2", "3", "4", ">4", "multiple", "brdf": errors}} on the lobes of ``t`` (module docstring)."""
    y_ms, se_ms, a_ms, _ = t.multiple()
    kc = kulla_conti_bins(t) if kind == "conductor" else None
    out = {}
    for model in models or STUDY_MODELS[kind]:
        if model == "kulla_conti":
            a_kc = np.einsum("jsp,sp->j", kc, lt.solid_angles())
            # each order: the Kulla-Conti shape with that order's albedo (the shape alone is compared)
            bins = np.stack([kc * (t.albedo[:, s - 1] / a_kc)[:, None, None] for s in ORDERS], axis=1)
            ms = kc
        else:
            bins = model_bins(model, kind, t, fits_dir)
            ms = bins.sum(axis=1)
        res = {}
        for k, s in enumerate(ORDERS):
            res[lt.ORDER_LABELS[s - 1]] = _errors(t, bins[:, k], t.value[:, s - 1], t.se[:, s - 1], t.albedo[:, s - 1])
        res["multiple"] = _errors(t, ms, y_ms, se_ms, a_ms)
        # the whole BRDF: exact single scattering (order 1 as simulated) plus the model
        total = t.value[:, 0] + y_ms
        total_se = np.hypot(t.se[:, 0], se_ms)
        res["brdf"] = _errors(t, t.value[:, 0] + ms, total, total_se, t.albedo[:, 0] + a_ms)
        out[model] = res
    return out


def per_lobe_study(kind: str, t: lt.LobeTable, forms=PER_LOBE_FORMS) -> dict:
    """Per-lobe fits of every form to every lobe (orders 2..5) of ``t``: steps, seconds and the floor."""
    lobes = [(j, s) for j in range(len(t)) for s in ORDERS]
    data = [lobe_inputs(t, j, s) for j, s in lobes]
    out = {}
    for name in forms:
        form = per_lobe_form(name)
        if name == "blog_scale":
            continue  # a scale with a given shape: the parameter tables' step, not a shape of its own
        fit = fit_lobes(form, data)
        errs, order_of = [], []
        for k, ((j, s), lobe) in enumerate(zip(lobes, data)):
            m = bin_averages_numpy(
                lambda mo, c, mi, a, th=fit.theta[k], form=form: form.numpy_function(th, mo, c, mi, a),
                lobe["mu_i"],
                lobe["alpha"],
            )
            y, se = t.value[j, s - 1], t.se[j, s - 1]
            ok = (y > 0) & (y >= SNR * se)
            if t.albedo[j, s - 1] >= MIN_ALBEDO and ok.any():
                errs.append(np.abs(m - y)[ok] / y[ok])
                order_of.append(s)
        by_order = {}
        for s in ORDERS:
            e = [x for x, o in zip(errs, order_of) if o == s]
            if e:
                cat = np.concatenate(e)
                by_order[lt.ORDER_LABELS[s - 1]] = {
                    "rms_rel": float(np.sqrt(np.mean(cat**2))),
                    "median_lobe_max": float(np.median([x.max() for x in e])),
                }
        res = {
            "lobes": len(data),
            "free": len(form.free_params),
            "steps_mean": float(fit.steps.mean()),
            "steps_max": int(fit.steps.max()),
            "steps_all_mean": float(fit.steps_all.mean()),
            "seconds_mean": float(fit.seconds.mean()),
            "seconds_max": float(fit.seconds.max()),
            "compile_seconds": float(fit.compile_seconds),
            "converged": float(fit.converged.mean()),
            "by_order": by_order,
        }
        if "m" in form.free_params:
            m = fit.theta[:, form.params.index("m")]
            res["m_range"] = [float(m.min()), float(m.max())]
        out[name] = res
    return out


def _timing_inputs(n: int) -> dict:
    rng = np.random.default_rng(20)
    return {
        "mu_i": rng.uniform(0, 1, n),
        "mu_o": rng.uniform(0, 1, n),
        "cos_phi": rng.uniform(-1, 1, n),
        "alpha": rng.uniform(0.05, 1, n),
        "rho": rng.uniform(0, 1, n),
    }


def cost_ns(fits_dir=None, n: int = 100_000, repeat: int = 7) -> dict:
    """ns per evaluation (C, double) of each generated model routine, one interleaved run; the blog's published
    model (text presets, diffuse) from a program of its presets.  {} without a C compiler."""
    from fitlab.codegen import emit
    from fitlab.codegen.bench import time_routines
    from fitlab.codegen.native import CompileError, build, compiler
    from fitlab.families.microfacet_energy.program.runtime import model_forms
    from fitlab.families.microfacet_energy.program.spec import fit_files, lobe_program
    from fitlab.store import FitFunction, fit_path, fits_folder, load

    if compiler() is None:
        return {}
    fits = {tgt: load(p) for tgt, p in fit_files(fits_dir).items()}
    rich = dict(fits)
    for kind in lt.KINDS:
        for target, form_name in model_forms("blog_rich", kind).items():
            rich[target] = load(fit_path(fits_folder(fits_dir), target, form_name))
    published = dict(fits)
    for target, form_name in model_forms("blog_text", "diffuse").items():
        from fitlab.core import get_target

        form = get_target(target).forms[form_name]
        published[target] = FitFunction(
            {
                "format": "fitlab-fit/1",
                "target": target,
                "form": form_name,
                "inputs": list(form.inputs),
                "expression": form.expression,
                "params": dict(zip(form.params, form.vector("blog_text").tolist())),
                "domain": {k: list(get_target(target).domain[k]) for k in form.inputs},
            }
        )
    inputs = _timing_inputs(n)
    cases = {}
    with tempfile.TemporaryDirectory() as tmp:
        try:
            libs = {}
            for key, recs in (("fits", fits), ("published", published), ("rich", rich)):
                prog = lobe_program(recs)
                libs[key] = (build(emit(prog, "c"), prog, Path(tmp) / key), prog)
        except CompileError:
            return {}
        lib, prog = libs["fits"]
        for name, routine in (
            ("kulla_conti conductor", "ms_kulla_conti"),
            ("blog_refit diffuse", "ms_blog_diffuse"),
            ("tilted diffuse", "ms_tilt_diffuse"),
            ("blog_refit conductor", "ms_blog_conductor"),
            ("tilted conductor", "ms_tilt_conductor"),
            ("E_ggx_cor (one E, fitted)", "E_ggx_cor"),
        ):
            r = prog.routine(routine)
            cases[name] = (lib, routine, [inputs.get(a, inputs["mu_o"]) for a in r.signature()], np.float64)
        lib, prog = libs["published"]
        r = prog.routine("ms_blog_diffuse")
        cases["blog_text diffuse"] = (lib, "ms_blog_diffuse", [inputs[a] for a in r.signature()], np.float64)
        lib, prog = libs["rich"]
        for kind in lt.KINDS:
            r = prog.routine(f"ms_blog_{kind}")
            cases[f"blog_rich {kind}"] = (lib, r.name, [inputs[a] for a in r.signature()], np.float64)
        ns = time_routines(cases, repeat)
        ns["blog_code diffuse"] = ns["blog_text diffuse"]  # the same program with other numbers
        return ns


def _g(x) -> str:
    return f"{x:.3g}" if np.isfinite(x) else "inf"


def _accuracy_table(acc: dict, ns: dict, kind: str) -> list[str]:
    lines = [
        "| model | order 2: max / RMS | order 3 | order 4 | tail > 4 | orders >= 2: max / RMS (noise) | "
        "energy of orders >= 2: max / RMS rel, max abs | whole BRDF: max / RMS | C ns |",
        "|---" * 9 + "|",
    ]
    for model, res in acc.items():
        cells = [f"{_g(res[o]['max_rel'])} / {_g(res[o]['rms_rel'])}" for o in ("2", "3", "4", ">4")]
        ms, br = res["multiple"], res["brdf"]
        cost = ns.get(f"{model} {kind}", ns.get(f"{model} conductor") if model == "kulla_conti" else None)
        cost = "0" if model == "none" else (f"{cost:.0f}" if cost is not None else "-")
        lines.append(
            f"| {_LABELS[model]} | " + " | ".join(cells) + f" | {_g(ms['max_rel'])} / {_g(ms['rms_rel'])} "
            f"({_g(ms['noise_rms'])}) | {_g(ms['energy_max_rel'])} / {_g(ms['energy_rms_rel'])}, "
            f"{_g(ms['energy_max_abs'])} | {_g(br['max_rel'])} / {_g(br['rms_rel'])} | {cost} |"
        )
    return lines


def _refit_rows(fits_dir=None) -> list[dict]:
    """Validation figures of every committed fit of the lobe-parameter targets and of their published presets."""
    from fitlab.core import targets
    from fitlab.store import fit_files, fits_folder, read_fit

    rows = []
    for name, t in targets().items():
        if not name.startswith("ms_"):
            continue
        for path in fit_files(fits_folder(fits_dir), name):
            rec = read_fit(path)
            v = rec["validation"]
            rows.append(
                {
                    "target": name,
                    "form": rec["form"],
                    "what": "refit",
                    "max": v["max_rel"],
                    "rms": v["rms_rel"],
                    "default": rec["form"] == t.default_form,
                }
            )
            if rec["form"] != t.default_form or not t.published:
                for pub in rec["published"]:
                    if pub["form"] == rec["form"] or rec["form"] == t.default_form:
                        rows.append(
                            {
                                "target": name,
                                "form": pub["form"],
                                "what": pub["preset"],
                                "max": pub["validation"]["max_rel"],
                                "rms": pub["validation"]["rms_rel"],
                                "default": False,
                            }
                        )
    seen, out = set(), []
    for r in rows:  # a preset shows once per target
        key = (r["target"], r["form"], r["what"])
        if key not in seen:
            seen.add(key)
            out.append(r)
    return out


def markdown(result: dict) -> str:
    """docs/microsurface_lobes.md from :func:`run`'s result."""
    L = [
        "# Multiple-scattering lobes by order: simulated, fitted, generated",
        "",
        "Generated by `python -m studies.microfacet_energy.microsurface_lobes --out docs` "
        f"({result['seconds'] / 60:.1f} minutes on 2 cores); the numbers are in microsurface_lobes.json. How the "
        "blog's lobe model is read (every ambiguity of its text and code) is in [blog_lobe_model.md](blog_lobe_model.md).",
        "",
        "## The simulated lobes",
        "",
        "The random walk of Heitz et al. (2016) on GGX microsurfaces (height-correlated Smith), diffuse (Lambertian) "
        "facets of albedo 1 and F = 1 conductors, lobes by order (1, 2, 3, 4 and the tail above 4) in 10 x 8 "
        "(mu_o, |phi_o|) bins with standard errors, on a 7 x 6 training grid of (alpha, mu_i) in [0.05, 1]^2 and an "
        "interleaved 42-job validation grid (`fitlab tabulate`; fitlab/data/microfacet_energy/lobes_*.csv, "
        "lobes/tables.py states grid, seed and budget):",
        "",
    ]
    L += ["| table | jobs | paths |", "|---|---|---|"]
    L += [f"| {k} | {v['jobs']} | {v['paths']:.3g} |" for k, v in result["tables"].items()]
    z = result["albedo_vs_engine"]
    L += [
        "",
        "Checks: the conductors' multiple-scattering albedo (orders >= 2) against 1 - E(mu_i) of the exact engine "
        f"(height-correlated GGX): max |z| {z['training']['max_abs_z']:.2f} (training, {z['training']['jobs']} jobs), "
        f"{z['validation']['max_abs_z']:.2f} (validation); RMS z {z['training']['rms_z']:.2f}, "
        f"{z['validation']['rms_z']:.2f}. Diffuse facets of albedo 0.6 against 0.6^S times albedo 1 (independent "
        "seeds, alpha = mu_i = 0.5): ratios "
        + ", ".join(f"{r:.4f}" for r in result["rho_identity"]["ratio"])
        + " (orders 1-4), z "
        + ", ".join(f"{x:+.2f}" for x in result["rho_identity"]["z"])
        + ".",
        "",
    ]
    L += [
        "## Fitting one lobe (the blog's step 3)",
        "",
        "Each shape of lobes/shapes.py fitted to every lobe of the training grid (orders 2, 3, 4, tail: "
        f"{next(iter(result['per_lobe']['diffuse'].values()))['lobes']} lobes per kind), optimistix "
        "Levenberg-Marquardt on the chi-square of the bins plus the albedo's (lobes/fitting.py says why), one "
        "compilation for all lobes; the forms with a deviation angle from 3 starts (-0.6, 0, 0.6 rad), the "
        "seconds per lobe counting every start. The "
        "blog ran BFGS, 'sometimes a hundred iterations' per lobe, overnight. Steps are LM steps (each one "
        "Jacobian and one linear solve); seconds per lobe after compilation; the floor is the RMS relative error "
        "of the fitted lobe on its meaningful bins (lobes of albedo >= 1e-3), by order.",
        "",
    ]
    L += [
        "| kind | shape | free | steps, kept start: mean (max) | steps, all starts | s per lobe: mean (max) | "
        "compile s | converged | floor RMS: order 2 / 3 / 4 / tail |",
        "|---" * 9 + "|",
    ]
    # (seconds per lobe: every start of the lobe together)
    for kind, forms in result["per_lobe"].items():
        for name, r in forms.items():
            floor = " / ".join(
                f"{r['by_order'][o]['rms_rel']:.3f}" if o in r["by_order"] else "-" for o in ("2", "3", "4", ">4")
            )
            L.append(
                f"| {kind} | {name} | {r['free']} | {r['steps_mean']:.0f} ({r['steps_max']}) | "
                f"{r['steps_all_mean']:.0f} | {r['seconds_mean'] * 1e3:.1f} ms ({r['seconds_max'] * 1e3:.0f} ms) | "
                f"{r['compile_seconds']:.1f} | {r['converged']:.0%} | {floor} |"
            )
    m = {k: v["blog_masking"]["m_range"] for k, v in result["per_lobe"].items() if "blog_masking" in v}
    L += [
        "",
        "The masking importance m (blog_masking, m free): fitted values range over "
        + "; ".join(f"{k} [{lo:.3g}, {hi:.3g}]" for k, (lo, hi) in m.items())
        + " (m is meant to lie in [0, 1]), for a floor barely lower than with m = 0: the blog's 'not very "
        "significant', confirmed; every other shape holds m at 0.",
        "",
    ]
    L += [
        "## The parameters as functions of alpha, mu_i and the order (the blog's step 4)",
        "",
        "Targets ms_{blog,tilt}_PARAM_{diffuse,conductor} (lobes/targets.py: error measures, sets, weights), "
        "refitted with `fitlab refit` (fits in fitlab/fits). Validation figures (the blog's presets exist for "
        "diffuse facets only; the tilted lobe's scale is measured against the energy-matching scale):",
        "",
        "| target | form | preset or refit | max | RMS |",
        "|---|---|---|---|---|",
    ]
    for r in result["refits"]:
        star = " (default)" if r["default"] else ""
        L.append(f"| {r['target']} | {r['form']}{star} | {r['what']} | {_g(r['max'])} | {_g(r['rms'])} |")
    for kind in lt.KINDS:
        L += [
            "",
            f"## Accuracy and cost against the simulated lobes: {kind} facets",
            "",
            "Validation grid, every lobe. Order columns: max / RMS relative error on the meaningful bins (value >= "
            f"{SNR:g} se); orders >= 2: the multiple-scattering lobe a renderer adds, with the bins' own noise; "
            "energy: the albedo error of orders >= 2, relative (max / RMS over the jobs) and absolute (a fraction of "
            "the incident energy); whole BRDF: single scattering (the simulated order 1, exact in a renderer) plus "
            "the model, relative; C ns: one evaluation of the generated C (double), one interleaved run.",
            "",
        ]
        L += _accuracy_table(result["accuracy"][kind], result["ns"], kind)
        worst = {m: r["multiple"]["worst"] for m, r in result["accuracy"][kind].items() if m != "none"}
        L += ["", "Where each model errs most (orders >= 2): " + "; ".join(f"{m}: {w}" for m, w in worst.items()) + "."]
        L += ["", f"![{kind}: simulated lobes against the models](microsurface_lobes_{kind}.png)", ""]
    kc = result["accuracy"]["conductor"]["kulla_conti"]
    L += [
        "## Kulla-Conti's f_ms against the simulated lobe (F = 1 conductors)",
        "",
        "f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)) of height-correlated GGX, the walk's order 1, exact E: "
        "its energy is the simulated one by construction (1 - E(mu_i); measured "
        f"{kc['multiple']['energy_max_rel']:.3g} max relative, the noise of the simulation). Its shape against the "
        "sum of the orders, and against each order's lobe scaled to that order's albedo:",
        "",
        "| lobe | max rel | RMS rel | noise RMS | where it differs most |",
        "|---|---|---|---|---|",
    ]
    for o, label in (
        ("multiple", "orders >= 2"),
        ("2", "order 2"),
        ("3", "order 3"),
        ("4", "order 4"),
        (">4", "tail above 4"),
    ):
        r = kc[o]
        L.append(f"| {label} | {_g(r['max_rel'])} | {_g(r['rms_rel'])} | {_g(r['noise_rms'])} | {r['worst']} |")
    ns = result["ns"]
    L += [
        "",
        "## Cost",
        "",
        "ns per evaluation of the generated C (double, gcc -O2, 1e5 random inputs), one interleaved "
        "run; only the ratios carry meaning. 'none' costs nothing; an E lookup of the fitted E_ggx_cor is the unit "
        "Kulla-Conti pays three times.",
        "",
        "| routine | ns | vs one E |",
        "|---|---|---|",
    ]
    unit = ns.get("E_ggx_cor (one E, fitted)")
    for k, v in ns.items():
        L.append(f"| {k} | {v:.0f} | {v / unit:.1f} |" if unit else f"| {k} | {v:.0f} | |")
    L += ["", "## Reading the results", "", *_reading(result), ""]
    return "\n".join(L) + "\n"


def _reading(result: dict) -> list[str]:
    acc = result["accuracy"]
    d, c = acc["diffuse"], acc["conductor"]

    def ms(res, key):
        return res["multiple"][key]

    return [
        "* The blog's published lobes (its diffuse model, text or code coefficients) do not describe the Smith "
        "microsurface's multiple scattering: their relative energy errors reach "
        f"{ms(d['blog_text'], 'energy_max_rel'):.3g} (text) and {ms(d['blog_code'], 'energy_max_rel'):.3g} (code), "
        f"RMS {ms(d['blog_text'], 'energy_rms_rel'):.3g} and {ms(d['blog_code'], 'energy_rms_rel'):.3g} (the blog simulated a Beckmann heightfield and writes that it is 'not sure my "
        "results are accurate or useable anymore'), and they leave out the orders above 3, which hold a quarter to a "
        "third of the multiple-scattering energy at alpha = 1.",
        "* Refitted (same lobe, same forms) the blog's model has RMS errors of "
        f"{ms(d['blog_refit'], 'rms_rel'):.2f} (lobe) and {ms(d['blog_refit'], 'energy_rms_rel'):.2f} (energy) on "
        f"diffuse facets; with the richer parameter forms {ms(d['blog_rich'], 'rms_rel'):.2f} and "
        f"{ms(d['blog_rich'], 'energy_rms_rel'):.2f}. Its lobe has no azimuth and cannot lean towards the mirror "
        "side, where the simulated lobes of oblique incidence put their energy (the figures).",
        f"* The tilted lobe follows the diffuse facets' lobes to {ms(d['tilted'], 'rms_rel'):.3f} RMS (the bins' own "
        f"noise: {ms(d['tilted'], 'noise_rms'):.3f}), max {ms(d['tilted'], 'max_rel'):.2f}, and their energy to "
        f"{ms(d['tilted'], 'energy_rms_rel'):.3f} RMS (max {ms(d['tilted'], 'energy_max_rel'):.2f}, "
        f"{ms(d['tilted'], 'energy_max_abs'):.3f} of the incident energy); the whole BRDF to "
        f"{d['tilted']['brdf']['rms_rel']:.3f} RMS (max {d['tilted']['brdf']['max_rel']:.2f}) against "
        f"{d['none']['brdf']['rms_rel']:.2f} (max {d['none']['brdf']['max_rel']:.2f}) without multiple scattering, "
        f"at {result['ns'].get('tilted diffuse', float('nan')) / result['ns'].get('blog_refit diffuse', float('nan')):.1f} "
        "times the C cost of the blog's lobe.",
        "* F = 1 conductors of small roughness scatter their second order into a narrow streak about the plane of "
        "incidence on the mirror side; no lobe here follows it (nor Kulla-Conti's, which has no azimuth), and the "
        "conductors' largest errors are there (alpha <= 0.2 at oblique incidence): the tilted lobe's RMS is "
        f"{ms(c['tilted'], 'rms_rel'):.2f} (energy {ms(c['tilted'], 'energy_rms_rel'):.2f}) against the refitted "
        f"blog lobe's {ms(c['blog_refit'], 'rms_rel'):.2f} ({ms(c['blog_refit'], 'energy_rms_rel'):.2f}).",
        "* Kulla-Conti's lobe has the simulated energy by construction (max "
        f"{ms(c['kulla_conti'], 'energy_max_rel'):.3f}, the simulation's noise) but a shape without azimuth, with "
        f"1 - E(mu_o) as its only dependence on mu_o: its relative error is {ms(c['kulla_conti'], 'rms_rel'):.2f} RMS "
        f"(max {ms(c['kulla_conti'], 'max_rel'):.1f}) against the simulated lobe, and "
        f"{c['kulla_conti']['brdf']['rms_rel']:.2f} on the whole BRDF, more than leaving multiple scattering out "
        f"({c['none']['brdf']['rms_rel']:.2f}) there, where it puts energy at grazing the lobe does not have; for the "
        "energy of a white furnace it is exact, and the cheapest.",
    ]


_COLOURS = {"blog_text": "tab:red", "blog_refit": "tab:blue", "tilted": "tab:orange", "kulla_conti": "tab:green"}


def _figure(tables: dict, fits_dir, out: Path) -> list[Path]:
    """One PNG per kind: the simulated lobe (f mu_o in the plane of incidence, error bars) against the models,
    orders 2, 3 and all orders >= 2, at :data:`FIGURE_POINTS`."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return []
    paths = []
    mu_c = 0.5 * (np.asarray(lt.MU_EDGES[1:]) + np.asarray(lt.MU_EDGES[:-1]))
    theta = np.degrees(np.arccos(mu_c))
    for kind in lt.KINDS:
        t = tables[(kind, "validation")]
        jobs = [int(np.where((t.alpha == a) & (t.mu_i == m))[0][0]) for a, m in FIGURE_POINTS]
        sub = lt.LobeTable(
            kind,
            "validation",
            t.alpha[jobs],
            t.mu_i[jobs],
            t.paths[jobs],
            t.value[jobs],
            t.se[jobs],
            t.albedo[jobs],
            t.albedo_se[jobs],
        )
        models = [m for m in STUDY_MODELS[kind] if m not in ("none", "blog_code", "blog_rich")]
        bins = {m: model_bins(m, kind, sub, fits_dir) for m in models if m != "kulla_conti"}
        kc = kulla_conti_bins(sub) if "kulla_conti" in models else None
        y_ms, se_ms, _, _ = sub.multiple()
        fig, axes = plt.subplots(3, len(jobs), figsize=(4.2 * len(jobs), 9.0), squeeze=False)
        for col in range(len(jobs)):
            rows = (
                ("order 2", sub.value[col, 1], sub.se[col, 1], lambda b, col=col: b[col, 0]),
                ("order 3", sub.value[col, 2], sub.se[col, 2], lambda b, col=col: b[col, 1]),
                ("orders >= 2", y_ms[col], se_ms[col], lambda b, col=col: b[col].sum(axis=0)),
            )
            for row, (label, y, se, pick) in enumerate(rows):
                ax = axes[row, col]
                for side, p, sign in (("back", 0, 1), ("forward", len(lt.PHI_EDGES) - 2, -1)):
                    ax.errorbar(
                        sign * theta,
                        y[:, p],
                        yerr=se[:, p],
                        fmt="o",
                        ms=3,
                        color="k",
                        label="simulated" if side == "back" else None,
                    )
                for m in models:
                    if m == "kulla_conti" and label != "orders >= 2":
                        continue  # Kulla-Conti's lobe is the sum of the orders
                    b = kc[col] if m == "kulla_conti" else pick(bins[m])
                    xs = np.concatenate((-theta, theta[::-1]))
                    ys = np.concatenate((b[:, -1], b[::-1, 0]))
                    ax.plot(xs, ys, label=m, color=_COLOURS[m])
                ax.set_title(f"{kind}, alpha {sub.alpha[col]:g}, mu_i {sub.mu_i[col]:g}: {label}", fontsize=9)
                ax.set_xlabel("theta_o (deg): < 0 mirror side, > 0 light side (|phi| bins 0 and 7)", fontsize=7)
                if col == 0:
                    ax.set_ylabel("bin average of f mu_o (1/sr)")
                if row == 2 and col == 0:
                    ax.legend(fontsize=7)
        fig.tight_layout()
        path = out / f"microsurface_lobes_{kind}.png"
        fig.savefig(path, dpi=72)
        plt.close(fig)
        paths.append(path)
    return paths


def run(fits_dir=None, data_dir=None, progress=print) -> dict:
    """Every measure of the module docstring, as data."""
    t0 = time.perf_counter()
    tables = _tables(data_dir)
    result = {"per_lobe": {}, "accuracy": {}, "albedo_vs_engine": {}}
    for kind in lt.KINDS:
        progress(f"per-lobe fits, {kind}")
        result["per_lobe"][kind] = per_lobe_study(kind, tables[(kind, "training")])
        progress(f"models against the validation lobes, {kind}")
        result["accuracy"][kind] = accuracy(kind, tables[(kind, "validation")], fits_dir=fits_dir)
    from fitlab.families.microfacet_energy.exact import directional_albedo

    for which in lt.SETS:
        t = tables[("conductor", which)]
        _, _, ms, ms_se = t.multiple()
        z = (ms - (1.0 - directional_albedo(t.mu_i, t.alpha, "ggx_correlated"))) / ms_se
        result["albedo_vs_engine"][which] = {
            "max_abs_z": float(np.max(np.abs(z))),
            "jobs": int(z.size),
            "rms_z": float(np.sqrt(np.mean(z**2))),
        }
    progress("the rho^S identity of diffuse facets")
    ident = lt.albedo_identity(rho=0.6, paths=200_000)
    result["rho_identity"] = {"ratio": ident["ratio"].tolist(), "z": ident["z"].tolist()}
    progress("C cost")
    result["ns"] = cost_ns(fits_dir)
    result["refits"] = _refit_rows(fits_dir)
    result["seconds"] = time.perf_counter() - t0
    result["tables"] = {f"{k} {w}": {"jobs": len(t), "paths": int(t.paths.sum())} for (k, w), t in tables.items()}
    return result


def main(argv=None) -> int:
    from fitlab._io import atomic_write_many

    p = argparse.ArgumentParser(
        prog="python -m studies.microfacet_energy.microsurface_lobes",
        description="Write microsurface_lobes.md, .json and the figures (this module's study).",
    )
    p.add_argument("--out", default=".", help="folder for microsurface_lobes.md, .json and .png")
    p.add_argument("--fits", default=None, help="fits folder (default: the packaged fits)")
    args = p.parse_args(argv)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        p.error(f"--out: {out} exists and is not a folder")
    result = run(Path(args.fits) if args.fits else None)
    with tempfile.TemporaryDirectory() as tmp:
        figures = _figure(_tables(), Path(args.fits) if args.fits else None, Path(tmp))
        files = {out / f.name: f.read_bytes() for f in figures}
    files[out / "microsurface_lobes.md"] = markdown(result).encode()
    files[out / "microsurface_lobes.json"] = (json.dumps(result, indent=1) + "\n").encode()
    atomic_write_many(files)
    for f in files:
        print(f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
