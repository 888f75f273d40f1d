"""The generated GGX albedos in the domain's corner (mu, alpha) -> (0, 0), in float64 and float32.

For small alpha, E(mu, alpha) depends on mu only through t = mu/alpha (the grazing layer; the exact engine's
values along a line mu = t alpha are the same for every alpha from 1e-6 down, its limit as alpha -> 0), and the
forms are written in v = alpha/(mu + alpha), exact for every mu + alpha down to the smallest normal float32
(fitlab/families/microfacet_energy/forms/common.py).  Checked here against the exact engine, with each fit's
own recorded validation error as the bound: the generated Python and C (double and float) along lines mu = t
alpha for alpha from 1e-6 down to 1e-30 (float32: 1e-30 too, where alpha^4 is not a float32), the mirror line
alpha = 0 (E = 1 exactly, 1 - E = 0) and the corner itself.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from fitlab.families.microfacet_energy.exact import directional_albedo

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "fitlab" / "fits" / "generated"
FITS = ROOT / "fitlab" / "fits"
MODEL = {"ggx_sep": "ggx_separable", "ggx_cor": "ggx_correlated"}
#: lines mu = t alpha through the corner: grazing (t = 0), inside the layer, and past it
T = np.array([0.0, 1 / 16, 0.5, 1.0, 2.0, 5.0, 16.0, 256.0])
#: alpha along those lines: from the validation set's smallest (1e-6) down to far below any floor
ALPHAS = (1e-6, 1e-8, 1e-9, 1e-12, 1e-20, 1e-30)
ROUTINES = [f"{q}_{m}" for m in MODEL for q in ("E", "one_minus_E")]


@pytest.fixture(scope="module")
def py():
    spec = importlib.util.spec_from_file_location("microfacet_energy_corners", GENERATED / "microfacet_energy.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def native(tmp_path_factory):
    from fitlab.codegen import load_program
    from fitlab.codegen.native import build, compiler

    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    files = {n: (GENERATED / n).read_text() for n in ("microfacet_energy.c", "microfacet_energy.h")}
    return build(files, load_program(family="microfacet_energy"), tmp_path_factory.mktemp("corners"))


def _recorded(routine):
    """The fit's recorded validation figure (max absolute error of E, max floored-relative error of 1 - E)."""
    record = json.loads((FITS / f"{routine}.json").read_text())
    return record["validation"]["max_rel"]


def _error(routine, approx, exact_e):
    exact = exact_e if routine.startswith("E_") else 1.0 - exact_e
    scale = 1.0 if routine.startswith("E_") else np.maximum(np.abs(exact), 1e-3)
    return np.abs(approx - exact) / scale


@pytest.fixture(scope="module")
def limits():
    """{model suffix: exact E along the lines T at alpha = 1e-12}, and the same at 1e-6: the exact limit."""
    out = {}
    for suffix, model in MODEL.items():
        e = directional_albedo(T * 1e-12, np.full_like(T, 1e-12), model)
        e6 = directional_albedo(T * 1e-6, np.full_like(T, 1e-6), model)
        np.testing.assert_allclose(e, e6, rtol=0, atol=1e-7)  # the exact E no longer depends on alpha there
        out[suffix] = e
    return out


@pytest.mark.parametrize("routine", ROUTINES)
def test_python_double_reaches_the_exact_limit_along_every_line(py, limits, routine):
    bound = _recorded(routine)
    e_exact = limits["ggx_" + routine[-3:]]
    f = getattr(py, routine)
    limit = f(T * 1e-12, np.full_like(T, 1e-12))
    for a in ALPHAS:
        got = f(T * a, np.full_like(T, a))
        if a <= 1e-9:  # one function of t along every line (the forms' own alpha terms are O(alpha)), down to
            # alpha = 1e-30: nothing blends with the corner's value
            np.testing.assert_allclose(got, limit, rtol=0, atol=1e-8, err_msg=f"alpha = {a:g}")
        err = _error(routine, got, e_exact)
        assert np.max(err) <= 1.1 * bound, (routine, a, T[np.argmax(err)], np.max(err), bound)


@pytest.mark.parametrize("routine", ROUTINES)
def test_mirror_line_and_corner_are_the_mirror(py, routine):
    mu = np.array([0.0, 1e-30, 1e-9, 1e-3, 0.5, 1.0])
    got = getattr(py, routine)(mu, np.zeros_like(mu))
    # the exact engine defines alpha = 0 as the mirror: E = 1 at every mu, the corner included
    want = directional_albedo(mu, np.zeros_like(mu), MODEL["ggx_" + routine[-3:]])
    np.testing.assert_array_equal(want, 1.0)
    np.testing.assert_array_equal(got, want if routine.startswith("E_") else 1.0 - want)


@pytest.mark.parametrize("routine", ROUTINES)
def test_c_double_and_float_at_the_corner(py, native, limits, routine):
    bound = _recorded(routine)
    e_exact = limits["ggx_" + routine[-3:]]
    for a in (*ALPHAS, 1e-37):
        mu, alpha = T * a, np.full_like(T, a)
        want = getattr(py, routine)(mu, alpha)
        np.testing.assert_allclose(native(routine, mu, alpha), want, rtol=1e-12, atol=1e-15)
        f32 = native(routine, mu.astype(np.float32), alpha.astype(np.float32), dtype=np.float32)
        assert np.all(np.isfinite(f32)), (routine, a, f32)
        # float is the double rounded, mu + alpha a normal float32 (mu below it too, 6e-39 at alpha = 1e-37)
        scale = 1.0 if routine.startswith("E_") else np.maximum(np.abs(want), 1e-3)
        assert np.max(np.abs(f32 - want) / scale) <= 1e-5, (routine, a, f32, want)
        assert np.max(_error(routine, f32.astype(float), e_exact)) <= 1.1 * bound + 1e-5, (routine, a)
    # the mirror line and the corner, in float
    mu = np.array([0.0, 1e-30, 1e-3, 1.0], dtype=np.float32)
    f32 = native(routine, mu, np.zeros_like(mu), dtype=np.float32)
    np.testing.assert_array_equal(f32, 1.0 if routine.startswith("E_") else 0.0)

