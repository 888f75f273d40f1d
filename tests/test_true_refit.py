"""The runtime model's parts fitted to the true BRDF (fitlab.families.lambert_sphere.program.true_refit):
the joint forms are the runtime structure's terms, the packaged fits make a model that reaches the true BRDF
(measured here against exact.brdf(phase="true") at points of the test's own), conserves energy and is 0 at
c = 0, and the fit files say what they are."""

import json
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from fitlab.core import get_form
from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, runtime_terms
from fitlab.families.lambert_sphere.program.report.audit import directional_albedo
from fitlab.families.lambert_sphere.program.runtime import TRUE_FORMS, runtime_model
from fitlab.families.lambert_sphere.program.true_refit import (
    GOAL_MU_MIN,
    GRAZING_WEIGHT,
    JOINT_PHI,
    ORDER_PARTS,
    START_FORMS,
    TRUE_FITS,
    joint_form,
    order_form,
    start_values,
    true_runtime_model,
)
from fitlab.fit.verify import verify_fit
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import fit_source, load

ROOT = Path(__file__).resolve().parents[1]


def _start_parts() -> dict:
    """{part: its form in the model "true" at its start values}, independently of the joint forms."""
    return {p: get_form(p, TRUE_FORMS[p]).expr.xreplace({sp.Symbol(k, real=True): sp.Float(v)
                                                         for k, v in start_values(p, TRUE_FORMS[p]).items()})
            for p in TRUE_FORMS}  # fmt: skip


def test_start_values_are_the_three_term_fits():
    """A part's start is its packaged fit to its own target; a log_exp_true H starts at its log_exp fit, the
    power of mu that form lacks at 0."""
    for part, form in TRUE_FORMS.items():
        start = start_values(part, form)
        source = load(fit_source(None, part, START_FORMS.get(form, form)))
        assert set(start) == set(get_form(part, form).params)
        assert all(start[k] == source.params.get(k, 0.0) for k in start), part
    assert (
        start_values("H1", "log_exp_true")["a04"] == 0.0 and "a04" not in load(fit_source(None, "H1", "log_exp")).params
    )


def test_true_fits_are_the_packaged_folder():
    assert TRUE_FITS == ROOT / "fitlab" / "fits" / "true"
    names = sorted(p.name for p in TRUE_FITS.glob("*.json"))
    assert len(names) == len(RUNTIME_PARTS) + 1
    assert {json.loads((TRUE_FITS / n).read_text())["target"] for n in names} == {*RUNTIME_PARTS, ORDER2_PART}


@pytest.mark.parametrize("order", [0, 1, 2])
def test_order_form_is_the_runtime_term(order):
    """At its start (start_values), the joint form of an order is the runtime structure's term of that order built
    from its parts' forms at the same values."""
    form, start = order_form(order)
    parts = _start_parts()
    term = lambdify_numpy(symbols(("mu_i", "mu_o", "c")), runtime_terms(parts)[f"m{order}"])
    rng = np.random.default_rng(order)
    mi, mo, c = rng.uniform(0.0, 1.0, (3, 200))
    mi[:3], mo[:3], c[:3] = (1e-6, 0.3, 1.0), (0.5, 1e-6, 1.0), (0.5, 1.0, 1e-4)
    want = term(mi, mo, c)
    got = form.numpy_function(form.vector(start), mi, mo, c)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-300)
    assert set(form.params) == {f"{p}_{q}" for p in ORDER_PARTS[order] for q in get_form(p, TRUE_FORMS[p]).params}
    assert not (form.expr.free_symbols & {sp.Symbol("phi", real=True)})


def test_joint_form_is_the_runtime_structure():
    """At its start, the joint form of stage 2 is the runtime model of its parts' forms at the same values without
    its energy scale and clamp: f_1 + fm0 + fm1 cos phi + fm2 cos 2phi, every part's parameters free."""
    from fitlab.families.lambert_sphere.forms.brdf import runtime_brdf

    form, start = joint_form()
    parts = _start_parts()
    unscaled = lambdify_numpy(
        symbols(("mu_i", "mu_o", "phi", "c")), next(a for a in runtime_brdf(parts).args if a != 0)
    )
    rng = np.random.default_rng(5)
    mi, mo, phi, c = rng.uniform(0.0, 1.0, (4, 300))
    mi[:3], mo[:3], c[:3] = (1e-6, 0.3, 1.0), (0.5, 1e-6, 1.0), (0.5, 1.0, 1e-4)
    phi *= np.pi
    np.testing.assert_allclose(
        form.numpy_function(form.vector(start), mi, mo, phi, c), unscaled(mi, mo, phi, c), rtol=1e-12, atol=1e-300
    )
    assert len(form.params) == sum(len(get_form(p, TRUE_FORMS[p]).params) for p in parts)
    assert not form.fixed


def test_joint_training_is_the_true_brdf_of_orders_0_to_2():
    """Stage 2's training values are the true BRDF less its orders >= 3 (2e-5 of f_r at most), checked against
    exact.brdf at a few of its points; the weights are GRAZING_WEIGHT exactly below the goal's edge."""
    from fitlab.families.lambert_sphere.program.true_refit import joint_training

    train, weights = joint_training()
    x = train.inputs
    assert np.array_equal(np.unique(x["phi"]), JOINT_PHI)
    low = np.minimum(x["mu_i"], x["mu_o"]) < GOAL_MU_MIN
    assert np.all(weights[low] == GRAZING_WEIGHT) and np.all(weights[~low] == 1.0) and low.any()
    pick = np.flatnonzero((x["c"] == 0.02) & (x["mu_i"] >= 0.01) & (x["mu_o"] >= 0.01))[::37]
    assert pick.size > 10
    want = exact.brdf(x["mu_i"][pick], x["mu_o"][pick], x["phi"][pick], 0.02, phase="true")
    np.testing.assert_allclose(train.y[pick], want, rtol=2e-5)


@pytest.fixture(scope="module")
def true_model():
    return true_runtime_model()


def _points(c, n, seed):
    """Random (mu_i, mu_o, phi) with mu in [0.01, 1], plus the grazing forward-scattering edge mu_i = mu_o = 0.01."""
    rng = np.random.default_rng(seed)
    mi, mo = rng.uniform(0.01, 1.0, (2, n))
    phi = rng.uniform(0.0, np.pi, n)
    mi, mo, phi = (
        np.concatenate((a, e))
        for a, e in zip((mi, mo, phi), ((0.01, 0.01, 0.01), (0.01, 0.01, 0.2), (np.pi, 0.0, np.pi)))
    )
    return mi, mo, phi


@pytest.mark.parametrize("c", [0.02, 0.37, 1.0])
def test_true_model_reaches_the_true_brdf(true_model, c):
    """Against the true BRDF at random points over mu >= 0.01 (and the grazing edge): within 2.5e-4, the model's goal
    (the audit and the report measure the whole domain), and closer than the parts fitted to their own targets."""
    mi, mo, phi = _points(c, 120, int(c * 100))
    want = exact.brdf(mi, mo, phi, c, phase="true")
    got = true_model(mi, mo, phi, np.full_like(mi, c))
    err = np.abs(got - want) / want
    shipped = np.abs(runtime_model(model="three-term")(mi, mo, phi, np.full_like(mi, c)) - want) / want
    assert err.max() <= 2.5e-4, (c, err.max())
    assert np.sqrt(np.mean(err**2)) <= 0.6 * np.sqrt(np.mean(shipped**2)) or err.max() <= 0.6 * shipped.max(), c


def test_true_model_energy(true_model):
    """Directional albedo at c = 1 in [0.9995, 1] from grazing to normal incidence (the energy scale holds it
    below 1), and exactly 0 at c = 0."""
    for mu in (0.0, 1e-3, 0.05, 0.2, 0.45, 0.7, 0.95, 1.0):
        a = directional_albedo(true_model, mu, 1.0)
        assert 0.9995 <= a <= 1.0, (mu, a)
    assert directional_albedo(true_model, 0.4, 0.0) == 0.0
    assert np.all(true_model(np.array([0.0, 0.3, 1.0]), np.array([0.5, 0.3, 1.0]), 1.0, 0.0) == 0.0)


def test_true_fit_files_say_what_they_are():
    for path in sorted(TRUE_FITS.glob("*.json")):
        fit = load(path)
        verify_fit(fit)  # the recorded error against its own target is what is measured now
        rec = fit.record
        assert "true BRDF" in rec["training"]["grid"] and "true BRDF" in rec["optimizer"]["objective"], path.name
        assert rec["claimed_accuracy"].startswith("none"), path.name
        assert fit.measured["max_rel"] == pytest.approx(rec["validation"]["max_rel"], rel=1e-9), path.name


def test_true_model_is_reciprocal_finite_and_nonnegative(true_model):
    rng = np.random.default_rng(7)
    mi, mo, phi, c = rng.uniform(0.0, 1.0, (4, 300))
    mi[:2], mo[:2] = (1e-7, 0.0), (0.4, 1e-7)
    phi *= np.pi
    a = true_model(mi, mo, phi, c)
    b = true_model(mo, mi, phi, c)
    np.testing.assert_allclose(a, b, rtol=1e-12)
    assert np.all(np.isfinite(a)) and np.all(a >= 0.0)


@pytest.mark.benchmark
def test_true_fits_regenerate(tmp_path):
    """``python -m fitlab.families.lambert_sphere.program.true_refit`` remakes the packaged fits: the model of the
    regenerated parts is the packaged model (the exact orders' set cold: a few minutes)."""
    from fitlab.families.lambert_sphere.program.true_refit import main

    assert main(["--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.glob("*.json")) == sorted(p.name for p in TRUE_FITS.glob("*.json"))
    rng = np.random.default_rng(3)
    mi, mo, phi, c = rng.uniform(0.0, 1.0, (4, 2000))
    phi *= np.pi
    np.testing.assert_allclose(
        true_runtime_model(tmp_path)(mi, mo, phi, c), true_runtime_model()(mi, mo, phi, c), rtol=1e-9, atol=1e-300
    )


def test_true_model_refuses_a_folder_without_every_part(tmp_path):
    """A folder that lacks a part would let the packaged fit (made for the mixed reference) fill in: refused, in
    one line naming the part."""
    from fitlab.store import FitFileError

    for path in TRUE_FITS.glob("*.json"):
        if path.name != "H1.log_exp_true.json":
            (tmp_path / path.name).write_bytes(path.read_bytes())
    with pytest.raises(FitFileError, match=r"no fit to the true BRDF of H1 .*H1\.log_exp_true\.json") as err:
        true_runtime_model(tmp_path)
    assert "\n" not in str(err.value)


def test_independent_set_holds_no_training_point():
    """The audit's independent points (datasets.true_independent_points, those of brdf_true_independent) are
    none of the training lattice's (datasets.true_orders_training, read from its definition): no exact values
    are computed here."""
    from fitlab.families.lambert_sphere.targets import datasets as d

    blocks, _ = d.true_independent_points()
    c = np.concatenate([np.full(len(p), cv) for cv, p in blocks])
    mu_i, mu_o = (np.concatenate([p[:, k] for _, p in blocks]) for k in (0, 1))
    train_c = np.concatenate((1.0 - d.TRUE_TRAINING_S**2, d.TRUE_TRAINING_EXTRA_C))
    on_lattice = np.isin(c, train_c) & np.isin(mu_i, d.TRUE_TRAINING_MU) & np.isin(mu_o, d.TRUE_TRAINING_MU)
    assert not on_lattice.any()
    assert np.isin(mu_i, d.EDGE_MU).sum() > 1000  # the edge block is there, at mu = 0.01 too
    assert (mu_i == 0.01).any()


@pytest.mark.e2e
def test_codegen_prints_the_true_model(tmp_path):
    """From the fits to generated code: ``fitlab codegen`` prints by default every part from the packaged folder of
    the parts fitted to the true BRDF, and the generated brdf is the model the audit measures (to rounding)."""
    import importlib.util

    from fitlab.codegen import generate

    text = generate("python")["lambert_sphere.py"]
    for path in TRUE_FITS.glob("*.json"):
        line = next(ln for ln in text.splitlines() if f" {path.name}  " in ln and "packaged (true)" in ln)
        assert "physics true;" in line, line
    (tmp_path / "true_model.py").write_text(text)
    spec = importlib.util.spec_from_file_location("true_model", tmp_path / "true_model.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rng = np.random.default_rng(11)
    mi, mo, phi, c = rng.uniform(0.0, 1.0, (4, 500))
    mi[:2], mo[:2], c[2] = (1e-6, 0.01), (0.3, 0.01), 1.0
    phi *= np.pi
    np.testing.assert_allclose(
        mod.brdf(mi, mo, np.cos(phi), c), true_runtime_model()(mi, mo, phi, c), rtol=1e-12, atol=1e-300
    )
