"""The generated code's NaN and domain policy, fuzzed: every exported routine, C (double and float),
Python and GLSL (compiled as C through the shim of its built-ins).

The policy (docs/codegen.md, "Guarantees"):

* NaN in any input gives NaN;
* a finite input outside the domain, and +-inf, is clamped into it: mu, c, kd into [0, 1], cos_phi into
  [-1, 1], the components of the local routines' vectors into [-1, 1];
* every other input gives a finite value; brdf and its variants are >= 0.

The domains are written here, not read from the generator: a generator that widens a clamp (c to [0, 2])
must fail these tests, whatever it writes into fits/generated.  The tests run the committed files in
fits/generated (test_codegen.py checks that they are what the committed fits generate).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest

from fitlab.codegen import load_program
from fitlab.codegen.native import build, build_glsl, compiler

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
GENERATED = ROOT / "fitlab" / "fits" / "generated"
needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler on PATH")

#: the documented domain of every scalar argument; a vector's components are in VECTOR
DOMAIN = {"mu": (0.0, 1.0), "mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "c": (0.0, 1.0), "kd": (0.0, 1.0),
          "cos_phi": (-1.0, 1.0), "u1": (0.0, 1.0), "u2": (0.0, 1.0)}  # fmt: skip
VECTOR = (-1.0, 1.0)
#: the routines that are a BRDF (or a part of one that is >= 0 by construction), or a density
NONNEGATIVE = {"brdf", "brdf_fast", "brdf_local", "brdf_fast_local", "single", "pdf_local", "sample_local"}

#: points per routine: C gets N_C per routine and scalar type, 17 routines x 2 types x 300k = 1.0e7 in all
N_C, N_PY, N_GLSL = 300_000, 40_000, 40_000


def edges(dtype) -> np.ndarray:
    """NaN, +-inf, +-0, denormals, the smallest normal, negative, > 1, +-huge, 1 +- ulp, -1 +- ulp, ..."""
    f = np.finfo(dtype)
    one, zero = dtype(1), dtype(0)
    huge = [1e300, -1e300] if dtype == np.float64 else []
    vals = [np.nan, np.inf, -np.inf, 0.0, -0.0, f.smallest_subnormal, -f.smallest_subnormal, f.smallest_normal,
            -f.smallest_normal, f.tiny * 4, 1e-7, -1e-7, 0.25, 0.5, -0.5, 2.0, -2.0, 1.2, -1.2, 1e10, -1e10,
            f.max, -f.max, np.nextafter(one, zero), one, np.nextafter(one, dtype(2)), -np.nextafter(one, zero),
            -one, -np.nextafter(one, dtype(2)), np.nextafter(zero, one), *huge]  # fmt: skip
    return np.array(vals, dtype=dtype)


def sample(rng, n: int, lo: float, hi: float, dtype) -> np.ndarray:
    """n values of one argument: a mix of edge values, uniform in the domain, uniform a little outside it,
    and log-uniform magnitudes of either sign over the type's whole range."""
    f = np.finfo(dtype)
    kind = rng.integers(0, 4, n)
    out = rng.uniform(lo, hi, n)
    wide = kind == 1
    out[wide] = rng.uniform(lo - 1.5, hi + 1.5, wide.sum())
    logs = kind == 2
    exps = rng.uniform(np.log10(float(f.smallest_subnormal)), np.log10(float(f.max)), logs.sum())
    out[logs] = np.where(rng.random(logs.sum()) < 0.5, -1.0, 1.0) * 10.0**exps
    out = out.astype(dtype)  # (huge values round to +-max or +-inf in float: kept, they are edge cases too)
    e = kind == 3
    out[e] = rng.choice(edges(dtype), e.sum())
    return out


def fuzz_inputs(routine, n: int, dtype, seed: int):
    """Arguments (raw) for ``routine``: scalars (n,), vectors (n, 3); a quarter of the vectors are unit vectors."""
    rng = np.random.default_rng(seed)
    args = []
    for a in routine.signature():
        if a in routine.vectors:
            v = np.stack([sample(rng, n, *VECTOR, dtype) for _ in range(3)], axis=-1)
            unit = rng.random(n) < 0.25
            u = rng.normal(size=(unit.sum(), 3))
            v[unit] = (u / np.linalg.norm(u, axis=-1, keepdims=True)).astype(dtype)
            args.append(v)
        else:
            args.append(sample(rng, n, *DOMAIN[a], dtype))
    return args


def clip(routine, args):
    """The arguments clamped into the documented domains (NaN stays NaN)."""
    return [np.clip(x, *(VECTOR if a in routine.vectors else DOMAIN[a])) for a, x in zip(routine.signature(), args)]


def nan_in(routine, args) -> np.ndarray:
    return np.any([np.isnan(x).reshape(len(x), -1).any(axis=1) for x in args], axis=0)


def value_of(result):
    """A routine's value; for a sampler (value, vector) the value, NaN wherever the vector is not finite (the
    direction must be finite wherever the density is not NaN; with a NaN input the density is NaN, the
    direction may be either)."""
    if not isinstance(result, tuple):
        return result
    vector, value = result
    return value + 0 * np.sum(vector, axis=-1)


def check_policy(name, routine, f, args, tag):
    """f(args) is NaN exactly where an input is NaN, finite elsewhere, equal to f(clip(args)), >= 0 for a BRDF."""
    out = value_of(f(*args))
    bad = nan_in(routine, args)
    assert out.shape == bad.shape
    wrong_nan = np.isnan(out) != bad
    assert not wrong_nan.any(), f"{tag} {name}: NaN policy broken at {[x[wrong_nan][:3] for x in args]}"
    finite = np.isfinite(out[~bad])
    assert finite.all(), f"{tag} {name}: not finite at {[x[~bad][~finite][:3] for x in args]}"
    clipped = value_of(f(*clip(routine, args)))
    differ = ~((out == clipped) | (np.isnan(out) & np.isnan(clipped)))
    assert not differ.any(), (f"{tag} {name}: clamping the inputs into the documented domain changes the value at "
                              f"{[x[differ][:3] for x in args]}: {out[differ][:3]} vs {clipped[differ][:3]}")  # fmt: skip
    if name in NONNEGATIVE:
        assert (out[~bad] >= 0).all(), f"{tag} {name}: negative"
    return out.size


# ---- fixtures: the committed files -------------------------------------------------


@pytest.fixture(scope="module")
def program():
    os.chdir(ROOT)
    return load_program(FITS)


def _committed(*names):
    return {n: (GENERATED / n).read_text() for n in names}


@pytest.fixture(scope="module")
def native(program, tmp_path_factory):
    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    return build(_committed("lambert_sphere.c", "lambert_sphere.h"), program, tmp_path_factory.mktemp("fuzz_c"))


@pytest.fixture(scope="module")
def glsl(program, tmp_path_factory):
    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    return build_glsl(_committed("lambert_sphere.glsl"), program, tmp_path_factory.mktemp("fuzz_glsl"))


@pytest.fixture(scope="module")
def py():
    spec = importlib.util.spec_from_file_location("fuzz_lambert_sphere", GENERATED / "lambert_sphere.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_every_argument_has_a_documented_domain(program):
    """A routine with an argument this file does not know would escape the fuzzing below."""
    for r in program.routines:
        for a in r.signature():
            assert a in r.vectors or a in DOMAIN, (r.name, a)
    assert len(program.routines) == 23  # with h2 and fm2 (the order-2 term), and the sampler's four


# ---- the fuzz ----------------------------------------------------------------------


@needs_cc
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_c_policy_fuzz(program, native, dtype):
    total = 0
    for k, r in enumerate(program.routines):
        args = fuzz_inputs(r, N_C, dtype, seed=1000 + k)
        total += check_policy(r.name, r, lambda *a, r=r: native(r.name, *a, dtype=dtype), args, f"C {np.dtype(dtype)}")
    assert total == N_C * len(program.routines)


def test_python_policy_fuzz(program, py):
    for k, r in enumerate(program.routines):
        args = fuzz_inputs(r, N_PY, np.float64, seed=2000 + k)
        f = getattr(py, r.name)
        with np.errstate(
            divide="raise", over="raise", invalid="raise"
        ):  # no inf or NaN made inside, no pow of a negative
            check_policy(r.name, r, f, args, "Python")
    # float32 inputs are taken as float64 by the numpy module: the same policy
    r = program.routine("brdf")
    check_policy("brdf", r, py.brdf, fuzz_inputs(r, N_PY, np.float32, seed=2999), "Python float32 inputs")


@needs_cc
def test_glsl_policy_fuzz(program, glsl):
    for k, r in enumerate(program.routines):
        args = fuzz_inputs(r, N_GLSL, np.float32, seed=3000 + k)
        check_policy(r.name, r, lambda *a, r=r: glsl(r.name, *a, dtype=np.float32), args, "GLSL (as C)")


# ---- named points: the clamps and the NaN policy, in every language ------------------


def _languages(native, glsl, py):
    return {
        "C double": lambda name, *a: value_of(native(name, *a)),
        "C float": lambda name, *a: value_of(native(name, *a, dtype=np.float32)),
        "GLSL": lambda name, *a: value_of(glsl(name, *a, dtype=np.float32)),
        "Python": lambda name, *a: value_of(getattr(py, name)(*a)),
    }


@needs_cc
def test_clamps_at_named_points(native, glsl, py):
    for lang, f in _languages(native, glsl, py).items():

        def same(name, outside, inside, f=f, lang=lang):
            got, want = f(name, *outside), f(name, *inside)
            assert np.isfinite(want) and got == want, (lang, name, outside, got, want)

        same("brdf", (0.3, 0.6, 0.4, 1.2), (0.3, 0.6, 0.4, 1.0))  # c = 1.2 is c = 1
        same("brdf", (0.3, 0.6, 0.4, -0.5), (0.3, 0.6, 0.4, 0.0))
        same("brdf", (0.3, 0.6, -2.0, 0.7), (0.3, 0.6, -1.0, 0.7))  # cos_phi = -2 is cos_phi = -1
        same("brdf", (0.3, 0.6, 2.0, 0.7), (0.3, 0.6, 1.0, 0.7))
        same("brdf", (1.5, -0.2, 0.1, 0.7), (1.0, 0.0, 0.1, 0.7))
        same("brdf", (np.inf, 0.5, -np.inf, np.inf), (1.0, 0.5, -1.0, 1.0))
        same("brdf_fast", (0.3, 0.6, 0.4, 0.7, 1.7), (0.3, 0.6, 0.4, 0.7, 1.0))
        same("h0", (0.5, 1.5), (0.5, 1.0))
        same("h1", (1e30, 0.5), (1.0, 0.5))
        same("const_l", (1e30,), (1.0,))
        same("c_of_kd", (-3.0,), (0.0,))
        same("kd_of_c", (np.inf,), (1.0,))
        same("fm1", (0.2, 0.3, 2.0), (0.2, 0.3, 1.0))
        same("brdf_local", (np.array([3.0, 0.0, 0.5]), np.array([0.6, 0.0, 0.8]), 1.2),
             (np.array([1.0, 0.0, 0.5]), np.array([0.6, 0.0, 0.8]), 1.0))  # fmt: skip


@needs_cc
def test_nan_in_any_input_gives_nan(program, native, glsl, py):
    for lang, f in _languages(native, glsl, py).items():
        for r in program.routines:
            sig = r.signature()
            base = [np.array([0.6, 0.0, 0.8]) if a in r.vectors else 0.5 for a in sig]
            for k, a in enumerate(sig):
                args = list(base)
                args[k] = np.array([0.6, np.nan, 0.8]) if a in r.vectors else np.nan
                assert np.isnan(f(r.name, *args)), (lang, r.name, a)
                if a in r.vectors and len(r.vectors) == 2:  # the other below the surface (0) unless NaN: NaN wins
                    args[1 - k if k < 2 else 0] = np.array([0.6, 0.0, -0.8])
                    assert np.isnan(f(r.name, *args)), (lang, r.name, a, "below")
        assert f("brdf_local", np.array([0.6, 0.0, -0.8]), np.array([0.6, 0.0, 0.8]), 0.5) == 0.0
