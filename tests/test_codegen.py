"""Generated code: reproducible, compiles clean, agrees with the JAX forms, finite everywhere.

The reference for every comparison is the JAX function lambdified from the same
fits through fitlab.forms / fitlab.families.lambert_sphere.program.runtime (not through codegen's printers).
"""

from __future__ import annotations

import ast
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

from fitlab.codegen import build_program, generate, load_program, parse_terms, program_spec, stable
from fitlab.codegen.languages import emit
from fitlab.codegen.native import STRICT_FLAGS, build, build_glsl, compiler
from fitlab.core import float64, get_target
from fitlab.families.lambert_sphere.program.rewrites import POLE_FLOOR
from fitlab.families.lambert_sphere.program.rewrites import stable as lambert_stable
from fitlab.families.lambert_sphere.program.runtime import energy_scale, runtime_model
from fitlab.forms.symbolic import lambdify_jax, symbols
from fitlab.store import fit_path, fit_source, load

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
#: the forms of the program codegen prints by default (its default model), by target
MODEL_FORMS = program_spec("lambert_sphere").model().forms


def fit_file(target: str) -> Path:
    """The fit file of ``target`` that the default program is built from (its model's folder of the fits first)."""
    form = MODEL_FORMS.get(target, get_target(target).default_form)
    return fit_source(FITS, target, form, program_spec("lambert_sphere").model().folder)


GENERATED = FITS / "generated"
N = 100_000
needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler on PATH")


@pytest.fixture(scope="module")
def program():
    os.chdir(ROOT)  # the banner names the fits relative to the project root
    return load_program(FITS, parse_terms(None))


@pytest.fixture(scope="module")
def sources(program):
    return {lang: emit(program, lang) for lang in ("c", "python", "glsl", "hlsl", "metal", "drjit")}


@pytest.fixture(scope="module")
def native(program, sources, tmp_path_factory):
    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    return build(sources["c"], program, tmp_path_factory.mktemp("c"))


@pytest.fixture(scope="module")
def py(sources, tmp_path_factory):
    d = tmp_path_factory.mktemp("py")
    (d / "lambert_sphere.py").write_text(sources["python"]["lambert_sphere.py"])
    spec = importlib.util.spec_from_file_location("generated_lambert_sphere", d / "lambert_sphere.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def inputs():
    rng = np.random.default_rng(20261122)
    mu_i, mu_o, c = rng.random(N), rng.random(N), rng.random(N)
    cos_phi = rng.uniform(-1.0, 1.0, N)
    hard_mu = [0.0, 1e-12, 1e-4, 0.5, 1.0]
    grid = np.array(np.meshgrid(hard_mu, hard_mu, [-1.0, 0.0, 1.0], [0.0, 1e-9, 0.5, 1.0], indexing="ij")).reshape(
        4, -1
    )
    grid = grid[:, (grid[0] + grid[1]) > 0]  # the pole itself is tested apart (the exact value is infinite)
    return tuple(np.concatenate([a, g]) for a, g in zip((mu_i, mu_o, cos_phi, c), grid))


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(a == b, 0.0, np.abs(a - b) / np.abs(b))


def jax_reference(expr, names):
    """The expression as a jitted JAX function, traced and run in float64 (import fitlab leaves JAX's default)."""
    f = jax.jit(lambdify_jax(symbols(names), expr))
    return float64(lambda *args: np.asarray(f(*args)))


# ---- reproducibility ----------------------------------------------------------


@pytest.mark.parametrize("lang", ["c", "python", "glsl", "hlsl", "metal", "drjit"])
def test_committed_generated_code_is_what_the_committed_fits_generate(sources, lang):
    for name, text in sources[lang].items():
        committed = (GENERATED / name).read_text()
        assert committed == text, (
            f"fitlab/fits/generated/{name} is stale: run fitlab codegen --lang {lang} --fits fitlab/fits --out fitlab/fits/generated"
        )


@pytest.mark.e2e
def test_generation_does_not_depend_on_hash_seed(tmp_path):
    code = (f"import os; os.chdir({str(ROOT)!r}); from fitlab.codegen import generate; "
            "import sys; sys.stdout.write(generate('c')['lambert_sphere.c'])")  # fmt: skip
    # both at once (two cores): each builds the program from scratch
    runs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONHASHSEED": seed}) for seed in ("1", "2")]  # fmt: skip
    outs = []
    for run in runs:
        out, err = run.communicate(timeout=600)
        assert run.returncode == 0, err
        outs.append(out)
    assert outs[0] == outs[1] == (GENERATED / "lambert_sphere.c").read_text()


def test_temporaries_are_named_in_an_order_that_does_not_follow_sympys():
    """fitlab.codegen.languages names cse's temporaries in an order of their own (operands first, then by sympy's sort
    key): sympy's cse was seen to list the same temporaries in another order after other sympy work in the
    process.  Two topological orders of the same temporaries give the same names and the same code."""
    import sympy as sp

    from fitlab.codegen.languages import _named_in_order

    x, y = sp.symbols("x y", real=True)
    a, b, c, d = sp.symbols("a b c d", cls=sp.Dummy, real=True)
    values = {a: x**2, b: y**2, c: a * b + x, d: sp.exp(c) + a}
    first = [(a, values[a]), (b, values[b]), (c, values[c]), (d, values[d])]
    second = [(b, values[b]), (a, values[a]), (c, values[c]), (d, values[d])]
    outs = [_named_in_order(found, [d + b], sp.numbered_symbols("t", real=True)) for found in (first, second)]
    assert outs[0] == outs[1]
    temps, (value,) = outs[0]
    t = sp.symbols("t0:4", real=True)
    assert temps == [(t[0], x**2), (t[1], y**2), (t[2], t[0] * t[1] + x), (t[3], sp.exp(t[2]) + t[0])]
    assert value == t[3] + t[1]


def test_banner_names_every_source_fit(sources):
    text = sources["c"]["lambert_sphere.h"]
    for name in ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "c_of_kd", "kd_of_c", "fast_brdf"):
        assert f" {fit_file(name).name} " in text


def test_banner_points_to_the_model_document(sources):
    for files in sources.values():
        for text in files.values():
            assert "docs/model.md" in text and "SPEC" not in text


def test_every_generated_file_opens_with_an_spdx_licence_line(sources):
    licence = (ROOT / "LICENSE").read_text().splitlines()[0]
    assert licence == "MIT License"
    for files in sources.values():
        for name, text in files.items():
            first = text.splitlines()[1] if text.startswith("/*") else text.splitlines()[0]
            assert first.endswith("SPDX-License-Identifier: MIT"), name


def test_build_program_takes_records_and_reads_no_file(program, monkeypatch):
    """Records (fit-file dicts) go straight in: the same routines as from the files, no file opened."""
    from fitlab.codegen import program_spec
    from fitlab.core import get_target
    from fitlab.store import read_fit

    records = {t: read_fit(fit_file(t)) for t in program_spec("lambert_sphere").fits}

    def no_reading(*args, **kwargs):
        raise AssertionError("build_program read a file")

    monkeypatch.setattr(Path, "read_text", no_reading)
    monkeypatch.setattr(Path, "read_bytes", no_reading)
    prog = build_program(records)
    assert [(r.name, r.args, r.expr) for r in prog.routines] == [(r.name, r.args, r.expr) for r in program.routines]
    # only the file edge (load_program) names files and re-measures the fits; from bare records no figure is
    # printed (none is copied from a record), and the docs are otherwise the same
    assert prog.sources == () and program.sources and len(program.source_notes) == len(program.sources)
    for built, loaded in zip(prog.routines, program.routines):
        assert "Measured by" not in built.doc and "Validation" not in built.doc and "as fitlab codegen" not in built.doc
        measured = loaded.doc.split(" Measured by fitlab codegen")[0].split(" Against the true BRDF")[0]
        assert measured.rstrip(".") == built.doc.rstrip(".")
    assert {get_target(t).routine for t in prog.parts} <= {r.name for r in prog.routines}


# ---- C ------------------------------------------------------------------------


@needs_cc
def test_c_compiles_clean_under_strict_flags(native):
    """The command line build() ran (not the constant it defaults to) compiled the generated file under
    the strict flags, warnings as errors, and no flag that would loosen the NaN policy."""
    cmd = native.command
    assert cmd is not None and Path(cmd[0]).name in ("cc", "gcc", "clang")
    for flag in ("-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"):
        assert flag in cmd, flag
    assert set(STRICT_FLAGS) <= set(cmd)
    assert not any(f.startswith(("-ffast-math", "-ffinite-math", "-Ofast", "-Wno-")) for f in cmd)
    assert any(a.endswith("lambert_sphere.c") for a in cmd)


@needs_cc
def test_c_and_python_agree_with_the_jax_runtime_model(native, py, inputs):
    # the reference gets the same cancellation-free rewrite as the generated parts (tested apart below);
    # points with mu_i + mu_o under the pole floor are tested apart (the unfloored model is ~1/(mu_i + mu_o))
    keep = inputs[0] + inputs[1] >= float(POLE_FLOOR)
    mu_i, mu_o, cos_phi, c = (a[keep] for a in inputs)
    expr = lambert_stable(runtime_model(fits_dir=FITS, forms=MODEL_FORMS).expr)
    ref = np.asarray(jax_reference(expr, ("mu_i", "mu_o", "phi", "c"))(mu_i, mu_o, np.arccos(cos_phi), c))
    got_c = native("brdf", mu_i, mu_o, cos_phi, c)
    got_py = py.brdf(mu_i, mu_o, cos_phi, c)
    assert np.all(np.isfinite(ref))
    random = np.arange(len(ref)) < keep[:N].sum()
    for got in (got_c, got_py):
        assert rel(got[random], ref[random]).max() < 1e-12
        # hard cases include c = 1e-9 with forward scattering, where f ~ c^2 is a difference of O(c)
        # terms: agreement to 1e-12 of the size of those terms, c / (pi (mu_i + mu_o))
        scale = np.maximum(np.abs(ref), c / (np.pi * (mu_i + mu_o)))
        assert (np.abs(got - ref) / np.where(scale > 0, scale, 1.0)).max() < 1e-12


@needs_cc
def test_fast_variant_agrees_with_its_fit(native, py, inputs):
    keep = inputs[0] + inputs[1] >= float(POLE_FLOOR)
    mu_i, mu_o, cos_phi, c = (a[keep] for a in inputs)
    kd = py.kd_of_c(c)
    fit = load(FITS / "fast_brdf.json")
    ref = np.asarray(jax_reference(fit.expression, fit.inputs)(mu_i, mu_o, np.arccos(cos_phi), c, kd))
    random = np.arange(len(ref)) < keep[:N].sum()
    scale = np.maximum(np.abs(ref), c / (np.pi * (mu_i + mu_o)))
    for got in (native("brdf_fast", mu_i, mu_o, cos_phi, c, kd), py.brdf_fast(mu_i, mu_o, cos_phi, c, kd)):
        assert rel(got[random], ref[random]).max() < 1e-12
        assert (np.abs(got - ref) / np.where(scale > 0, scale, 1.0)).max() < 1e-12


@needs_cc
@pytest.mark.parametrize("target,routine", [("H0", "h0"), ("H1", "h1"), ("l", "const_l"), ("m", "const_m"),
                                            ("B", "const_b"), ("C", "const_c"), ("D", "const_d"), ("F", "const_f"),
                                            ("kd_of_c", "kd_of_c"), ("c_of_kd", "c_of_kd")])  # fmt: skip
def test_parts_agree_with_their_fits(native, py, inputs, target, routine):
    fit = load(fit_file(target))
    args = (inputs[0], inputs[3]) if len(fit.inputs) == 2 else (inputs[3],)
    args = tuple(np.concatenate([a, [0.0, 1e-12, 1e-6, 0.5, 1.0]]) for a in args)
    ref = np.asarray(jax_reference(fit.expression, fit.inputs)(*args))
    # the generated parts are rewritten to avoid cancellation near c = 0 and kd = 0 (the family's rewrites,
    # fitlab.families.lambert_sphere.program.rewrites):
    # they agree with the JAX form to 1e-12 of the form's scale, and with the rewritten form to 1e-12
    scale = np.abs(ref).max()
    assert np.abs(native(routine, *args) - ref).max() < 1e-12 * scale
    assert np.abs(py.__dict__[routine](*args) - ref).max() < 1e-12 * scale
    rewritten = np.asarray(jax_reference(lambert_stable(fit.expression), fit.inputs)(*args))
    # relative, except beside a sign change of B-F (a root), where 1e-15 of the scale
    assert np.all(np.abs(native(routine, *args) - rewritten) <= 1e-12 * np.abs(rewritten) + 1e-15 * scale)


def test_stable_rewrite_keeps_digits_near_the_exact_zeros():
    """B, kd(c) near c = 0 and c(kd) near kd = 0: the rewrite keeps full relative accuracy
    (checked against the same form evaluated in 50-digit arithmetic)."""
    import sympy as sp

    for target, name in (("B", "c"), ("kd_of_c", "c"), ("c_of_kd", "kd")):
        fit = load(FITS / f"{target}.json")
        x = sp.Symbol(name, real=True)
        f = jax_reference(lambert_stable(fit.expression), fit.inputs)
        for v in (1e-12, 1e-8, 1e-4):
            exact = float(fit.expression.subs(x, sp.Float(v, 50)).evalf(50))
            assert abs(float(f(v)) - exact) <= 1e-12 * abs(exact), (target, v)  # unrewritten: 1e-4 at c = 1e-12


def test_stable_rewrite_keeps_digits_of_one_minus_a_square():
    """sqrt(1 - x^2) and max(0, 1 - x^2) as |x| -> 1: written directly, 1 - x*x keeps eps/(1 - |x|) of its
    value (5e-5 at 1 - x = 1e-12); rewritten, full accuracy (against 40-digit arithmetic).  numpy, not XLA,
    evaluates it: XLA may fuse 1 - x*x into one exact fused multiply-add, which C compilers need not do."""
    import mpmath as mp
    import sympy as sp

    x = sp.Symbol("x", real=True)
    for written in (sp.sqrt(1 - x**2), sp.sqrt(sp.Max(0, 1 - x**2)), sp.Max(0, 1 - x**2) / 2):
        f = sp.lambdify(x, stable(written), "numpy")
        for v in (1.0 - 1e-12, -1.0 + 1e-9, 1.0 - 2.0**-30 - 2.0**-40, 0.5):
            with mp.workdps(40):
                exact = float(sp.lambdify(x, written, "mpmath")(mp.mpf(v)))
            assert abs(float(f(v)) - exact) <= 4e-16 * abs(exact), (written, v)


@needs_cc
def test_single_scattering_keeps_its_digits_in_forward_scattering_at_grazing(native, py):
    """At mu_i = 1e-6, mu_o = 1e-4, phi = pi (1 - u = 5e-9) the generated single scattering agrees with the exact
    engine's c p(u)/(mu_i + mu_o) to 3e-9 of f_1 in double (sqrt(1 - u^2) written directly lost 37 % there;
    bound 1e-7); at mu_i = mu_o = 1e-2 (1 - u = 2e-4) the float version to 2.3e-4, where float resolves u to
    1.5 eps/(1 - u) = 4.5e-4 (it lost 18 %; bound 1e-3)."""
    from fitlab.families.lambert_sphere.exact import phase_function

    def exact_single(mi, mo, c):  # phi = pi: u = S - mu_i mu_o, as the engine's brdf computes it
        u = np.sqrt((1.0 - mi * mi) * (1.0 - mo * mo)) - mi * mo
        return c * phase_function(u) / (mi + mo)

    c = np.array([1e-6, 0.5, 1.0])
    mi, mo, cos_phi = np.full(3, 1e-6), np.full(3, 1e-4), np.full(3, -1.0)
    want = exact_single(mi, mo, c)
    assert rel(native("single", mi, mo, cos_phi, c), want).max() < 1e-7
    assert rel(py.single(mi, mo, cos_phi, c), want).max() < 1e-7
    mi, mo = np.full(3, 1e-2), np.full(3, 1e-2)
    assert rel(native("single", mi, mo, cos_phi, c, dtype=np.float32), exact_single(mi, mo, c)).max() < 1e-3


#: grazing to normal cosines (both 0 apart: the pole) and albedos from c = 1e-9 to 1
_EDGE_MU = np.array([0.0, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.3, 1.0])
_EDGE_C = np.array([1e-9, 1e-6, 1e-4, 1e-2, 0.5, 1.0])


@needs_cc
def test_multiple_scattering_terms_keep_their_digits_in_float(native):
    """fm0, fm1, fm2 in float against double, plain relative error, down to mu = 1e-6 and c = 1e-9: written as
    ((H H - 1) Q + (Q - Q_ss))/(mu_i + mu_o) with H H - 1 = expm1(...) and the O(c) parts cancelled in the algebra,
    they lose no more than a few float roundings (measured 1.2e-6; as printed, (H H Q/2pi - n_ss)/(mu_i + mu_o)
    lost every digit at c <= 1e-4 or mu = 1e-6)."""
    mu_i, mu_o, c = (a.ravel() for a in np.meshgrid(_EDGE_MU, _EDGE_MU, _EDGE_C, indexing="ij"))
    keep = mu_i + mu_o > 0
    mu_i, mu_o, c = mu_i[keep], mu_o[keep], c[keep]
    for name in ("fm0", "fm1", "fm2"):
        f64, f32 = native(name, mu_i, mu_o, c), native(name, mu_i, mu_o, c, dtype=np.float32)
        assert rel(f32, f64).max() < 1e-5, name  # rel is 0 where both are 0 (S = 0 at mu = 1)


@needs_cc
def test_float_brdf_against_exact_at_grazing(native):
    """The float brdf and eval (prepare once per material) against the exact engine at grazing, plain relative
    error, mu_i, mu_o in 1e-6 .. 1e-2, phi = 0, pi/2, pi, c in 1e-9 .. 1: against the true BRDF, which the default
    model's parts were fitted to, within 2e-3, the model's goal down to mu = 1e-6 (its H forms have the true BRDF's
    grazing law), and float within 1e-5 of double.  Before the terms
    were written without cancellation: 2.26 (c = 1e-3, phi = pi), 100 % for c <= 1e-4, 1.1 % at c = 1; and with fm0, fm1 fixed but
    single scattering read from u: 6.7e-3 at c = 1e-6, 100 % as c -> 0 in forward scattering (u rounds to 1)."""
    from fitlab.families.lambert_sphere.exact import brdf as exact_brdf

    mus = np.array([1e-6, 1e-5, 1e-4, 1e-3, 1e-2])
    cs = np.array([1e-9, 1e-6, 1e-4, 1e-3, 1e-2, 0.5, 1.0])
    mu_i, mu_o, c = (a.ravel() for a in np.meshgrid(mus, mus, cs, indexing="ij"))
    materials = native("prepare_c", c, dtype=np.float32)
    for phi in (0.0, np.pi / 2, np.pi):
        exact = exact_brdf(mu_i, mu_o, phi, c, phase="true")
        cos_phi = np.full_like(mu_i, np.cos(phi))
        double = native("brdf", mu_i, mu_o, cos_phi, c)
        for f in (native("brdf", mu_i, mu_o, cos_phi, c, dtype=np.float32),
                  native("eval", materials, np.arange(c.size), mu_i, mu_o, cos_phi, dtype=np.float32)):  # fmt: skip
            assert rel(f, exact).max() < 2e-3
            assert rel(f, double).max() < 1e-5


@needs_cc
def test_single_scattering_in_float_at_forward_grazing(native):
    """Single scattering from 1 - u as a sum of terms >= 0 and sin x - x cos x by its series: in float within 5e-6
    of double (measured 1.0e-6, bound 5e-6) down to mu = 1e-6 in forward and back-scattering, where float's u is 1 or -1."""
    mus = np.array([1e-6, 1e-4, 1e-3, 1e-2, 0.5])
    grid = np.meshgrid(mus, mus, [-1.0, -0.999, 0.0, 1.0], indexing="ij")
    mu_i, mu_o, cos_phi = (np.float32(a.ravel()).astype(float) for a in grid)  # the same inputs in both
    c = np.full_like(mu_i, 0.5)
    assert (
        rel(native("single", mu_i, mu_o, cos_phi, c, dtype=np.float32), native("single", mu_i, mu_o, cos_phi, c)).max()
        < 5e-6
    )


def test_runtime_terms_are_the_printed_terms():
    """The cancellation-free terms are the printed ones, identically (eqs. 22, 30 less single scattering), for
    parts of any form (undefined functions) and both normalisations."""
    import sympy as sp

    from fitlab.families.lambert_sphere.forms import brdf as forms_brdf
    from fitlab.families.lambert_sphere.forms.constants import A_EXACT, E_EXACT

    mu_i, mu_o, c, mu = symbols(("mu_i", "mu_o", "c", "mu"))
    parts = {p: sp.Function(p)(mu, c) for p in ("H0", "H1", "H2")}
    parts.update({p: sp.Function(p)(c) for p in ("l", "m", "B", "C", "D", "F")})
    sigma, p_, q_ = mu_i + mu_o, mu_i * mu_o, mu_i**2 + mu_o**2
    h = {n: parts[n].subs(mu, mu_i) * parts[n].subs(mu, mu_o) for n in ("H0", "H1")}
    B, C, D, F, ell, m = (parts[n] for n in "BCDFlm")
    for norm, (k, j) in forms_brdf.NORMALISATIONS.items():
        terms = forms_brdf.runtime_terms(parts, norm)
        q = A_EXACT + B * sigma + C * p_ + D * p_ * sigma + E_EXACT * p_**2 + F * q_
        fm0 = (h["H0"] * q / (2 * sp.pi) - forms_brdf.SINGLE_NUMERATOR_0) / sigma
        fm1 = (c * h["H1"] * forms_brdf.S * (1 + ell * sigma + (ell**2 + sp.Rational(45, 64) * m) * p_) / (k * sp.pi)
               - forms_brdf.SINGLE_NUMERATOR_1 / j) / sigma  # fmt: skip
        assert sp.simplify(sp.expand((terms["m0"] - fm0) * sigma)) == 0
        assert sp.simplify(sp.expand((terms["m1"] - fm1) * sigma)) == 0


def test_parts_in_algebra_are_the_parts_with_exact_structure():
    """The shipped model's log-exp H and c2_rational constants are inlined in the terms (H H - 1 = expm1, C - 2c/3
    and F + 15c/128 cancelled in the algebra), the others called."""
    import sympy as sp

    from fitlab.families.lambert_sphere.forms.brdf import less_exactly, parts_in_algebra

    shipped = {p: load(fit_file(p)).expression for p in ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F")}
    assert set(parts_in_algebra(shipped)) == {"H0", "H1", "H2", "C", "F", "m"}
    c = symbols(("c",))[0]
    assert 2 * c / 3 not in sp.Add.make_args(less_exactly(shipped["C"], 2 * c / 3))
    # a constant without the exact O(c) term is called, and its difference left to floating point
    assert less_exactly(load(fit_path(FITS, "C", "rational_4_3")).expression, 2 * c / 3) is None
    assert less_exactly(1 + c * (1 + c), 1) == c * (1 + c)
    assert less_exactly(c * (2 * c / 3 + c**3), 2 * c**2 / 3) is not None
    assert less_exactly(c**2 / (1 + c), c) is None


@needs_cc
def test_float_agrees_with_double(native, inputs):
    """Float vs double at the same (float-rounded) inputs, plain relative error: measured 4.7e-7 at the 99.9th
    percentile and 9.0e-7 at most (every term is evaluated without cancellation, single scattering from 1 - u:
    no point needs a looser scale, as forward scattering with tiny f did when float rounded u to 1)."""
    mu_i, mu_o, cos_phi, c = (np.float32(a).astype(float) for a in inputs)
    f64 = native("brdf", mu_i, mu_o, cos_phi, c)
    f32 = native("brdf", mu_i, mu_o, cos_phi, c, dtype=np.float32)
    r = rel(f32, f64)
    assert np.percentile(r, 99.9) < 2e-6
    assert r.max() < 5e-6
    for name in ("h0", "h1"):
        assert rel(native(name, mu_i, c, dtype=np.float32), native(name, mu_i, c)).max() < 1e-5


@needs_cc
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_no_nan_or_inf_anywhere_in_the_domain(native, dtype):
    edge = [0.0, 1e-38 if dtype == np.float32 else 1e-300, 1e-7, 0.5, 1.0 - 1e-7, 1.0]
    g = np.array(np.meshgrid(edge, edge, [-1.0, -0.5, 0.0, 1.0], edge, edge, indexing="ij")).reshape(5, -1)
    mu_i, mu_o, cos_phi, c, kd = g
    checks = {
        "brdf": (mu_i, mu_o, cos_phi, c), "single": (mu_i, mu_o, cos_phi, c), "fm0": (mu_i, mu_o, c),
        "fm1": (mu_i, mu_o, c), "brdf_fast": (mu_i, mu_o, cos_phi, c, kd), "h0": (mu_i, c), "h1": (mu_i, c),
        "c_of_kd": (kd,), "kd_of_c": (c,), "const_b": (c,), "const_d": (c,),
    }  # fmt: skip
    for name, args in checks.items():
        out = native(name, *args, dtype=dtype)
        assert np.all(np.isfinite(out)), name
    assert np.all(native("brdf", mu_i, mu_o, cos_phi, c, dtype=dtype) >= 0)


@needs_cc
def test_the_pole_is_large_and_finite(native, py):
    for dtype in (np.float64, np.float32):
        at_pole = native("brdf", 0.0, 0.0, 1.0, 1.0, dtype=dtype)
        near = native("brdf", 1e-3, 1e-3, 1.0, 1.0, dtype=dtype)
        assert np.isfinite(at_pole) and at_pole > 100 * near
    assert np.isfinite(py.brdf(0.0, 0.0, 1.0, 1.0))


@needs_cc
def test_reciprocity(native, py):
    rng = np.random.default_rng(7)
    wi, wo = rng.normal(size=(2, 20_000, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    c = rng.random(20_000)
    for f, bound in ((lambda a, b: native("brdf_local", a, b, c), 1e-13), (lambda a, b: py.brdf_local(a, b, c), 1e-13),
                     (lambda a, b: native("brdf_local", a, b, c, dtype=np.float32), 1e-5)):  # fmt: skip
        assert rel(f(wi, wo), f(wo, wi)).max() < bound
    # local-frame entry agrees with the (mu, cos phi) one and is 0 below the surface
    mu_i, mu_o = wi[:, 2], wo[:, 2]
    cos_phi = (wi[:, 0] * wo[:, 0] + wi[:, 1] * wo[:, 1]) / np.sqrt((1 - mu_i**2) * (1 - mu_o**2))
    assert rel(native("brdf_local", wi, wo, c), native("brdf", mu_i, mu_o, cos_phi, c)).max() < 1e-9
    below = wi * np.array([1, 1, -1])
    assert np.all(native("brdf_local", below, wo, c) == 0) and np.all(py.brdf_local(wi, below, c) == 0)


@needs_cc
def test_terms_option_keeps_only_the_terms_asked_for(tmp_path):
    prog = load_program(FITS, parse_terms("single,m0"))
    names = [r.name for r in prog.routines]
    assert "fm1" not in names and "fm0" in names
    m = build(emit(prog, "c"), prog, tmp_path)
    x = np.array([0.3, 0.7]), np.array([0.6, 0.2]), np.array([0.5, -0.5]), np.array([0.9, 0.4])
    # brdf = max(0, s (single + fm0)), s the energy scale of the terms kept
    parts = {t: load(fit_file(t)).expression for t in ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F")}
    scale = float(energy_scale(parts, ("single", "m0")))
    assert 0.99 < scale <= 1.0
    expect = np.maximum(0.0, scale * (m("single", *x) + m("fm0", x[0], x[1], x[3])))
    assert rel(m("brdf", *x), expect).max() < 1e-15
    with pytest.raises(ValueError, match="single, m0, m1"):
        parse_terms("single,m3")


# ---- Python -------------------------------------------------------------------


def test_python_module_imports_only_numpy(sources):
    tree = ast.parse(sources["python"]["lambert_sphere.py"])
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    imported |= {(n.module or ".").split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert imported == {"numpy"}


def test_python_module_broadcasts(py):
    out = py.brdf(np.linspace(0, 1, 5)[:, None], 0.5, 1.0, np.array([0.2, 0.9]))
    assert out.shape == (5, 2) and out.dtype == np.float64
    assert py.h0(0.5, 0.5).shape == ()


# ---- GLSL ---------------------------------------------------------------------


@needs_cc
def test_glsl_compiles_as_c_and_agrees(program, sources, tmp_path):
    """GLSL's float subset is C: compiled against a shim of the GLSL built-ins (fitlab.codegen.native.GLSL_SHIM),
    the shader functions must compile (declared before use, only known built-ins) and agree in float."""
    glsl = build_glsl(sources["glsl"], program, tmp_path / "glsl")
    assert "-Werror" in glsl.command
    ref = build(sources["c"], program, tmp_path / "ref")
    rng = np.random.default_rng(3)
    wi, wo = rng.normal(size=(2, 2000, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    wi, wo, c = wi.astype(np.float32), wo.astype(np.float32), rng.random(2000).astype(np.float32)
    got = glsl("brdf_local", wi, wo, c, dtype=np.float32).astype(float)
    want = ref("brdf_local", wi.astype(float), wo.astype(float), c.astype(float))
    assert np.all(np.abs(got - want) <= 1e-4 * np.abs(want) + 1e-7)
    kd = np.array([0.0, 1e-6, 0.3, 0.5, 0.9, 1.0], dtype=np.float32)
    want = ref("c_of_kd", kd.astype(float))
    assert np.all(np.abs(glsl("c_of_kd", kd, dtype=np.float32) - want) <= 1e-5 * np.abs(want) + 1e-30)
    with pytest.raises(TypeError, match="float64"):
        glsl("c_of_kd", kd.astype(float))


@pytest.mark.skipif(
    shutil.which("glslangValidator") is None, reason="glslangValidator not installed (apt: glslang-tools)"
)
@pytest.mark.parametrize("version", ["#version 330", "#version 300 es\nprecision highp float;"])
def test_glsl_validates_with_glslang(sources, tmp_path, version):
    main = ("out vec4 color; uniform vec3 wi; uniform vec3 wo; uniform float c;\nvoid main() { float kd = "
            "lambert_sphere_kd_of_c(c); color = vec4(lambert_sphere_brdf_local(wi, wo, c) + "
            "lambert_sphere_brdf_fast_local(wi, wo, c, kd) + lambert_sphere_c_of_kd(kd)); }\n")  # fmt: skip
    shader = tmp_path / "test.frag"
    shader.write_text(version + "\n" + sources["glsl"]["lambert_sphere.glsl"] + main)
    res = subprocess.run(["glslangValidator", str(shader)], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


# ---- CLI ----------------------------------------------------------------------


def test_cli_errors_write_nothing(tmp_path, capsys):
    from fitlab.cli import main

    assert main(["codegen", "--lang", "c", "--terms", "single,bogus", "--out", str(tmp_path / "a")]) == 2
    assert "single, m0, m1" in capsys.readouterr().err
    assert main(["codegen", "--lang", "c", "--fits", str(tmp_path / "none"), "--out", str(tmp_path / "b")]) == 2
    assert "no such folder" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["codegen", "--lang", "c", "--fits", str(tmp_path / "empty"), "--form", "H0=sr_none",
                 "--out", str(tmp_path / "b")]) == 2  # fmt: skip
    assert "no such fit file" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
    with pytest.raises(SystemExit):
        main(["codegen", "--lang", "fortran"])
    assert main(["codegen", "--lang", "python", "--out", str(tmp_path / "ok")]) == 0
    assert (tmp_path / "ok" / "lambert_sphere.py").read_text() == (GENERATED / "lambert_sphere.py").read_text()
    with pytest.raises(ValueError, match="unknown language"):
        generate("fortran")


def test_half_integer_powers_print_as_products_with_one_sqrt():
    # s^3 = (1 - c)^(3/2) appears in the richer forms; pow() would cost tens of ns per call
    import sympy as sp

    from fitlab.codegen.printers import CPrinter, GLSLPrinter, NumpyPrinter

    (x,) = symbols(("x",))
    name = str
    assert CPrinter("double", name).doprint(x ** sp.Rational(3, 2)) == "(x*sqrt(x))"
    assert CPrinter("float", name).doprint((1 - x) ** sp.Rational(5, 2)) == "((1.0F - x)*(1.0F - x)*sqrtf(1.0F - x))"
    assert GLSLPrinter(name).doprint(x ** sp.Rational(7, 2)) == "(x*x*x*sqrt(x))"
    assert "pow" in CPrinter("double", name).doprint(x ** sp.Rational(9, 2))  # long products: pow stays
    f = eval("lambda x: " + NumpyPrinter(name).doprint(x ** sp.Rational(3, 2)), {"numpy": np})
    v = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(f(v), v**1.5, rtol=4e-16, atol=0)


def test_a_family_without_a_program_of_its_own_gets_one_routine_per_target(tmp_path):
    """No codegen of its own: codegen prints each target's routine from its record, in Python and C."""
    import sympy as sp

    from fitlab.core import Dataset, Family, Input, Target, families, register_family, unregister_family
    from fitlab.forms import Form
    from fitlab.store import FORMAT

    x, a = sp.Symbol("x", real=True), sp.Symbol("a", real=True)

    def points():
        xs = np.linspace(0.0, 1.0, 11)
        return Dataset({"x": xs}, np.exp(xs), "toy")

    target = Target("toy_exp", "exp(x)", (Input("x", (0.0, 1.0)),), "line", (), points, points, routine="toy_exp")
    form = Form("toy_exp", "line", ("x",), ("a",), 1 + a * x, presets={"p": {"a": 1.0}})

    class ToyCodegen(Family, name="toy_codegen", description="A toy family", target_names=("toy_exp",)):
        def targets(self):
            return (target,)

        def forms(self):
            return (form,)

    families()
    register_family(ToyCodegen())
    try:
        record = {"format": FORMAT, "target": "toy_exp", "form": "line", "inputs": ["x"],
                  "expression": form.expression, "params": {"a": 1.75}, "domain": {"x": [0.0, 1.0]}}  # fmt: skip
        prog = build_program({"toy_exp": record})
        assert [r.name for r in prog.routines] == ["toy_exp"] and prog.terms == () and prog.name == "toy_codegen"
        files = emit(prog, "python")
        assert set(files) == {"toy_codegen.py"} and "A toy family" in files["toy_codegen.py"]
        namespace = {}
        exec(compile(files["toy_codegen.py"], "toy_codegen.py", "exec"), namespace)
        assert np.allclose(namespace["toy_exp"](np.array([0.0, 0.5, 1.0])), [1.0, 1.875, 2.75], rtol=1e-15)
        if compiler() is not None:
            native = build(emit(prog, "c"), prog, tmp_path)
            assert np.allclose(native("toy_exp", np.array([0.0, 0.5, 1.0])), [1.0, 1.875, 2.75], rtol=1e-15)
    finally:
        unregister_family("toy_codegen")


# ---- the NaN and domain policy (fuzzed in test_codegen_fuzz.py) ---------------------


def test_policy_is_one_symbolic_definition_printed_in_every_language():
    """Max/Min print as the same NaN-propagating conditional in C, GLSL and numpy (with a constant, and of
    two expressions); more arguments are split by the emitter, not printed; every routine has a domain."""
    import sympy as sp

    from fitlab.codegen import Routine, with_domain
    from fitlab.codegen.printers import CPrinter, GLSLPrinter, NumpyPrinter

    x, y = symbols(("x", "y"))
    assert CPrinter("double", str).doprint(sp.Max(0, x)) == "((x < 0.0) ? (0.0) : (x))"
    assert CPrinter("float", str).doprint(sp.Min(1, x)) == "((x > 1.0F) ? (1.0F) : (x))"
    assert GLSLPrinter(str).doprint(sp.Max(-1, x)) == "((x < -1.0) ? (-1.0) : (x))"
    f = eval("lambda x: " + NumpyPrinter(str).doprint(sp.Min(1, sp.Max(0, x))), {"numpy": np})
    np.testing.assert_array_equal(f(np.array([np.nan, -np.inf, -1.0, 0.25, 2.0, np.inf])), [np.nan, 0, 0, 0.25, 1, 1])
    g = eval("lambda x, y: " + NumpyPrinter(str).doprint(sp.Max(x, y)), {"numpy": np})
    np.testing.assert_array_equal(g(np.array([np.nan, 1.0, 2.0, 0.5]), np.array([1.0, np.nan, 1.0, 3.0])),
                                  [np.nan, np.nan, 2.0, 3.0])  # fmt: skip
    with pytest.raises(ValueError, match="NaN policy"):
        CPrinter("double", str).doprint(sp.Max(x, y, sp.Rational(1, 2)))
    with pytest.raises(ValueError, match="no domain for y"):
        with_domain(Routine("f", ("x", "y"), x + y, "", domain={"x": (0.0, 1.0)}))


def test_every_routine_clamps_every_input(program):
    """build_program gives every routine of the program its domain and clamps every input it uses."""
    import sympy as sp

    for r in program.routines:
        assert set(r.domain) == set(r.args), r.name
        for s in r.expr.free_symbols:
            lo, hi = r.domain[s.name]
            assert r.expr.has(sp.Min(hi, sp.Max(lo, s))), (r.name, s)
            # (sympy may merge the clamp's min with a tighter one: min(1/2, max(0, kd)) stays clamped)
            assert not r.expr.xreplace({sp.Max(lo, s): sp.Dummy()}).has(s), (r.name, s, "used unclamped")


@needs_cc
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_brdf_clamps_and_nan_in_the_built_c(native, py, dtype):
    """The named edge values: brdf(..., c = 1.2) is brdf(..., c = 1), cos_phi = -2 is -1, NaN gives NaN
    in C and Python alike, and the parts are clamped too."""
    f = lambda name, *a: native(name, *a, dtype=dtype)  # noqa: E731
    for g in (f, lambda name, *a: getattr(py, name)(*a)):
        assert g("brdf", 0.3, 0.6, 0.4, 1.2) == g("brdf", 0.3, 0.6, 0.4, 1.0) > 0
        assert g("brdf", 0.3, 0.6, -2.0, 0.7) == g("brdf", 0.3, 0.6, -1.0, 0.7) > 0
        assert g("brdf", 0.3, 0.6, 2.0, 0.7) == g("brdf", 0.3, 0.6, 1.0, 0.7) > 0
        assert np.isnan(g("brdf", np.nan, 0.5, 0.5, 0.5)) and np.isnan(g("brdf", 0.5, 0.5, np.nan, 0.5))
        assert np.isnan(g("c_of_kd", np.nan))
        assert g("h0", 0.5, 1.5) == g("h0", 0.5, 1.0) and np.isfinite(g("h0", 0.5, 1.0))
        assert g("h1", np.inf, 0.5) == g("h1", 1.0, 0.5) and np.isfinite(g("h1", 1.0, 0.5))
        assert g("const_l", np.inf) == g("const_l", 1.0) and np.isfinite(g("const_l", 1.0))
        assert g("const_l", -np.inf) == g("const_l", 0.0) == 0.0


def test_default_model_is_the_reports_real_time_recommendation():
    """One rule picks the real-time model (fitlab.report.pareto.recommend, on the committed docs/report.csv),
    and the generated code's default model is in the forms it picks; the pick's parts are those fitted to the true
    BRDF (fitlab/fits/true, the row the report names by that folder), which ``--fits fitlab/fits/true`` prints."""
    import csv
    import math

    from fitlab.report.pareto import recommend

    def number(v):
        try:
            return float(v)
        except ValueError:
            return math.nan

    with open(ROOT / "docs" / "report.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["section"] == "brdf"]
    numeric = ("max_rel", "rms_rel", "max_rel_grazing", "bytes", "ns_c_double", "ns_python")
    rows = [{**r, **{k: number(r[k]) for k in numeric}} for r in rows]
    picked = recommend(rows)["real-time"]
    changed = {t: f for t, f in MODEL_FORMS.items() if f != get_target(t).default_form}
    label = ", ".join(f"{t}: {f}" for t, f in changed.items())
    assert picked["source"].endswith(f"fitlab/fits/true: {label})")  # the folder: test_true_refit.py
    assert program_spec("lambert_sphere").default_model == "true"
