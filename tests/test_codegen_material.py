"""Per-material set-up in generated code: prepare once, evaluate many times.

``prepare_c(c)`` / ``prepare(kd)`` fill a struct with every quantity that depends on the material alone;
``eval`` and ``eval_local`` give what ``brdf`` and ``brdf_local`` give, in every language (C double and
float, numpy, GLSL compiled as C), with the RGB variants three evaluations.  The transformation itself
(inline, merge exponentials, hoist) is checked on small expressions.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import sympy as sp

from fitlab.codegen import (
    MaterialSpec,
    Routine,
    call,
    clamp,
    emit,
    field_symbol,
    hoist_params,
    inline_calls,
    load_program,
    material_of,
    merge_exp_products,
)
from fitlab.codegen.native import build, build_glsl, compiler
from fitlab.forms.symbolic import symbols

needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler on PATH")
x, y, c = symbols(("x", "y", "c"))


# ---- the transformation ----------------------------------------------------------


def test_hoist_gathers_what_depends_on_the_parameters_alone():
    expr = 0.5 * sp.sqrt(1 - c) * x**2 + 3 * c + 2 + sp.exp(c) * y
    (out,), fields = hoist_params([expr], ("c",))
    assert {s.name for s in out.free_symbols} <= {"x", "y", "material_0", "material_1", "material_2"}
    # the evaluator reads the fields; substituting them back gives the expression
    assert sp.simplify(out.xreplace({field_symbol(j): f for j, f in enumerate(fields)}) - expr) == 0
    # 3c + 2 is one field (numbers go with the material), as is 0.5 sqrt(1 - c)
    assert any(sp.simplify(f - (3 * c + 2)) == 0 for f in fields)
    assert any(sp.simplify(f - 0.5 * sp.sqrt(1 - c)) == 0 for f in fields)


def test_hoist_leaves_conditions_in_place():
    expr = sp.Piecewise((x, c < sp.Rational(1, 2)), (c * x, True))
    (out,), fields = hoist_params([expr], ("c",))
    assert out.has(sp.StrictLessThan) and fields == [c]


def test_inline_and_merge_exponentials():
    h = Routine("h", ("x", "c"), sp.exp(c * x), "h", domain={"x": (0.0, 1.0), "c": (0.0, 1.0)})
    top = Routine(
        "top",
        ("x", "y", "c"),
        call("h", x, c) * call("h", y, c),
        "top",
        domain={"x": (0.0, 1.0), "y": (0.0, 1.0), "c": (0.0, 1.0)},
    )
    inlined = inline_calls(top.expr, {"h": h, "top": top})
    assert inlined == sp.exp(c * x) * sp.exp(c * y)
    merged = merge_exp_products(inlined)
    assert sum(1 for e in sp.preorder_traversal(merged) if isinstance(e, sp.exp)) == 1
    assert sp.simplify(merged - inlined) == 0


def test_a_clamped_argument_is_not_clamped_again():
    h = Routine("h", ("x",), clamp(x, 0.0, 1.0) ** 2, "h", domain={"x": (0.0, 1.0)})
    out = inline_calls(call("h", clamp(y, 0.0, 1.0)), {"h": h})
    assert out == clamp(y, 0.0, 1.0) ** 2


def test_material_of_names_evaluators_and_setups():
    r = Routine("f", ("x", "c"), sp.sqrt(1 - c) * x + c**2, "f", domain={"x": (0.0, 1.0), "c": (0.0, 1.0)})
    m = material_of([r], MaterialSpec(("c",), {"eval": "f"}, {"prepare": ("kd", "c_of_kd")}))
    assert m.prepare_name == "prepare_c" and m.setups == (("prepare", "kd", "c_of_kd"),)
    (ev,) = m.evaluators
    assert ev.args == ("x",) and "c" not in {s.name for s in ev.expr.free_symbols}


# ---- the generated Lambert-sphere code ---------------------------------------------


@pytest.fixture(scope="module")
def program():
    return load_program()


@pytest.fixture(scope="module")
def native(program, tmp_path_factory):
    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    return build(emit(program, "c"), program, tmp_path_factory.mktemp("material"))


@pytest.fixture(scope="module")
def py(program, tmp_path_factory):
    d = tmp_path_factory.mktemp("material_py")
    path = d / f"{program.name}.py"
    path.write_text(emit(program, "python")[path.name])
    spec = importlib.util.spec_from_file_location("material_generated", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def points():
    """Materials (the edges c = 0, 1e-9, 1e-4, 1, and random) and points, random and at the edges of mu and
    cos phi; point i takes material which[i]."""
    rng = np.random.default_rng(19)
    c = np.concatenate(([0.0, 1e-9, 1e-4, 0.5, 1.0], rng.random(40)))
    n = 20000
    mu_i, mu_o, cos_phi = rng.random(n), rng.random(n), rng.uniform(-1, 1, n)
    edge = np.array([0.0, 1e-6, 0.01, 1.0])
    e = [a.ravel() for a in np.meshgrid(edge, edge, np.array([-1.0, 0.0, 1.0]), indexing="ij")]
    mu_i, mu_o, cos_phi = (np.concatenate((a, b)) for a, b in zip((mu_i, mu_o, cos_phi), e))
    which = rng.integers(0, len(c), len(mu_i))
    which[: len(c)] = np.arange(len(c))
    return c, which, mu_i, mu_o, cos_phi


def _rel(a, b):
    return np.abs(a - b) / np.where(b != 0, np.abs(b), 1.0)


def test_the_evaluators_read_no_material_parameter(program):
    m = program.material
    assert m.params == ("c",) and len(m.fields) > 0
    for r in m.evaluators:
        assert "c" not in {s.name for s in r.expr.free_symbols}, r.name
    for f in m.fields:
        assert {s.name for s in f.free_symbols} == {"c"}


@needs_cc
def test_eval_is_brdf_in_c(native, points):
    c, which, mu_i, mu_o, cos_phi = points
    mats = native("prepare_c", c)
    got = native("eval", mats, which, mu_i, mu_o, cos_phi)
    want = native("brdf", mu_i, mu_o, cos_phi, c[which])
    # the same expression rearranged (hoisted, exp(a) exp(b) = exp(a + b)): agreement to rounding, relative
    # to the size of the O(c) terms where f ~ c^2 at c -> 0 (as in tests/test_codegen.py)
    scale = np.maximum(np.abs(want), c[which] / (np.pi * np.maximum(mu_i + mu_o, 1e-6)))
    assert np.all(np.isfinite(got))
    assert np.max(np.abs(got - want) / np.where(scale > 0, scale, 1.0)) < 1e-12
    assert np.all(got[c[which] == 0] == 0)


@needs_cc
def test_float_eval_within_1e4_of_double(native, points):
    """The float version within 1e-4 relative of the double one (mu >= 0.01, as the goal's domain)."""
    c, which, mu_i, mu_o, cos_phi = (np.float32(a).astype(float) if a.dtype.kind == "f" else a for a in points)
    keep = (mu_i >= 0.01) & (mu_o >= 0.01) & (c[which] > 0)
    d = native("eval", native("prepare_c", c), which, mu_i, mu_o, cos_phi)
    f = native("eval", native("prepare_c", c, dtype=np.float32), which, mu_i, mu_o, cos_phi, dtype=np.float32)
    assert np.max(_rel(f[keep], d[keep])) < 1e-4


@needs_cc
def test_prepare_kd_rgb_and_local(native, points):
    c, which, mu_i, mu_o, cos_phi = points
    kd = np.array([0.0, 0.2, 0.5, 0.9, 1.0])
    assert np.array_equal(native("prepare", kd), native("prepare_c", native("c_of_kd", kd)))
    mats = native("prepare", np.array([0.2, 0.5, 0.9, 0.3, 0.6, 1.0]))  # two RGB materials
    pick = which % 2
    rgb = native("eval_rgb", mats, pick, mu_i, mu_o, cos_phi)
    for k in range(3):
        assert np.array_equal(rgb[:, k], native("eval", mats, 3 * pick + k, mu_i, mu_o, cos_phi))
    rng = np.random.default_rng(4)
    wi, wo = rng.normal(size=(2, 3000, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    mats = native("prepare_c", c)
    w = which[:3000]
    assert np.max(_rel(native("eval_local", mats, w, wi, wo), native("brdf_local", wi, wo, c[w]))) < 1e-12


@needs_cc
def test_nan_and_out_of_domain_materials(native):
    mats = native("prepare_c", np.array([np.nan, 2.0, 1.0, -1.0, 0.0]))
    got = native("eval", mats, np.arange(5), 0.5, 0.4, 0.3)
    assert np.isnan(got[0]) and got[1] == got[2] and got[3] == got[4] == 0.0
    assert np.isnan(native("eval", mats, np.array([2]), np.nan, 0.4, 0.3)[0])


@needs_cc
def test_numpy_agrees_with_c(native, py, points):
    c, which, mu_i, mu_o, cos_phi = points
    mats = py.prepare_c(c)
    assert mats.shape == (len(c), len(native.material.fields))
    assert np.max(_rel(mats, native("prepare_c", c))) < 1e-13
    got = py.eval(mats[which], mu_i, mu_o, cos_phi)
    rel = _rel(got, native("eval", native("prepare_c", c), which, mu_i, mu_o, cos_phi))
    # Near mu_i = mu_o = 0 the evaluator adds terms some 1e5 times its value (at c = 0.777, mu_i = 0,
    # mu_o = 1e-6: C is 2e-12 and numpy 2e-11 from the 60-digit value), so a one-ulp difference between
    # numpy's exp and libm's is amplified there; everywhere else the two agree to 1e-12.
    grazing = np.minimum(mu_i, mu_o) < 1e-5
    assert np.max(rel[~grazing]) < 1e-12
    assert np.max(rel[grazing]) < 1e-10
    # RGB by broadcasting: materials (3, fields) against inputs with a trailing axis
    rgb = py.eval(py.prepare(np.array([0.2, 0.5, 0.9])), mu_i[:50, None], mu_o[:50, None], cos_phi[:50, None])
    assert rgb.shape == (50, 3)


@needs_cc
def test_glsl_agrees_with_c_float(program, native, points, tmp_path):
    glsl = build_glsl(emit(program, "glsl"), program, tmp_path / "glsl")
    c, which, mu_i, mu_o, cos_phi = points
    keep = (mu_i >= 0.01) & (mu_o >= 0.01)
    args = [a[keep].astype(np.float32) for a in (mu_i, mu_o, cos_phi)]
    want = native("eval", native("prepare_c", c, dtype=np.float32), which[keep], *args, dtype=np.float32)
    got = glsl("eval", glsl("prepare_c", c, dtype=np.float32), which[keep], *args, dtype=np.float32)
    assert np.all(np.abs(got - want) <= 1e-4 * np.abs(want) + 1e-7)
    mats = glsl("prepare", np.array([0.2, 0.5, 0.9], dtype=np.float32), dtype=np.float32)
    rgb = glsl("eval_rgb", mats, np.zeros(10, dtype=np.int64), *(a[:10] for a in args), dtype=np.float32)
    for k in range(3):
        assert np.array_equal(rgb[:, k], glsl("eval", mats, np.full(10, k), *(a[:10] for a in args), dtype=np.float32))


def test_baselines_have_the_same_set_up():
    """The benchmark's Lambert and Oren-Nayar get the same per-material treatment as the runtime model."""
    from fitlab.families.lambert_sphere.program.baselines import baseline_program

    prog = baseline_program()
    assert prog.material.params == ("kd",)
    lam = next(r for r in prog.material.evaluators if r.name == "eval_lambert")
    assert lam.expr == field_symbol(0) and sp.simplify(prog.material.fields[0] - symbols(("kd",))[0] / sp.pi) == 0
