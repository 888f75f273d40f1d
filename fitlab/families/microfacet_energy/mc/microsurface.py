r"""The Smith microsurface of Heitz, Hanika, d'Eon and Dachsbacher (2016), "Multiple-Scattering
Microfacet BSDFs with the Smith Model": heights, slopes, masking and the sampling of both.

Pure ``jax.numpy`` maps of directions and uniforms in (0, 1), so that the walk
(:mod:`.walk`) can vectorise them and tests can feed fixed uniforms.  Directions
are unit 3-vectors given as three arrays (x, y, z), z along the macro normal.

Slopes (anisotropic alpha_x, alpha_y; isotropic when equal).  With the stretched
tangent t^2(w) = (alpha_x^2 w_x^2 + alpha_y^2 w_y^2) / w_z^2 = alpha(phi)^2 tan^2(theta):

* GGX: D(m) = 1 / (pi alpha_x alpha_y mu_m^4 (1 + (m_x^2/alpha_x^2 + m_y^2/alpha_y^2) / mu_m^2)^2),
  Lambda(w) = (-1 + sqrt(1 + t^2)) / 2 for w_z > 0.
* Beckmann: D(m) = exp(-(m_x^2/alpha_x^2 + m_y^2/alpha_y^2) / mu_m^2) / (pi alpha_x alpha_y mu_m^4),
  Lambda(w) = (exp(-a^2) / (a sqrt(pi)) - erfc(a)) / 2 with a = 1 / t, for w_z > 0.
* Both are :mod:`fitlab.physics.microfacet`'s (Lambda at the roughness of w's azimuth, written without
  cancellation); this module adds the walk's heights and sampling.
* Downward directions (w_z < 0): Lambda(w) = -1 - Lambda(-w) (paper, eq. 9): the projected area of
  the microsurface seen along w is w_z (1 + Lambda(w)) either way.  Lambda(w) = 0 for w = +z.

Details: docs/microsurface.md, section ``fitlab.families.microfacet_energy.mc.microsurface``."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
from jax.scipy.special import erfc, erfinv

from fitlab._montecarlo import sincos_2pi
from fitlab.physics import microfacet

__all__ = [
    "DISTRIBUTIONS",
    "height_c1",
    "height_inv_c1",
    "smith_lambda",
    "masking_g1",
    "sample_height",
    "sample_c1",
    "sample_vndf",
    "reflect",
    "refract",
    "ESCAPED",
]

DISTRIBUTIONS = ("ggx", "beckmann")
#: sample_height's value for a ray that leaves the microsurface
ESCAPED = math.inf
#: most steps of the Beckmann visible-slope inversion (a bisection step halves the bracket; from the start of
#: docs/microsurface.md, 8 are typical and 17 the most seen in 2e5 draws over the sphere of directions)
_BECKMANN_STEPS = 60
#: the inversion stops when the CDF residual is below this fraction of the CDF's total
_BECKMANN_TOLERANCE = 1e-14
_BECKMANN_SLOPE_FLOOR = -6.0
_SQRT_PI = math.sqrt(math.pi)
#: a positive stand-in for 0 of each precision, far below any value that matters
_TINY = {"float64": 1e-300, "float32": 1e-30}


def height_c1(h):
    """C1(h) = clip((h + 1) / 2, 0, 1): the cumulative uniform height distribution on [-1, 1]."""
    return jnp.clip(0.5 * (h + 1.0), 0.0, 1.0)


def height_inv_c1(u):
    """invC1(U) = clip(2 U - 1, -1, 1), U in [0, 1]."""
    return jnp.clip(2.0 * u - 1.0, -1.0, 1.0)


def _power(x, y):
    """x^y for x in [0, 1]: ``x ** y`` in float64 (the C reference walk's pow); exp(y log x) in float32, which
    XLA's CPU backend vectorises where its float32 pow is a scalar libm call (5 times the cost), at a relative
    error of |y log x| float32 epsilons (1e-6 at |y log x| = 17.3, the most a float32 uniform gives a falling
    ray)."""
    if x.dtype == jnp.float32:
        return jnp.exp(y * jnp.log(x))
    return x**y


def smith_lambda(x, y, z, alpha_x, alpha_y, distribution: str):
    """Smith's Lambda(w) for w = (x, y, z) on the whole sphere: Lambda of |z| upwards
    (:func:`fitlab.physics.microfacet.smith_lambda`), -1 - that downwards.

    Horizontal w (z = 0): +inf (the +-inf limits differ; callers treat z = 0 apart)."""
    lam = microfacet.smith_lambda(x, y, jnp.abs(z), alpha_x, alpha_y, distribution)
    return jnp.where(z >= 0.0, lam, -1.0 - lam)


def masking_g1(x, y, z, h, alpha_x, alpha_y, distribution: str):
    """G1(w, h) = C1(h)^Lambda(w) for z > 0 (1 where Lambda = 0), 0 for z <= 0."""
    lam = smith_lambda(x, y, z, alpha_x, alpha_y, distribution)
    c1 = height_c1(h)
    up = jnp.where(lam > 0.0, _power(c1, jnp.where(lam > 0.0, lam, 1.0)), 1.0)
    return jnp.where(z > 0.0, up, 0.0)


def sample_height(x, y, z, h, u, alpha_x, alpha_y, distribution: str):
    """The height of the next intersection of the ray from height h along w = (x, y, z), or ESCAPED.

    u in (0, 1).  See docs/microsurface.md ("Free path")."""
    lam = smith_lambda(x, y, z, alpha_x, alpha_y, distribution)
    c1 = height_c1(h)
    g1 = masking_g1(x, y, z, h, alpha_x, alpha_y, distribution)
    lam_safe = jnp.where(lam != 0.0, lam, 1.0)
    # (1 - u)^(1/Lambda): for a rising ray it grows C1 (the hit lies above), for a falling one it shrinks it
    h_next = height_inv_c1(c1 / _power(1.0 - u, 1.0 / lam_safe))
    h_next = jnp.where(z == 0.0, h, h_next)
    escapes = (z > 0.0) & (u > 1.0 - g1)
    return jnp.where(escapes, ESCAPED, h_next)


def sample_c1(x, y, z, c1, u, alpha_x, alpha_y, distribution: str):
    """:func:`sample_height` of heights given by their C1 (in [0, 1]): the C1 of the next intersection of the ray
    from C1 = ``c1`` along w = (x, y, z), or ESCAPED.  The float32 walk carries C1, whose float32 resolves the
    bottom of the microsurface (C1 -> 0) to float32's relative precision, where float32 heights h = 2 C1 - 1 stop
    at 2^-24 from h = -1 (and a path there is stuck: its G1 is 0).  NaN only from C1 = 0 (an underflow)."""
    lam = smith_lambda(x, y, z, alpha_x, alpha_y, distribution)
    up = jnp.where(lam > 0.0, _power(c1, jnp.where(lam > 0.0, lam, 1.0)), 1.0)
    g1 = jnp.where(z > 0.0, up, 0.0)
    lam_safe = jnp.where(lam != 0.0, lam, 1.0)
    c1_next = jnp.clip(c1 / _power(1.0 - u, 1.0 / lam_safe), 0.0, 1.0)
    c1_next = jnp.where(z == 0.0, c1, c1_next)
    escapes = (z > 0.0) & (u > 1.0 - g1)
    return jnp.where(escapes, ESCAPED, c1_next)


def _normalize(x, y, z):
    n = jnp.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


def _vndf_ggx(wx, wy, wz, u1, u2, alpha_x, alpha_y):
    vx, vy, vz = _normalize(alpha_x * wx, alpha_y * wy, wz)
    lensq = vx * vx + vy * vy
    inv = jnp.where(lensq > 0.0, 1.0 / jnp.sqrt(jnp.where(lensq > 0.0, lensq, 1.0)), 0.0)
    t1x, t1y = jnp.where(lensq > 0.0, -vy * inv, 1.0), jnp.where(lensq > 0.0, vx * inv, 0.0)
    # T2 = V x T1 (T1 has no z component)
    t2x, t2y, t2z = -vz * t1y, vz * t1x, vx * t1y - vy * t1x
    r = jnp.sqrt(u1)
    sin_ang, cos_ang = sincos_2pi(u2)
    p1, p2 = r * cos_ang, r * sin_ang
    s = 0.5 * (1.0 + vz)
    p2 = (1.0 - s) * jnp.sqrt(jnp.maximum(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = jnp.sqrt(jnp.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    nx = p1 * t1x + p2 * t2x + p3 * vx
    ny = p1 * t1y + p2 * t2y + p3 * vy
    nz = p2 * t2z + p3 * vz
    return _normalize(alpha_x * nx, alpha_y * ny, jnp.maximum(_TINY[nz.dtype.name], nz))


def _beckmann_slope_x(cot_theta, sin_theta, cos_theta, u):
    """x < s_i = cot(theta) with the visible-slope CDF of docs/microsurface.md equal to u."""
    s_i = jnp.clip(cot_theta, _BECKMANN_SLOPE_FLOOR, 8.0)

    def g(x):
        return 0.5 * cos_theta * erfc(-x) + sin_theta * jnp.exp(-x * x) / (2.0 * _SQRT_PI)

    g_max = g(s_i)
    target = u * g_max
    lo = jnp.minimum(s_i - 1.0, -8.0) + 0.0 * u
    hi = s_i + 0.0 * u
    # start: the root without the sin(theta) term, erfc(-x) = 2 target / cos(theta), inside the bracket
    guess = erfinv(jnp.clip(1.0 - 2.0 * target / jnp.maximum(cos_theta, 1e-3), -1.0 + 1e-15, 1.0 - 1e-15))
    x = jnp.clip(guess, lo + 1e-9 * (hi - lo), hi - 1e-9 * (hi - lo))

    def step(state):
        x, lo, hi, done, it = state
        f = g(x) - target
        lo = jnp.where(f < 0.0, x, lo)
        hi = jnp.where(f < 0.0, hi, x)
        slope = jnp.exp(-x * x) * (cos_theta - x * sin_theta) / _SQRT_PI
        newton = jnp.where(slope > 0.0, x - f / jnp.where(slope > 0.0, slope, 1.0), 0.5 * (lo + hi))
        # Newton where it stays inside the bracket, bisection elsewhere: monotone convergence
        x_new = jnp.where((newton > lo) & (newton < hi), newton, 0.5 * (lo + hi))
        # converged: the CDF is inverted to 1e-14 in u (or the bracket is at rounding); a lane that is done
        # keeps its x, so that it does not depend on how long its neighbours take
        converged = (jnp.abs(f) <= _BECKMANN_TOLERANCE * g_max) | (hi - lo <= 1e-13)
        return jnp.where(done | converged, x, x_new), lo, hi, done | converged, it + 1

    state = (x, lo, hi, jnp.zeros(jnp.shape(x), bool), 0)
    state = jax.lax.while_loop(lambda s: (s[4] < _BECKMANN_STEPS) & ~jnp.all(s[3]), step, state)
    return state[0]


def _vndf_beckmann(wx, wy, wz, u1, u2, alpha_x, alpha_y):
    vx, vy, vz = _normalize(alpha_x * wx, alpha_y * wy, wz)
    sin_theta = jnp.sqrt(vx * vx + vy * vy)
    polar = sin_theta < 1e-12
    safe = jnp.where(polar, 1.0, sin_theta)
    cos_phi, sin_phi = jnp.where(polar, 1.0, vx / safe), jnp.where(polar, 0.0, vy / safe)
    cot = jnp.where(polar, 0.0, vz / safe)
    # straight up or down the slopes are drawn below; cos = 0 gives those lanes an inversion that converges
    x = _beckmann_slope_x(cot, jnp.where(polar, 1.0, sin_theta), jnp.where(polar, 0.0, vz), u1)
    y = erfinv(2.0 * u2 - 1.0)
    # straight up (or down): the visible slopes are the slopes themselves, a radial normal sample
    rad = jnp.sqrt(-jnp.log(u1))
    x = jnp.where(polar, rad * jnp.cos(2.0 * jnp.pi * u2), x)
    y = jnp.where(polar, rad * jnp.sin(2.0 * jnp.pi * u2), y)
    xr = cos_phi * x - sin_phi * y
    yr = sin_phi * x + cos_phi * y
    return _normalize(-alpha_x * xr, -alpha_y * yr, jnp.ones_like(xr))


def sample_vndf(wx, wy, wz, u1, u2, alpha_x, alpha_y, distribution: str):
    """A microfacet normal m from the visible normals D_wi of wi = (wx, wy, wz) (docs/microsurface.md).

    u1, u2 in (0, 1); wi on either side of the horizon (not horizontal and below: the projected
    area vanishes only for wi straight down).  Returns (m_x, m_y, m_z), m_z > 0, wi.m >= 0."""
    if distribution == "ggx":
        return _vndf_ggx(wx, wy, wz, u1, u2, alpha_x, alpha_y)
    dtype = wx.dtype
    # the visible-slope inversion's tolerances are float64's: a float32 walk inverts in float64
    up = (jnp.asarray(a, jnp.float64) for a in (wx, wy, wz, u1, u2, alpha_x, alpha_y))
    return tuple(m.astype(dtype) for m in _vndf_beckmann(*up))


def reflect(wx, wy, wz, mx, my, mz):
    """-w + 2 (w.m) m: the mirror image of w (pointing away from the facet) about m."""
    d = 2.0 * (wx * mx + wy * my + wz * mz)
    return _normalize(d * mx - wx, d * my - wy, d * mz - wz)


def refract(wx, wy, wz, mx, my, mz, eta):
    """The direction refracted through the facet m from w (pointing away from the facet, w.m >= 0) into a
    medium of relative index eta = n_t / n_i: m (c / eta - c_t) - w / eta, c = w.m, c_t = sqrt(1 - (1 - c^2) /
    eta^2) (Snell; the paper's code).  It points away from the facet on the other side (its dot with m is
    -c_t).  Beyond the critical angle (eta < 1) c_t is taken as 0: the caller never refracts there (the
    Fresnel factor is 1)."""
    c = wx * mx + wy * my + wz * mz
    cos_t = jnp.sqrt(jnp.maximum(0.0, 1.0 - (1.0 - c * c) / (eta * eta)))
    a = c / eta - cos_t
    return _normalize(a * mx - wx / eta, a * my - wy / eta, a * mz - wz / eta)
