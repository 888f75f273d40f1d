"""Symbolic regression (fitlab.discover): recovery of known sparse forms, the front, and the round
trip of a discovered form through JSON, refit and codegen."""

from __future__ import annotations

import importlib.util
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from fitlab.cli import main
from fitlab.core import float64, get_target
from fitlab.discover import Library, SparseRegression, discover, get_library, pareto_front, save
from fitlab.discover.library import libraries_of, products
from fitlab.discover.refine import candidate_form, operation_count
from fitlab.forms.symbolic import symbols

ROOT = Path(__file__).resolve().parents[1]
mu, c = symbols(("mu", "c"))


def _toy_library(**kw):
    shapes = {"mu": mu, "mu2": mu**2, "mu3": mu**3, "sqrt(mu)": sp.sqrt(mu), "mu sqrt(mu)": mu * sp.sqrt(mu)}
    return Library(name="toy", target="toy", inputs=("mu",), numerator=shapes, denominator=shapes, **kw)


#: the points of [0, 1] where a candidate must reproduce the function
UNIT_GRID = np.linspace(0.0, 1.0, 401)


def _recover(lib, y_of_mu, truth, x=UNIT_GRID):
    reg = SparseRegression(lib).fit({"mu": x}, y_of_mu(x), np.abs(y_of_mu(x)))
    exact = [cand for cand in reg.candidates_ if np.max(np.abs(reg.predict({"mu": x}, cand) / y_of_mu(x) - 1)) < 1e-9]
    assert exact, "no candidate reproduces the function"
    sparsest = min(exact, key=lambda cand: cand.n_terms)
    assert sparsest.support == (tuple(sorted(truth[0])), tuple(sorted(truth[1])))
    for part, coefs in zip((sparsest.num, sparsest.den), truth):
        for k, v in coefs.items():
            assert part[k] == pytest.approx(v, rel=1e-8, abs=1e-10)
    # every sparser candidate misses it by far: the known form is where the front drops
    for cand in reg.candidates_:
        if cand.n_terms < sparsest.n_terms:
            with np.errstate(all="ignore"):
                assert np.max(np.abs(reg.predict({"mu": x}, cand) / y_of_mu(x) - 1)) > 1e-4


def test_recovers_a_known_rational_form():
    lib = _toy_library(n0=sp.S.One)
    truth = ({"mu2": 0.7, "sqrt(mu)": -0.4}, {"mu": 0.5})
    _recover(lib, lambda x: (1 + 0.7 * x**2 - 0.4 * np.sqrt(x)) / (1 + 0.5 * x), truth)


def test_recovers_a_known_linear_form_with_offset_and_factor():
    shapes = {"1": sp.S.One, "mu": mu, "mu2": mu**2, "mu3": mu**3, "sqrt(mu)": sp.sqrt(mu)}
    lib = Library(name="toy", target="toy", inputs=("mu",), numerator=shapes, offset=sp.exp(mu), factor=1 + mu)
    truth = ({"1": 0.25, "mu3": -1.5}, {})
    _recover(lib, lambda x: np.exp(x) + (1 + x) * (0.25 - 1.5 * x**3), truth)


def test_recovers_a_known_form_whose_denominator_is_pinned_by_an_input():
    # y = mu/(mu + 0.3 (1 - mu)^2 - 0.1 (1 - mu)^3): d0 = mu, as in the c_of_kd ratio library
    t = 1 - mu
    shapes = {"t^(1/2)": sp.sqrt(t), "t": t, "t^2": t**2, "t^3": t**3}
    lib = Library(name="toy", target="toy", inputs=("mu",), numerator=shapes, denominator=shapes, factor=mu,
                  n0=sp.S.One, d0=mu)  # fmt: skip
    truth = ({}, {"t^2": 0.3, "t^3": -0.1})
    y = lambda x: x / (x + 0.3 * (1 - x) ** 2 - 0.1 * (1 - x) ** 3)  # noqa: E731
    _recover(lib, y, truth, x=np.linspace(0.0025, 1.0, 400))
    from fitlab.discover.regression import Candidate

    form = candidate_form(lib, Candidate(*truth, "test", "toy"))
    x = np.array([0.0, 1e-12, 0.5, 1.0])
    got = form(form.start_values, x)
    assert got[0] == 0.0 and got[-1] == 1.0 and np.allclose(got[1:], y(x[1:]), rtol=1e-14)


def test_library_rejects_undeclared_inputs():
    with pytest.raises(ValueError, match="not inputs"):
        Library(name="bad", target="toy", inputs=("mu",), numerator={"c": c})
    with pytest.raises(ValueError, match="no numerator"):
        Library(name="bad", target="toy", inputs=("mu",), numerator={})


def test_products_labels():
    out = products({"c": c}, {"1": sp.S.One, "mu": mu})
    assert list(out) == ["c", "c mu"]
    assert out["c mu"] == c * mu


def test_pareto_front():
    pts = [(1, 0.5), (2, 0.1), (2, 0.2), (3, 0.1), (4, 0.01), (4, 0.01)]
    assert pareto_front(pts) == [0, 1, 4]


@pytest.mark.parametrize("target, name", [(t, lib.name) for t, libs in sorted(libraries_of().items()) for lib in libs])
def test_library_terms_finite_at_domain_edges(target, name):
    lib = get_library(target, name)
    edge = {"mu": [0.0, 0.0, 1.0, 1e-12], "c": [0.0, 1.0, 1.0, 0.5], "kd": [0.0, 1.0, 0.5, 1e-12],
            "mu_i": [0.0, 1e-6, 1.0, 1.0], "mu_o": [1e-6, 0.0, 1.0, 0.0], "phi": [0.0, np.pi, -np.pi, 1.0]}  # fmt: skip
    domains = get_target(target).domain
    # an input without hand-picked edges: both ends of its domain and a point next to the lower one
    edge.update({k: [lo, hi, hi, lo + 1e-12 * (hi - lo)] for k, (lo, hi) in domains.items() if k not in edge})
    values = lib.evaluate({k: np.array(edge[k]) for k in lib.inputs})
    assert all(np.all(np.isfinite(v)) for v in values.values())


@float64  # float64 for this test's own JAX calls, without changing JAX's global configuration
def test_arranged_form_equals_the_model_and_gradients_stay_finite():
    import jax
    import jax.numpy as jnp

    lib = get_library("H0")
    labels = list(lib.numerator)
    from fitlab.discover.regression import Candidate

    cand = Candidate({labels[0]: 0.3, labels[3]: -0.2, labels[9]: 0.1}, {labels[9]: 0.4, labels[10]: -0.1}, "test")
    form = candidate_form(lib, cand)
    x_mu, x_c = np.meshgrid(np.array([0.0, 1e-9, 0.3, 1.0]), np.array([0.0, 0.5, 1.0]))
    model = sp.lambdify(symbols(("mu", "c")), lib.model(cand.num, cand.den).subs(sp.Max(mu, sp.Float("1e-30")), mu))
    with np.errstate(all="ignore"):
        ref = model(np.where(x_mu > 0, x_mu, 1e-300), x_c)
    got = form(form.start_values, x_mu, x_c)
    assert np.allclose(got, ref, rtol=1e-13)
    assert np.all(got[:, 0] == 1.0) and np.all(got[0] == 1.0)  # H = 1 at mu = 0 and at c = 0, exactly
    assert operation_count(form.substituted(form.start_values)) > 0
    theta = jnp.asarray(form.vector(form.start_values))
    grad = jax.jacfwd(lambda th: form.jax_function(th, jnp.asarray(x_mu), jnp.asarray(x_c)))(theta)
    assert bool(jnp.all(jnp.isfinite(grad)))
    assert np.all(np.isfinite(form(form.start_values, x_mu.astype(np.float32), x_c.astype(np.float32))))


@pytest.fixture(scope="module")
def kd_discovery():
    return discover("kd_of_c", thresholds=np.logspace(-3, 0, 4), max_terms=2, minimax_rounds=1, progress=False)


@pytest.mark.e2e
def test_discover_front_and_outputs(kd_discovery, tmp_path):
    disc = kd_discovery
    assert disc.front and all(name in {d.name for d in disc.refined} for name in disc.front)
    by_terms = pareto_front([(d.terms, d.validation["max_rel"]) for d in disc.refined])
    assert {disc.refined[i].name for i in by_terms} <= set(disc.front)
    assert all(d.record["validation"]["points"] > 0 and d.operations > 0 for d in disc.refined)
    assert any(r["kind"] == "published" for r in disc.reference)
    from fitlab.discover.output import front_table, write_outputs

    assert all(name in front_table(disc) for name in disc.front)
    # every support the regression found is refitted, or dropped with its reason stated
    refined = {d.candidate.support for d in disc.refined}
    dropped = {(tuple(sorted(g["numerator"])), tuple(sorted(g["denominator"]))): g["reason"] for g in disc.dropped}
    assert {c.support for c in disc.candidates} == refined | set(dropped) and not refined & set(dropped)
    assert all(reason.startswith(("not on the linearised fronts", "its refit failed", "its linearised fit",
                                  "its sizes and linearised error")) or "more than max_terms (2)" in reason
               for reason in dropped.values())  # fmt: skip
    assert any("more than max_terms (2)" in r for r in dropped.values())
    table = front_table(disc)
    for reason in dropped.values():
        assert reason in table
    paths = write_outputs(disc, tmp_path)
    assert sorted(p.name for p in paths) == ["kd_of_c.json", "kd_of_c.md", "kd_of_c.png"]
    assert paths[2].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads(paths[1].read_text())["front"] == disc.front

    # saving from the written front: every name is checked before anything is written
    from fitlab.discover import save_from_front

    fits = tmp_path / "fits"
    with pytest.raises(KeyError, match="not on the front"):
        save_from_front(paths[1], [disc.front[0], "sr_9_nothere"], fits)
    assert not fits.exists() or not any(fits.iterdir())
    saved = save_from_front(paths[1], disc.front, fits)
    assert [p.name for p in saved] == [f"kd_of_c.{n}.json" for n in disc.front]


@pytest.mark.e2e
def test_discovered_form_round_trips_through_json_refit_and_codegen(kd_discovery, tmp_path):
    from fitlab.codegen import generate, write_generated
    from fitlab.store import load, read_fit

    disc = kd_discovery
    best = min((disc.get(n) for n in disc.front), key=lambda d: d.validation["max_rel"])
    fits = tmp_path / "fits"
    shutil.copytree(ROOT / "fitlab" / "fits", fits, ignore=shutil.ignore_patterns("generated"))
    path = save(disc, best.name, fits)
    assert path.name == f"kd_of_c.{best.name}.json"
    fit = load(path)
    c_val = np.concatenate(([0.0, 1e-12, 1.0], np.linspace(0, 1, 101)))
    values = fit(c=c_val)
    form = candidate_form(disc.library_of(best.candidate), best.candidate, best.name)
    assert np.allclose(values, form(best.record["params"], c_val), rtol=1e-14, atol=0)
    assert values[0] == 0.0 and values[2] == pytest.approx(1.0, abs=1e-15)

    # refit takes it like any other form, from its file (with its minimax stage: a least-squares refit of a minimax
    # fit trades max for RMS, worse than its start by fitlab.fit.metrics.worse)
    out = tmp_path / "refits"
    assert (
        main(["refit", "--target", "kd_of_c", "--form", best.name, "--fits", str(fits), "--out", str(out), "--quiet"])
        == 0
    )
    again = read_fit(out / f"kd_of_c.{best.name}.json")
    assert again["origin"] == best.record["origin"] and again["origin"]["method"] == "fitlab discover"
    assert again["validation"]["max_rel"] <= 1.5 * best.validation["max_rel"]

    # codegen takes it: the generated Python evaluates it to rounding
    gen = tmp_path / "gen"
    write_generated(generate("python", fits, forms={"kd_of_c": best.name}), gen)
    spec = importlib.util.spec_from_file_location("gen_kd", gen / "lambert_sphere.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert np.allclose(mod.kd_of_c(c_val), values, rtol=1e-13, atol=1e-16)
    assert best.name in (gen / "lambert_sphere.py").read_text()

    # and the C back end compiles it under the strict flags, and agrees
    from fitlab.codegen import emit, load_program
    from fitlab.codegen.native import build, compiler

    if compiler() is None:
        pytest.skip("no C compiler")
    program = load_program(fits, forms={"kd_of_c": best.name})
    native = build(emit(program, "c"), program, tmp_path / "c")
    assert np.allclose(native("kd_of_c", c_val), values, rtol=1e-13, atol=1e-16)


def test_cli_errors(tmp_path, capsys):
    assert main(["discover", "--target", "nope", "--out", str(tmp_path)]) == 2
    assert "no discovery library" in capsys.readouterr().err
    assert main(["discover", "--target", "H0", "--max-terms", "0", "--out", str(tmp_path)]) == 2
    assert "--max-terms" in capsys.readouterr().err
    assert main(["discover", "--target", "H0", "--from-front", "--out", str(tmp_path)]) == 2
    assert "goes with --save" in capsys.readouterr().err
    assert main(["discover", "--target", "H0", "--from-front", "--save", "x", "--out", str(tmp_path)]) == 2
    assert "--save writes into --fits" in capsys.readouterr().err  # never into the packaged fits
    assert main(["discover", "--target", "H0", "--from-front", "--save", "x", "--out", str(tmp_path),
                 "--fits", str(tmp_path / "fits")]) == 2  # fmt: skip
    assert "no such front" in capsys.readouterr().err
    assert main(["discover", "--target", "H0", "--cost", "--out", str(tmp_path)]) == 2
    assert "--cost goes with --save" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
    a_file = tmp_path / "file"
    a_file.write_text("")
    assert main(["discover", "--target", "H0", "--out", str(a_file)]) == 2
    assert "not a folder" in capsys.readouterr().err
    a_file.unlink()
    with pytest.raises(SystemExit):
        main(["codegen", "--lang", "c", "--form"])
    assert main(["codegen", "--lang", "c", "--out", str(tmp_path), "--form", "H0"]) == 2
    assert "TARGET=FORM" in capsys.readouterr().err
    assert main(["codegen", "--lang", "c", "--out", str(tmp_path), "--form", "H0=absent"]) == 2
    assert "no such fit file" in capsys.readouterr().err
