r"""``fitlab audit``: every published formula measured against the exact engine.

Writes docs/audit.md (tables) and docs/audit.json (the same numbers).  Three
parts:

1. each published approximation (both presets where there are two) on the
   validation set of its target (fitlab.families.lambert_sphere.targets): claimed accuracy,
   max and RMS relative error, the worst point;
2. the runtime model (docs/model.md, "The runtime BRDF";
   f_r = max(0, f_1 + fm0 + fm1 cos phi)) built
   from the presets, from the refits in fits/, and with exact ingredients (its
   floor: only fm2 cos 2 phi is missing) against the mixed reference
   (:func:`fitlab.families.lambert_sphere.exact.brdf`, phase "mixed", which its parts were fitted to) on
   the BRDF validation set, over the whole domain and away from grazing; then the same models and
   the mixed reference itself against the true BRDF (phase "true") on the same points and at
   independent random points; the exported tables (``fitlab codegen --tables``) in each of these;
3. the white furnace: the directional albedo of each runtime model and of the exported tables at c = 1,
   which should be 1 (the true BRDF gives 1; the mixed reference gives kd_mixed(1) - 1 = 1.0e-5,
   the true phase function's excess over the three-term one in single scattering).

The published formulas of the albedo maps are measured against kd_true, the spherical albedo of the
material's BRDF (the whole phase function), and against kd_three_term.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fitlab.codegen import DEFAULT_FORMS
from fitlab.core import Outputs, get_target, targets
from fitlab.families.lambert_sphere.exact import (
    albedo,
    brdf,
    gauss_legendre,
    graded_gauss,
    multiple_scattering_modes,
    phase_function,
    spherical_albedo,
)
from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS
from fitlab.families.lambert_sphere.program.runtime import PRESET_VARIANTS, RuntimeModel, runtime_model
from fitlab.families.lambert_sphere.program.table_export import DEFAULT_LOOKUP, DEFAULT_NODES, numpy_brdf
from fitlab.families.lambert_sphere.program.true_refit import true_runtime_model
from fitlab.families.lambert_sphere.targets import datasets as d
from fitlab.fit.metrics import relative_errors, summary
from fitlab.fit.refit import preset_metrics
from fitlab.report.methods import FitEntry, best_forms, origin_kind
from fitlab.store import FitFileError, fit_files, fits_folder, read_fit, strict_json

__all__ = ["audit", "directional_albedo", "richer_forms"]

GRAZING = 1.0 / 64.0
FURNACE_MU = (0.0, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0)


def _published_rows() -> list[dict]:
    rows = []
    for t in targets().values():
        for form_name, preset in t.published:
            m = preset_metrics(t, form_name, preset)
            rows.append(
                {
                    "target": t.name,
                    "form": form_name,
                    "preset": preset,
                    "claimed": t.claimed,
                    "error_measure": t.error_measure,
                    **m,
                }
            )
    # the same formulas against the other readings of kd (docs/model.md, "Albedo maps")
    valid = d.kd_of_c_validation()
    kd3 = spherical_albedo(valid.inputs["c"], phase="three_term")
    form = get_target("kd_of_c").forms["printed"]
    rows.append(
        {
            "target": "kd_of_c vs kd_three_term",
            "form": "printed",
            "preset": "paper",
            "claimed": "none stated",
            "error_measure": "relative",
            **summary(form("paper", valid.inputs["c"]), kd3, kd3, valid.inputs),
        }
    )
    valid = d.fm1_validation()
    form = get_target("fm1").forms["fast"]
    half = valid.y / 2.0
    rows.append(
        {
            "target": "fm1 vs printed eq. 28 (half)",
            "form": "fast",
            "preset": "paper",
            "claimed": "none stated",
            "error_measure": "relative to f^(0)",
            **summary(
                form("paper", valid.inputs["mu_i"], valid.inputs["mu_o"], valid.inputs["c"]),
                half,
                valid.aux["f0"],
                valid.inputs,
            ),
        }
    )
    return rows


def richer_forms(fits_dir: Path) -> dict:
    """part -> form of each runtime part's most accurate refit form in ``fits_dir`` (the lowest validation
    max error its fit file records, among fits not made by discover), where that is not the default
    form: the rule of the report's "refit, richer" model (:func:`fitlab.report.methods.best_forms`)."""
    entries = []
    for part in RUNTIME_PARTS:
        default = get_target(part).default_form
        for path in fit_files(Path(fits_dir), part):
            try:
                rec = read_fit(path)
            except FitFileError:
                continue  # an unreadable file is reported where the model that needs it is built
            max_rel = float(rec.get("validation", {}).get("max_rel", math.inf))
            entries.append(FitEntry(path, part, rec["form"], origin_kind(rec), rec["form"] == default, max_rel, rec))
    return best_forms(entries, {"refit"}, RUNTIME_PARTS)


def _runtime_models(fits_dir: Path) -> tuple[list[RuntimeModel], list[str]]:
    models = [runtime_model(v) for v in PRESET_VARIANTS]
    missing = []
    richer = richer_forms(fits_dir)
    for forms in (None, richer) if richer else (None,):
        try:
            models.append(runtime_model(fits_dir=fits_dir, forms=forms, model=DEFAULT_FORMS))
        except FitFileError as exc:
            missing.append(str(exc))
    models.append(true_runtime_model())  # the packaged parts fitted to the true BRDF, whatever fits_dir is
    return models, missing


#: the first rows of the runtime table against the true BRDF: fitlab's reference before the true-phase engine,
#: and the floor of the runtime structure f_1 + fm0 + fm1 cos phi + fm2 cos 2phi (its terms exact: orders >= 3
#: dropped)
MIXED_ROW = "mixed reference (exact.brdf, phase 'mixed')"
TRUE_FLOOR_ROW = "true ingredients (multiple-scattering orders >= 3 dropped)"
#: the row of the exported tables as `fitlab codegen --tables` ships them (their BRDF computed in double from
#: the float32 texture: fitlab.families.lambert_sphere.program.table_export.numpy_brdf)
TABLES_ROW = f"exported tables ({DEFAULT_NODES} nodes, {DEFAULT_LOOKUP}; fitlab codegen --tables)"


def _tables_candidate(mi, mo, ph, c) -> tuple:
    return TABLES_ROW, numpy_brdf()(mi, mo, ph, c), {}


def _runtime_rows(models) -> list[dict]:
    """The runtime models against the mixed reference (exact.brdf(phase="mixed"), the reference the runtime
    parts were fitted to), with its floor: exact ingredients, fm2 dropped."""
    valid = d.brdf_validation("mixed")
    mi, mo, ph, c = (valid.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    fm2 = multiple_scattering_modes(mi, mo, c, phase="mixed")[2]
    candidates = [("exact ingredients (fm2 dropped)", np.maximum(0.0, valid.y - fm2 * np.cos(2 * ph)), {})]
    candidates += [(m.name, m(mi, mo, ph, c), m.sources) for m in models] + [_tables_candidate(mi, mo, ph, c)]
    return _error_rows(valid, candidates)


def _runtime_true_rows(models) -> list[dict]:
    """The runtime models and the mixed reference itself against the true BRDF (exact.brdf(phase="true"))
    on the same points."""
    valid = d.brdf_validation("true")
    mixed = d.brdf_validation("mixed")
    for k in ("mu_i", "mu_o", "phi", "c"):
        if not np.array_equal(valid.inputs[k], mixed.inputs[k]):
            raise RuntimeError(f"the true and mixed BRDF validation sets differ in {k}")
    mi, mo, ph, c = (valid.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    u = -(mi * mo + np.sqrt((1.0 - mi * mi) * (1.0 - mo * mo)) * np.cos(ph))
    single = c * phase_function(u) / (mi + mo)
    kept = valid.aux["fm0"] + valid.aux["fm1"] * np.cos(ph) + valid.aux["fm2"] * np.cos(2 * ph)
    floor = np.maximum(0.0, single + kept)
    candidates = [(MIXED_ROW, mixed.y, {}), (TRUE_FLOOR_ROW, floor, {})]
    candidates += [(m.name, m(mi, mo, ph, c), m.sources) for m in models] + [_tables_candidate(mi, mo, ph, c)]
    return _error_rows(valid, candidates)


def _runtime_true_independent_rows(models) -> list[dict]:
    """The runtime models and the mixed reference against the true BRDF at random points no fit saw
    (:func:`...targets.datasets.brdf_true_independent`)."""
    valid = d.brdf_true_independent()
    mi, mo, ph, c = (valid.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    candidates = [(MIXED_ROW, brdf(mi, mo, ph, c, phase="mixed"), {})]
    candidates += [(m.name, m(mi, mo, ph, c), m.sources) for m in models] + [_tables_candidate(mi, mo, ph, c)]
    return _error_rows(valid, candidates)


def _error_rows(valid, candidates) -> list[dict]:
    mi, mo = valid.inputs["mu_i"], valid.inputs["mu_o"]
    nonzero = valid.y > 0
    away = nonzero & (mi >= GRAZING) & (mo >= GRAZING)
    rows = []
    for name, approx, sources in candidates:
        err = relative_errors(approx, valid.y, np.abs(valid.y))
        i = int(np.argmax(np.where(nonzero, err, -1.0)))
        j = int(np.argmax(np.where(away, err, -1.0)))
        rows.append(
            {
                "model": name,
                "sources": sources,
                "max_rel": float(err.max()),
                "max_rel_nonzero": float(err[nonzero].max()),
                "rms_rel_nonzero": float(np.sqrt(np.mean(err[nonzero] ** 2))),
                "max_rel_away": float(err[away].max()),
                "rms_rel_away": float(np.sqrt(np.mean(err[away] ** 2))),
                "worst": {k: float(v[i]) for k, v in valid.inputs.items() if k != "kd"},
                "worst_away": {k: float(v[j]) for k, v in valid.inputs.items() if k != "kd"},
                "points": int(err.size),
            }
        )
    return rows


def directional_albedo(model, mu_i: float, c: float = 1.0, n_phi: int = 96) -> float:
    """a(mu_i) = int_0^2pi int_0^1 f_r(mu_i, mu_o, phi, c) mu_o dmu_o dphi, by a graded Gauss rule in
    mu_o (resolves the 1/(mu_i + mu_o) pole at grazing) and Gauss-Legendre in phi on [0, pi] (f_r is even in phi)."""
    v, w = graded_gauss(16, 0.25, 1e-14)
    x, wx = gauss_legendre(n_phi)
    phi = np.pi * x
    f = model(np.full((v.size, phi.size), mu_i), v[:, None], phi[None, :], np.full((v.size, phi.size), c))
    return float(2.0 * np.pi * np.sum((w * v)[:, None] * wx[None, :] * f))


def _furnace_rows(models) -> list[dict]:
    rows = [
        {
            "model": "exact (fitlab.families.lambert_sphere.exact.albedo, phase 'true': whole phase function)",
            "albedo": {str(m): float(albedo(m, 1.0, phase="true")) for m in FURNACE_MU},
        },
        {
            "model": "exact (fitlab.families.lambert_sphere.exact.albedo, phase 'mixed')",
            "albedo": {str(m): float(albedo(m, 1.0, phase="mixed")) for m in FURNACE_MU},
        },
    ]
    for model in models:
        rows.append({"model": model.name, "albedo": {str(m): directional_albedo(model, m) for m in FURNACE_MU}})
    tables = numpy_brdf()
    rows.append({"model": TABLES_ROW, "albedo": {str(m): directional_albedo(tables, m) for m in FURNACE_MU}})
    for r in rows:
        r["max_abs_deviation"] = max(abs(a - 1.0) for a in r["albedo"].values())
    return rows


def _f(x: float) -> str:
    return "inf" if not math.isfinite(x) else f"{x:.2e}"


def _point(p: dict) -> str:
    return ", ".join(f"{k}={v:.4g}" for k, v in p.items() if k not in ("exact", "approx"))


def _markdown(result: dict) -> str:
    out = [
        "# Audit of the published approximations",
        "",
        "Generated by `fitlab audit` (do not edit); the numbers are in `docs/audit.json`.",
        "Errors are measured against `fitlab.families.lambert_sphere.exact` on the validation sets of `fitlab.families.lambert_sphere.targets`",
        "(see each target's error measure there); *max rel\\** leaves out the target's exact zeros, where any",
        "formula that misses the zero has an infinite relative error.",
        "",
        "## Published formulas",
        "",
        "| target | form / preset | claimed | max rel | max rel* | RMS rel | worst point (exact, approx) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result["published"]:
        w = r["worst"]
        out.append(
            f"| {r['target']} | {r['form']} / {r['preset']} | {r['claimed']} | {_f(r['max_rel'])} | "
            f"{_f(r['max_rel_nonzero'])} | {_f(r['rms_rel'])} | {_point(w)} ({w['exact']:.6g}, {w['approx']:.6g}) |"
        )
    out += [
        "",
        '## Runtime model (docs/model.md) against the mixed reference (`exact.brdf(phase="mixed")`)',
        "",
        f"Validation set: {result['runtime_grid']}. *away* = mu_i, mu_o >= 1/64. Variants: `paper_printed`",
        "(all printed, 6 pi / 384 pi, H1 read as printed), `paper` (printed coefficients, H1 in the renderer's",
        "reading, the exact 3 pi / 192 pi), `renderer` (the renderer's coefficients), `refit` (fits/, default",
        "forms), `refit (...)` (the richer forms).",
        "",
        "| model | max rel | max rel* | RMS rel* | max rel, away | RMS rel, away | worst point | worst away |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["runtime"]:
        out.append(
            f"| {r['model']} | {_f(r['max_rel'])} | {_f(r['max_rel_nonzero'])} | {_f(r['rms_rel_nonzero'])} | "
            f"{_f(r['max_rel_away'])} | {_f(r['rms_rel_away'])} | {_point(r['worst'])} | {_point(r['worst_away'])} |"
        )
    for m in result["missing_fits"]:
        out.append(f"\n(not measured: {m})")
    out += [
        "",
        '## Runtime model against the true BRDF (`exact.brdf(phase="true")`)',
        "",
        "The same points; the reference is the BRDF of the material: the whole phase function in every",
        'collision (docs/model.md, "Which phase function"). The runtime parts of the `refit` rows were fitted to',
        "the mixed reference above (true single scattering, three-term multiple scattering); its own row gives",
        "its gap. The parts of the row `refit to the true BRDF` were fitted to the true BRDF's Fourier orders 0 to 2",
        'in the same structure and forms (fitlab/fits/true; docs/model.md, "Parts fitted to the true BRDF").',
        "The floor of the runtime structure is the row with its terms exact (true single scattering and the",
        "true multiple scattering's Fourier orders 0 to 2): what refitted parts could reach at best.",
        "The exported tables (`fitlab codegen --tables`) carry the true BRDF: the three-term Fourier orders from",
        "the H-function tables, each corrected to the whole phase function by a table of Q_m = (fm_m,true -",
        'fm_m,three-term)/fm_0,three-term (docs/model.md, "The exported tables"); their row against the mixed',
        "reference in the table above is the mixed reference's own gap.",
        f"Validation set: {result['runtime_true_grid']}.",
        "",
        "| model | max rel | max rel* | RMS rel* | max rel, away | RMS rel, away | worst point | worst away |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["runtime_true"]:
        out.append(
            f"| {r['model']} | {_f(r['max_rel'])} | {_f(r['max_rel_nonzero'])} | {_f(r['rms_rel_nonzero'])} | "
            f"{_f(r['max_rel_away'])} | {_f(r['rms_rel_away'])} | {_point(r['worst'])} | {_point(r['worst_away'])} |"
        )
    out += [
        "",
        "### At independent points",
        "",
        "The true BRDF at random points no fit saw (the parts fitted to the true BRDF were fitted on another",
        f"lattice): {result['runtime_true_independent_grid']}.",
        "",
        "| model | max rel | max rel* | RMS rel* | max rel, away | RMS rel, away | worst point | worst away |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["runtime_true_independent"]:
        out.append(
            f"| {r['model']} | {_f(r['max_rel'])} | {_f(r['max_rel_nonzero'])} | {_f(r['rms_rel_nonzero'])} | "
            f"{_f(r['max_rel_away'])} | {_f(r['rms_rel_away'])} | {_point(r['worst'])} | {_point(r['worst_away'])} |"
        )
    out += [
        "",
        "## White furnace (c = 1): directional albedo, should be 1",
        "",
        "| model | " + " | ".join(f"mu_i = {m:g}" for m in FURNACE_MU) + " | max abs(a - 1) |",
        "|---|" + "---|" * (len(FURNACE_MU) + 1),
    ]
    for r in result["furnace"]:
        out.append(
            f"| {r['model']} | "
            + " | ".join(f"{a:.6f}" for a in r["albedo"].values())
            + f" | {r['max_abs_deviation']:.2e} |"
        )
    return "\n".join(out) + "\n"


def audit(fits_dir: Path | None = None, show_progress: bool = False) -> Outputs:
    """The audit of the fits in ``fits_dir`` (None: the packaged fits): its summary (the rows, a dict) and
    its two files, audit.json and audit.md, as bytes (the caller writes them; ``fitlab audit`` as one unit);
    ``show_progress``: a bar over its stages on stderr."""
    from tqdm import tqdm

    with tqdm(total=7, desc="audit", unit="stage", disable=not show_progress, leave=False) as bar:

        def stage(name, value):
            bar.set_postfix_str(name, refresh=False)
            bar.update()
            return value

        models, missing = _runtime_models(fits_folder(fits_dir))
        published = stage("published formulas", _published_rows())
        grid = stage("BRDF validation set", d.brdf_validation("mixed").grid)
        runtime = stage("runtime models", _runtime_rows(models))
        true_grid = stage("true BRDF validation set", d.brdf_validation("true").grid)
        runtime_true = stage("runtime models against the true BRDF", _runtime_true_rows(models))
        independent_grid = d.brdf_true_independent().grid
        runtime_true_independent = stage("... at independent points", _runtime_true_independent_rows(models))
        furnace = stage("white furnace", _furnace_rows(models))
    result = {
        "published": published,
        "runtime_grid": grid,
        "runtime": runtime,
        "runtime_true_grid": true_grid,
        "runtime_true": runtime_true,
        "runtime_true_independent_grid": independent_grid,
        "runtime_true_independent": runtime_true_independent,
        "missing_fits": missing,
        "furnace": furnace,
    }
    return Outputs(result, {"audit.json": strict_json(result).encode(), "audit.md": _markdown(result).encode()})
