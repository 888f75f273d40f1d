"""The walk's random numbers and its Beckmann visible-normal inversion against independent computations:
the unrolled Threefry-2x32 is JAX's bit for bit, and the Newton inversion of the visible-slope CDF (which
stops each lane at its own convergence) agrees with a bracketing root finder (scipy's brentq) on the same
equation, rising and falling directions, u down to 2^-33 and up to 1 - 2^-33."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
import pytest
from jax.extend.random import threefry_2x32
from scipy.optimize import brentq
from scipy.special import erfc, erfinv

from fitlab._montecarlo import threefry_2x32 as threefry_2x32_unrolled
from fitlab.core import float64
from fitlab.families.microfacet_energy.mc.microsurface import sample_vndf
from fitlab.families.microfacet_energy.mc.walk import job_key


@float64
def test_unrolled_threefry_is_jax_threefry():
    rng = np.random.default_rng(3)
    x0 = rng.integers(0, 2**32, 4096, dtype=np.uint64).astype(np.uint32)
    x1 = rng.integers(0, 2**32, 4096, dtype=np.uint64).astype(np.uint32)
    x0[:3], x1[:3] = (0, 2**32 - 1, 7), (0, 2**32 - 1, 2**31)
    for seed in (0, 1, 2**63 - 1):
        key = jnp.asarray(job_key(seed, 3, 1), jnp.uint32)
        ref = np.asarray(threefry_2x32(key, jnp.concatenate([jnp.asarray(x0), jnp.asarray(x1)])))
        a, b = threefry_2x32_unrolled(key, jnp.asarray(x0), jnp.asarray(x1))
        np.testing.assert_array_equal(np.concatenate([np.asarray(a), np.asarray(b)]), ref)


def _visible_slope_equation(w, ax, ay):
    """(g, g_max, rotation) of the visible-slope equation g(x) = u g_max (module docstring of .microsurface)
    for the direction w: g the CDF up to its normalisation, rotation (cos phi, sin phi) of the stretched w."""
    v = np.array([ax * w[0], ay * w[1], w[2]])
    v /= np.linalg.norm(v)
    sin_t = math.hypot(v[0], v[1])
    cos_t = v[2]
    s_i = min(max(cos_t / sin_t, -6.0), 8.0)

    def g(x):
        return 0.5 * cos_t * erfc(-x) + sin_t * math.exp(-x * x) / (2.0 * math.sqrt(math.pi))

    return g, g(s_i), s_i, (v[0] / sin_t, v[1] / sin_t), cos_t, sin_t


@float64
def test_beckmann_inversion_agrees_with_brentq():
    """The walk's x (recovered from its normal) solves g(x) = u g_max to its stopping rule, |residual| <=
    1e-14 g_max (an error of 1e-14 in u, far below the 2^-32 spacing of the walk's uniforms), and is the
    brentq root within what that residual allows, 1e-14 g_max / g'(x)."""
    rng = np.random.default_rng(5)
    ax, ay = 0.4, 0.9
    cases = []
    for _ in range(300):
        w = rng.normal(size=3)
        w /= np.linalg.norm(w)
        v = np.array([ax * w[0], ay * w[1], w[2]])
        if v[2] / math.hypot(v[0], v[1]) < -6.0:  # steeper rising rays take the bracket of cot = -6 (module
            continue  # docstring): an approximation for rays that all but never hit
        cases.append((w, rng.uniform(), rng.uniform()))
    edge_u = (2.0**-33, 1e-6, 0.5, 1.0 - 1e-6, 1.0 - 2.0**-33)
    cases += [(np.array([0.6, 0.0, 0.8]), u, 0.3) for u in edge_u] + [
        (np.array([0.6, 0.0, -0.8]), u, 0.7) for u in edge_u
    ]
    w = np.array([c[0] for c in cases])
    u1 = np.array([c[1] for c in cases])
    u2 = np.array([c[2] for c in cases])
    m = np.array(
        sample_vndf(*(jnp.asarray(w[:, k]) for k in range(3)), jnp.asarray(u1), jnp.asarray(u2), ax, ay, "beckmann")
    ).T
    for (wi, u, b), got in zip(cases, m):
        g, g_max, s_i, (cos_p, sin_p), cos_t, sin_t = _visible_slope_equation(wi, ax, ay)
        xr, yr = -got[0] / (ax * got[2]), -got[1] / (ay * got[2])
        x_walk, y_walk = cos_p * xr + sin_p * yr, -sin_p * xr + cos_p * yr
        target = u * g_max
        assert abs(g(x_walk) - target) <= 1e-13 * g_max, (wi, u)
        x = brentq(lambda t, g=g, target=target: g(t) - target, min(s_i - 1.0, -8.0), s_i, xtol=1e-15, rtol=1e-15)
        slope = math.exp(-x * x) * (cos_t - x * sin_t) / math.sqrt(math.pi)
        assert abs(x_walk - x) <= 1e-12 + 1e-13 * g_max / slope, (wi, u)
        assert y_walk == pytest.approx(erfinv(2.0 * b - 1.0), abs=1e-12)


# -- the walks' uniforms and heights in float32 ------------------------------------------------------------
_EXTREME_WORDS = [
    0,
    1,
    0xFF,
    0x1FF,
    0x200,
    0xFFFF,
    2**23 - 1,
    2**23,
    2**24 - 1,
    2**24,
    2**31 - 1,
    2**31,
    2**31 + 1,
    0xFFFFFE00,
    0xFFFFFEFF,
    0xFFFFFF00,
    0xFFFFFF7F,
    0xFFFFFF80,
    0xFFFFFFFE,
    0xFFFFFFFF,
]


@float64
@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_uniforms_are_cell_midpoints_strictly_inside_0_1(dtype):
    """Every uniform is the midpoint of its cell of [0, 1], exactly, as the docstring states, and strictly
    inside (0, 1), also 1 - u, at the extreme words; before, float32's (word >> 8 + 1/2) 2^-24 rounded to 1 for
    the 256 words from 0xFFFFFF00 (and to the even neighbour for every word >= 2^31)."""
    from fitlab._montecarlo import FLOAT32_UNIFORM_BITS, uniforms

    bits = FLOAT32_UNIFORM_BITS if dtype == "float32" else 32
    rng = np.random.default_rng(59)
    words = np.concatenate([_EXTREME_WORDS, rng.integers(0, 2**32, 100_000)]).astype(np.uint32)
    u = np.asarray(uniforms(jnp.asarray(words), jnp.dtype(dtype)))
    assert u.dtype == np.dtype(dtype)
    exact = [(math.floor(int(w) / 2 ** (32 - bits)) + 0.5) / 2**bits for w in words]  # Python floats: exact here
    assert np.array_equal(u.astype(np.float64), np.array(exact))
    one_minus = np.asarray(jnp.asarray(1.0, dtype) - jnp.asarray(u))
    assert u.min() == 2.0 ** -(bits + 1) and one_minus.min() == 2.0 ** -(bits + 1) and u.max() < 1.0


def _fall(c_or_h, one_minus_u, by_c1):
    """The next height of a ray falling straight down (Lambda = -1: C1 -> C1 (1 - U)) from C1 or h."""
    from fitlab.families.microfacet_energy.mc.microsurface import sample_c1, sample_height

    f32 = jnp.float32
    u = f32(1.0) - f32(one_minus_u)
    sample = sample_c1 if by_c1 else sample_height
    return sample(f32(0.0), f32(0.0), f32(-1.0), f32(c_or_h), u, f32(1.0), f32(1.0), "ggx")


def test_float32_heights_resolve_the_bottom_of_the_microsurface():
    """Two falls at normal incidence with 1 - U = 2^-12, then 2^-14, end at C1 = 2^-26.  A float32 h rounds
    2 C1 - 1 to -1 exactly, where G1 = 0 and a rising near-normal ray's next height is 0 / 0 = NaN (how paths of
    the float32 walk ended as NaN and were capped after 1000 bounces); the float32 walk's C1 holds it, and a
    rising ray from there meets the surface above it or escapes."""
    from fitlab.families.microfacet_energy.mc.microsurface import ESCAPED, sample_c1, sample_height

    f32 = jnp.float32
    h = _fall(_fall(1.0, 2.0**-12, False), 2.0**-14, False)
    assert float(h) == -1.0
    rise = (f32(1e-3), f32(0.0), f32(np.sqrt(1 - 1e-6)))  # near normal: 1 / Lambda ~ 1e7, (1 - U)^(1/Lambda) = 0
    assert np.isnan(float(sample_height(*rise, h, f32(0.5), f32(1.0), f32(1.0), "ggx")))
    c1 = _fall(_fall(1.0, 2.0**-12, True), 2.0**-14, True)
    assert float(c1) == 2.0**-26
    for u in (2.0**-24, 0.5, 1 - 2.0**-24):
        after = float(sample_c1(*rise, c1, f32(u), f32(1.0), f32(1.0), "ggx"))
        assert after == ESCAPED or 2.0**-26 < after <= 1.0
