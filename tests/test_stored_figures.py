"""The headline figures stored in fits/*.json and docs/audit.json, recomputed.

Every committed fit is loaded as a user loads it (fitlab.store.load: the stored
expression text through the restricted parser, the stored parameters),
evaluated on its target's validation set restricted to the fit's domain, and its
max, RMS and max-without-zeros relative errors are recomputed here, in plain
numpy and math.fsum, without fitlab.fit.metrics; the stored figures must agree
to RTOL.  The same for every stored "published" row (a registered form with the
preset's parameters, the parameters the row records) and for the rows of
docs/audit.json that are cheap to recompute: the published formulas, the
runtime models built from presets and from fits/, and the white furnace
(directional albedo by an independent quadrature).  Two audit rows need exact
values that are slow to compute (fm2 on the BRDF validation set, 18 s; the
three-term spherical albedo, 47 s); they are marked benchmark
(``pytest -m benchmark``).

The stored figures are written by fitlab.fit.metrics.summary, so a wrong summary
shows here as a mismatch with every file; summary itself is also checked
against the independent implementation on random data.

Tolerance: the fit file's figures come from the registered form's numpy
function, the recomputation from the stored expression text with the parameters
substituted, so the two agree to rounding; the largest difference seen is
3e-10 relative (F.rational_4_3, max_rel 2.7e-7, set by cancellation at small c).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from fitlab.core import get_target, targets
from fitlab.families.lambert_sphere.program.report.audit import TABLES_ROW
from fitlab.families.lambert_sphere.program.table_export import numpy_brdf
from fitlab.forms.symbolic import lambdify_numpy, parse_expression, symbols
from fitlab.store import decode_nonfinite, load

ROOT = Path(__file__).resolve().parents[1]
FITS = sorted((ROOT / "fitlab" / "fits").glob("*.json"))
AUDIT = ROOT / "docs" / "audit.json"
RTOL = 1e-8


# -- an independent implementation of the error measures -----------------------------------------
def rel_errors(approx, exact, scale) -> np.ndarray:
    """|approx - exact| / scale; at scale 0 (an exact zero): 0 where approx == exact, else inf;
    a non-finite approx is an infinite error."""
    approx = np.asarray(approx, dtype=float).ravel()
    exact = np.asarray(exact, dtype=float).ravel()
    scale = np.broadcast_to(np.asarray(scale, dtype=float), exact.shape).ravel()
    err = np.empty(exact.shape)
    diff = np.abs(approx - exact)
    pos = scale > 0
    err[pos] = diff[pos] / scale[pos]
    err[~pos] = np.where(diff[~pos] == 0.0, 0.0, math.inf)
    err[~np.isfinite(approx)] = math.inf
    return err


def figures(approx, exact, scale) -> dict:
    err = rel_errors(approx, exact, scale)
    n = err.size
    nonzero = np.broadcast_to(np.asarray(scale, dtype=float), np.shape(exact)).ravel() > 0
    # RMS by compensated summation in Python floats: no numpy reduction in common with summary()
    rms = math.inf if not np.all(np.isfinite(err)) else math.sqrt(math.fsum((err * err).tolist()) / n)
    absolute = np.abs(np.asarray(approx, dtype=float).ravel() - np.asarray(exact, dtype=float).ravel())
    absolute[~np.isfinite(absolute)] = math.inf
    return {
        "max_rel": max(err.tolist()),
        "rms_rel": rms,
        "max_rel_nonzero": max(err[nonzero].tolist()) if nonzero.any() else 0.0,
        "max_abs": max(absolute.tolist()),
        "points": n,
        "_err": err,
    }


def assert_same(stored, got, what: str):
    stored = float(stored)
    if math.isinf(stored) or math.isinf(got):
        assert stored == got, f"{what}: stored {stored!r}, recomputed {got!r}"
    else:
        # abs: an error at the rounding level is itself rounding noise (E_avg_on's fit is exact to 3e-13; the Fresnel
        # fits of constant-index dielectrics are exact, their errors a few ulp of F <= 1 that move between points
        # with the order of evaluation)
        assert got == pytest.approx(stored, rel=RTOL, abs=1e-14), f"{what}: stored {stored!r}, recomputed {got!r}"


def check_row(
    stored: dict, got: dict, ds, what: str, exact=None, keys=("max_rel", "rms_rel", "max_rel_nonzero", "max_abs")
):
    """``stored`` (a fit file's or the audit's row) against ``got`` (:func:`figures`) on dataset ``ds``
    (``exact``: the exact values where they are not ds.y)."""
    exact = ds.y if exact is None else exact
    assert stored["points"] == got["points"], f"{what}: {stored['points']} points stored, {got['points']} in the set"
    for key in keys:
        assert_same(stored[key], got[key], f"{what} {key}")
    if "worst" in stored:
        # the stored worst point lies in the set, with the stored exact value, and its error is the maximum
        w = stored["worst"]
        # inputs computed by the exact engine (kd) may differ in the last bits between numpy/scipy releases
        at = np.ones(len(ds), dtype=bool)
        for name, value in w.items():
            if name in ds.inputs:
                at &= np.isclose(ds.inputs[name], value, rtol=1e-13, atol=0.0)
        assert at.any(), f"{what}: the stored worst point {w} is not in the validation set"
        i = int(np.flatnonzero(at)[0])
        if "exact" in w:
            want = pytest.approx(float(exact[i]), rel=1e-12, abs=1e-300)
            assert w["exact"] == want, f"{what}: worst point's exact value"
        assert_same(stored["max_rel"], float(got["_err"][i]), f"{what} error at the worst point")


def preset_values(target, form_name: str, params: dict, ds) -> np.ndarray:
    """A registered form with the given parameters on ``ds``: its expression text read back by the
    restricted parser, the numbers substituted, lambdified (not Form.numpy_function, which wrote the
    stored figures).  Not through FitFunction: the audit's mixed BRDF set holds kd = kd_mixed(1) = 1 + 1e-5,
    just outside the domain a fit file may state."""
    form = target.forms[form_name]
    expr = parse_expression(form.expression, (*form.inputs, *form.params))
    expr = expr.xreplace({sp.Symbol(k, real=True): sp.Float(repr(float(v)), 17) for k, v in params.items()})
    f = lambdify_numpy(symbols(form.inputs), expr)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = f(*(ds.inputs[name] for name in form.inputs))
    return np.broadcast_to(np.asarray(out, dtype=float), ds.y.shape)


def evaluate(f, ds) -> np.ndarray:
    return f(**{name: ds.inputs[name] for name in f.inputs})


def _validation(target, domain=None):
    ds = target.validation()
    return ds if domain is None else ds.restricted({k: tuple(v) for k, v in domain.items()})


# -- fits/*.json -----------------------------------------------------------------------------------
def test_every_target_has_a_committed_fit():
    # every Lambert-sphere target (families registered by other tests, e.g. a toy, have no committed fits)
    committed = {json.loads(p.read_text())["target"] for p in FITS}
    assert committed <= set(targets())
    assert {t.name for t in targets().values() if t.family == "lambert_sphere"} <= committed


@pytest.mark.parametrize("path", FITS, ids=[p.name for p in FITS])
def test_fit_validation_figures_are_recomputed(path):
    f = load(path)
    rec = f.record
    target = get_target(rec["target"])
    ds = _validation(target, rec["domain"])
    stored = rec["validation"]
    got = figures(evaluate(f, ds), ds.y, target.scale(ds))
    check_row(stored, got, ds, f"{path.name} validation")


@pytest.mark.parametrize("path", FITS, ids=[p.name for p in FITS])
def test_fit_published_rows_are_recomputed(path):
    rec = decode_nonfinite(json.loads(path.read_text()))
    target = get_target(rec["target"])
    assert [(p["form"], p["preset"]) for p in rec["published"]] == [tuple(x) for x in target.published]
    ds = _validation(target, rec["domain"])
    scale = target.scale(ds)
    for row in rec["published"]:
        what = f"{path.name} published {row['form']}/{row['preset']}"
        preset = dict(target.forms[row["form"]].presets[row["preset"]])
        # to 4 ulps: the Fresnel family's presets are computed from measured spectra with numpy's reductions, whose
        # SIMD paths (chosen by the processor) round the last bit differently from one machine to another
        assert row["params"].keys() == preset.keys(), f"{what}: params are not the preset's"
        for name, value in preset.items():
            assert row["params"][name] == pytest.approx(value, rel=4 * np.finfo(float).eps, abs=0), f"{what}: {name}"
        approx = preset_values(target, row["form"], row["params"], ds)
        check_row(row["validation"], figures(approx, ds.y, scale), ds, what)


# -- docs/audit.json -------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def audit():
    return decode_nonfinite(json.loads(AUDIT.read_text()))


def test_audit_published_rows_are_recomputed(audit):
    rows = {(r["target"], r["form"], r["preset"]): r for r in audit["published"]}
    for target in (t for t in targets().values() if t.family == "lambert_sphere"):  # the audit's family
        ds = _validation(target)
        for form_name, preset in target.published:
            what = f"audit.json published {target.name} {form_name}/{preset}"
            assert (target.name, form_name, preset) in rows, f"{what}: missing"
            params = target.forms[form_name].presets[preset]
            approx = preset_values(target, form_name, params, ds)
            check_row(rows[(target.name, form_name, preset)], figures(approx, ds.y, target.scale(ds)), ds, what)


def test_audit_fm1_against_printed_eq28_is_recomputed(audit):
    (row,) = [r for r in audit["published"] if r["target"] == "fm1 vs printed eq. 28 (half)"]
    target = get_target("fm1")
    ds = _validation(target)
    approx = preset_values(target, "fast", target.forms["fast"].presets["paper"], ds)
    half = ds.y / 2.0
    check_row(row, figures(approx, half, ds.aux["f0"]), ds, "audit.json fm1 vs eq. 28 (half)", exact=half)


@pytest.mark.benchmark
def test_audit_kd_against_three_term_albedo_is_recomputed(audit):
    from fitlab.families.lambert_sphere.exact import spherical_albedo

    (row,) = [r for r in audit["published"] if r["target"] == "kd_of_c vs kd_three_term"]
    target = get_target("kd_of_c")
    ds = _validation(target)
    kd3 = spherical_albedo(ds.inputs["c"], phase="three_term")
    approx = preset_values(target, "printed", target.forms["printed"].presets["paper"], ds)
    check_row(row, figures(approx, kd3, np.abs(kd3)), ds, "audit.json kd_of_c vs kd_three_term", exact=kd3)


@pytest.fixture(scope="module")
def runtime_models():
    from fitlab.codegen import DEFAULT_FORMS
    from fitlab.families.lambert_sphere.program.report.audit import richer_forms
    from fitlab.families.lambert_sphere.program.runtime import PRESET_VARIANTS, runtime_model
    from fitlab.families.lambert_sphere.program.true_refit import true_runtime_model

    models = [runtime_model(v) for v in PRESET_VARIANTS]
    models.append(runtime_model(fits_dir=ROOT / "fitlab" / "fits", model=DEFAULT_FORMS))
    richer = richer_forms(ROOT / "fitlab" / "fits")
    if richer:
        models.append(runtime_model(fits_dir=ROOT / "fitlab" / "fits", forms=richer, model=DEFAULT_FORMS))
    models.append(true_runtime_model(ROOT / "fitlab" / "fits" / "true"))  # the parts fitted to the true BRDF
    return models


def _runtime_figures(approx, exact, mi, mo):
    err = rel_errors(approx, exact, np.abs(exact))
    nonzero = exact > 0
    away = nonzero & (mi >= 1 / 64) & (mo >= 1 / 64)

    def rms(e):
        return math.sqrt(math.fsum((e * e).tolist()) / e.size) if np.all(np.isfinite(e)) else math.inf

    return {"max_rel": max(err.tolist()), "max_rel_nonzero": max(err[nonzero].tolist()),
            "rms_rel_nonzero": rms(err[nonzero]), "max_rel_away": max(err[away].tolist()),
            "rms_rel_away": rms(err[away]), "points": err.size, "_err": err, "_nonzero": nonzero}  # fmt: skip


_RUNTIME_KEYS = ("max_rel", "max_rel_nonzero", "rms_rel_nonzero", "max_rel_away", "rms_rel_away")


def _check_runtime_row(row, got, ds, what):
    assert row["points"] == got["points"], what
    for key in _RUNTIME_KEYS:
        assert_same(row[key], got[key], f"{what} {key}")
    # the stored worst point (over the nonzero points) carries the max_rel_nonzero error
    at = got["_nonzero"].copy()
    for name, value in row["worst"].items():
        at &= ds.inputs[name] == value
    assert at.any(), f"{what}: worst point {row['worst']} not in the set"
    assert_same(row["max_rel_nonzero"], float(got["_err"][np.flatnonzero(at)[0]]), f"{what} error at the worst point")


def test_audit_runtime_rows_are_recomputed(audit, runtime_models):
    from fitlab.families.lambert_sphere.targets import datasets as d

    ds = d.brdf_validation("mixed")
    assert audit["runtime_grid"] == ds.grid
    mi, mo, ph, c = (ds.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    rows = {r["model"]: r for r in audit["runtime"]}
    assert set(rows) - {m.name for m in runtime_models} == {"exact ingredients (fm2 dropped)", TABLES_ROW}
    for model in runtime_models:
        row = rows[model.name]
        assert row["sources"] == model.sources, f"audit.json runtime {model.name}: sources"
        got = _runtime_figures(model(mi, mo, ph, c), ds.y, mi, mo)
        _check_runtime_row(row, got, ds, f"audit.json runtime {model.name}")
    got = _runtime_figures(numpy_brdf()(mi, mo, ph, c), ds.y, mi, mo)
    _check_runtime_row(rows[TABLES_ROW], got, ds, "audit.json exported tables")


def test_audit_runtime_true_rows_are_recomputed(audit, runtime_models):
    """The rows against the true BRDF: the runtime models and the mixed reference, recomputed on the true set."""
    from fitlab.families.lambert_sphere import exact
    from fitlab.families.lambert_sphere.program.report.audit import MIXED_ROW, TRUE_FLOOR_ROW
    from fitlab.families.lambert_sphere.targets import datasets as d

    ds = d.brdf_validation("true")
    assert audit["runtime_true_grid"] == ds.grid
    mixed = d.brdf_validation("mixed")
    mi, mo, ph, c = (ds.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    for k, v in (("mu_i", mi), ("mu_o", mo), ("phi", ph), ("c", c)):
        np.testing.assert_array_equal(mixed.inputs[k], v)
    rows = {r["model"]: r for r in audit["runtime_true"]}
    assert set(rows) == {m.name for m in runtime_models} | {MIXED_ROW, TRUE_FLOOR_ROW, TABLES_ROW}
    got = _runtime_figures(numpy_brdf()(mi, mo, ph, c), ds.y, mi, mo)
    _check_runtime_row(rows[TABLES_ROW], got, ds, "audit.json exported tables vs true")
    _check_runtime_row(rows[MIXED_ROW], _runtime_figures(mixed.y, ds.y, mi, mo), ds, "audit.json mixed vs true")
    # the floor: the true BRDF less its multiple-scattering orders >= 3; at one albedo the set's orders 0 to 2
    # with the engine's higher orders and the closed-form single scattering add up to the set's BRDF
    single = c * exact.phase_function(-(mi * mo + np.sqrt((1 - mi * mi) * (1 - mo * mo)) * np.cos(ph))) / (mi + mo)
    kept = single + ds.aux["fm0"] + ds.aux["fm1"] * np.cos(ph) + ds.aux["fm2"] * np.cos(2 * ph)
    floor = np.maximum(0.0, kept)
    _check_runtime_row(rows[TRUE_FLOOR_ROW], _runtime_figures(floor, ds.y, mi, mo), ds, "audit.json true floor")
    cv = float(np.unique(c)[9])  # c = 1 - (15/32)^2, mid-range
    sel = c == cv
    modes = exact.multiple_scattering_modes(mi[sel], mo[sel], cv, phase="true")
    higher = sum(fm * np.cos(m * ph[sel]) for m, fm in enumerate(modes) if m >= 3)
    np.testing.assert_allclose(kept[sel] + higher, ds.y[sel], rtol=1e-12)
    for model in runtime_models:
        got = _runtime_figures(model(mi, mo, ph, c), ds.y, mi, mo)
        _check_runtime_row(rows[model.name], got, ds, f"audit.json runtime {model.name} vs true")


def test_audit_runtime_true_independent_rows_are_recomputed(audit, runtime_models):
    """The rows at the independent random points: the runtime models and the mixed reference against the true
    BRDF, recomputed; the set's points are random, apart from every training lattice."""
    from fitlab.families.lambert_sphere import exact
    from fitlab.families.lambert_sphere.program.report.audit import MIXED_ROW
    from fitlab.families.lambert_sphere.targets import datasets as d

    ds = d.brdf_true_independent()
    assert audit["runtime_true_independent_grid"] == ds.grid
    mi, mo, ph, c = (ds.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    rows = {r["model"]: r for r in audit["runtime_true_independent"]}
    assert set(rows) == {m.name for m in runtime_models} | {MIXED_ROW, TABLES_ROW}
    got = _runtime_figures(numpy_brdf()(mi, mo, ph, c), ds.y, mi, mo)
    _check_runtime_row(rows[TABLES_ROW], got, ds, "audit.json exported tables vs true, independent")
    mixed = np.empty_like(ds.y)
    for cv in np.unique(c):
        sel = c == cv
        mixed[sel] = exact.brdf(mi[sel], mo[sel], ph[sel], cv, phase="mixed")
    _check_runtime_row(
        rows[MIXED_ROW], _runtime_figures(mixed, ds.y, mi, mo), ds, "audit.json mixed vs true, independent"
    )
    for model in runtime_models:
        got = _runtime_figures(model(mi, mo, ph, c), ds.y, mi, mo)
        _check_runtime_row(rows[model.name], got, ds, f"audit.json runtime {model.name} vs true, independent")


@pytest.mark.benchmark
def test_audit_runtime_floor_row_is_recomputed(audit):
    from fitlab.families.lambert_sphere.exact import multiple_scattering_modes
    from fitlab.families.lambert_sphere.targets import datasets as d

    ds = d.brdf_validation("mixed")
    mi, mo, ph, c = (ds.inputs[k] for k in ("mu_i", "mu_o", "phi", "c"))
    fm2 = multiple_scattering_modes(mi, mo, c, phase="mixed")[2]
    (row,) = [r for r in audit["runtime"] if r["model"] == "exact ingredients (fm2 dropped)"]
    approx = np.maximum(0.0, ds.y - fm2 * np.cos(2 * ph))
    _check_runtime_row(row, _runtime_figures(approx, ds.y, mi, mo), ds, "audit.json runtime floor")


def directional_albedo(model, mu_i: float, c: float = 1.0) -> float:
    """int_{-pi}^{pi} int_0^1 f_r mu_o dmu_o dphi: 12-point Gauss-Legendre on 57 geometric panels in mu_o
    (1e-14 .. 1, for the 1/(mu_i + mu_o) pole at grazing) and the 256-point midpoint rule over the period
    in phi; independent of the audit's graded Gauss rule (agreement seen: 1e-9)."""
    edges = np.concatenate(([0.0], np.logspace(-14, 0, 57)))
    x, w = np.polynomial.legendre.leggauss(12)
    lo, hi = edges[:-1, None], edges[1:, None]
    mu = (0.5 * (hi - lo) * (x + 1) + lo).ravel()
    wmu = (0.5 * (hi - lo) * w).ravel()
    n = 256
    phi = (np.arange(n) + 0.5) * 2 * np.pi / n - np.pi
    f = model(np.full((mu.size, n), mu_i), mu[:, None], phi[None, :], np.full((mu.size, n), c))
    return float(np.sum((wmu * mu)[:, None] * f) * 2 * np.pi / n)


def test_audit_furnace_rows_are_recomputed(audit, runtime_models):
    from fitlab.families.lambert_sphere.exact import albedo

    rows = {r["model"]: r for r in audit["furnace"]}
    exact_names = {
        phase: name
        for name in rows
        if name.startswith("exact (")
        for phase in ("true", "mixed")
        if f"phase '{phase}'" in name
    }
    assert set(rows) - {m.name for m in runtime_models} == set(exact_names.values()) | {TABLES_ROW}
    assert set(exact_names) == {"true", "mixed"}
    for model in [*runtime_models, numpy_brdf()]:
        row = rows[getattr(model, "name", TABLES_ROW)]
        for mu, stored in row["albedo"].items():
            got = directional_albedo(model, float(mu))
            assert got == pytest.approx(stored, abs=1e-7), f"furnace {row['model']} mu_i = {mu}"
    for row in rows.values():
        assert row["max_abs_deviation"] == pytest.approx(max(abs(a - 1.0) for a in row["albedo"].values()), rel=1e-12)
    for mu, stored in rows[exact_names["mixed"]]["albedo"].items():
        got = float(albedo(float(mu), 1.0, phase="mixed"))
        assert got == pytest.approx(stored, rel=1e-12), f"furnace exact (mixed) mu_i = {mu}"
        assert abs(got - 1.0) < 2e-4  # the true phase function's excess over the three-term one is small
    for mu, stored in rows[exact_names["true"]]["albedo"].items():
        got = float(albedo(float(mu), 1.0, phase="true"))
        assert got == pytest.approx(stored, rel=1e-12), f"furnace exact (true) mu_i = {mu}"
        assert abs(got - 1.0) < 1e-12  # the whole phase function in every collision conserves energy


# -- fitlab.fit.metrics.summary against the independent implementation ---------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_summary_matches_an_independent_computation(seed):
    from fitlab.fit.metrics import relative_errors, summary

    rng = np.random.default_rng(seed)
    n = 1000
    x = rng.uniform(0, 1, n)
    exact = rng.normal(size=n)
    approx = exact * (1 + rng.normal(scale=1e-2, size=n)) + rng.normal(scale=1e-3, size=n)
    scale = np.abs(exact)
    got = summary(approx, exact, scale, {"x": x})
    want = figures(approx, exact, scale)
    for key in ("max_rel", "rms_rel", "max_rel_nonzero", "max_abs"):
        assert got[key] == pytest.approx(want[key], rel=1e-12), key
    assert got["points"] == n
    i = int(np.argmax(want["_err"]))
    assert got["worst"] == {"x": x[i], "exact": exact[i], "approx": approx[i]}
    np.testing.assert_allclose(relative_errors(approx, exact, scale), want["_err"], rtol=1e-15)
    # RMS is not the mean, nor the max: a heavy tail separates the three
    err = want["_err"]
    assert got["rms_rel"] == pytest.approx(math.sqrt(np.mean(err**2)), rel=1e-12)
    assert np.mean(err) < got["rms_rel"] * (1 - 1e-3) and got["rms_rel"] < got["max_rel"]


def test_summary_on_exact_zeros_and_nan():
    from fitlab.fit.metrics import summary

    exact = np.array([0.0, 0.0, 1.0, 2.0, 4.0])
    approx = np.array([0.0, 1e-9, 1.5, 2.0, 3.0])  # a missed zero (inf), a hit zero (0), 0.5, 0, 0.25
    got = summary(approx, exact, np.abs(exact), {"x": np.arange(5.0)})
    assert got["max_rel"] == math.inf and got["rms_rel"] == math.inf
    assert got["max_rel_nonzero"] == 0.5 and got["max_abs"] == 1.0 and got["worst"]["x"] == 1.0
    got = summary(approx[2:], exact[2:], exact[2:], {"x": np.arange(3.0)})
    assert got["rms_rel"] == pytest.approx(math.sqrt((0.25 + 0 + 0.0625) / 3), rel=1e-15)
    got = summary(np.array([1.0, np.nan]), np.array([1.0, 1.0]), np.ones(2), {"x": np.arange(2.0)})
    assert got["max_rel"] == math.inf and got["rms_rel"] == math.inf and got["worst"]["x"] == 1.0


def test_model_doc_states_how_far_the_true_fit_parts_moved():
    """docs/model.md, "Parts fitted to the true BRDF": how far the parts moved from their three-term targets, as
    their fit files record it (the section's table is rendered from docs/audit.json when the site is built)."""
    text = (ROOT / "docs" / "model.md").read_text()
    section = text[text.index("### Parts fitted to the true BRDF") : text.index("## The runtime BRDF")]
    moved = {
        p: json.loads((ROOT / "fitlab" / "fits" / "true" / f).read_text())["validation"]["max_rel"]
        for p, f in (("H0", "H0.log_exp_true.json"), ("l", "l.cubic.json"))
    }
    assert f"H0 moves by up to {100 * moved['H0']:.1f} %, l by {100 * moved['l']:.0f} %" in " ".join(section.split())
