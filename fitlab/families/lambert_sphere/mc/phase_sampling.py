r"""Sampling the scattering cosine u of one collision, and turning directions.

u is the cosine between the photon's flight direction before and after the
collision (u = -w_i . w_o for single scattering; mean -4/9, backward;
docs/model.md, "Conventions" and "Phase function").
All functions are pure ``jax.numpy`` maps of uniforms in (0, 1) to samples, so
that the random walk (``fitlab.families.lambert_sphere.mc.transport``) can vectorise them and tests can
feed them fixed uniforms.

Densities are per unit solid angle (1/sr).  A density in u alone is 2 pi times
the solid-angle density: int_{-1}^{1} 2 pi p(u) du = 1.

True phase function p(u) = 2 (sqrt(1-u^2) - u acos u) / (3 pi^2):

* ``sample_true_exact``  (eq. 5): u = sqrt((1-x1)(1-x2)) sin(2 pi x3) - sqrt(x1 x2),
  three uniforms, exact.
* ``sample_true_approx`` (eq. 6): u = 1 - 2 (1 - x^(0.0401885 x + 1.01938))^0.397225,
  one uniform; |u - F^-1(x)| < 5e-4 is the paper's claim (tests check it).

Details: docs/montecarlo.md, section ``fitlab.families.lambert_sphere.mc.phase_sampling``."""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from fitlab._montecarlo import sincos_2pi
from fitlab.core import float64
from fitlab.physics.lambert_sphere import phase_function, three_term_phase_function

__all__ = [
    "THREE_TERM_NORM",
    "U1",
    "p_true",
    "p_three_term",
    "sample_true_exact",
    "sample_true_approx",
    "sample_three_term",
    "MIX",
    "mixture_density",
    "sample_mixture",
    "MIXTURE_SECOND_MOMENTS",
    "C_LIMIT",
    "unbounded_reason",
    "turn",
]

# --- three-term constants (exact, from g(u) = 27/32 - 4/3 u + 15/32 u^2) ---
U1 = (64.0 - math.sqrt(451.0)) / 45.0  # the root of g in [-1, 1]
_EPS = 5.0 / 32.0  # g''/6


def _G(u: float) -> float:
    return 27.0 / 32.0 * u - 2.0 / 3.0 * u * u + 5.0 / 32.0 * u**3


_K = (4.0 / 3.0 - 15.0 / 16.0 * U1) / 2.0  # -g'(u1)/2
_M_POS = _G(U1) - _G(-1.0)
_M_NEG = _G(U1) - _G(1.0)
#: int |p3| dOmega = (M+ + M-)/2; M+ - M- = 2 (p3 integrates to 1).
THREE_TERM_NORM = (_M_POS + _M_NEG) / 2.0
_NEWTON_STEPS = 8


@float64
def p_true(u):
    """p(u) = 2 (sqrt(1-u^2) - u acos u)/(3 pi^2), 1/sr (:func:`fitlab.physics.lambert_sphere.phase_function`); u
    clipped to [-1, 1]."""
    return phase_function(jnp.clip(u, -1.0, 1.0))


@float64
def p_three_term(u):
    """p3(u) = (1 - (4/3) u + (5/16) P2(u)) / (4 pi), 1/sr; negative for u > 0.95029
    (:func:`fitlab.physics.lambert_sphere.three_term_phase_function`)."""
    return three_term_phase_function(jnp.asarray(u))


@float64
def sample_true_exact(x1, x2, x3):
    """Eq. 5: u = sqrt((1-x1)(1-x2)) sin(2 pi x3) - sqrt(x1 x2); exact for p (sin by :func:`sincos_2pi`)."""
    return jnp.sqrt((1.0 - x1) * (1.0 - x2)) * sincos_2pi(x3)[0] - jnp.sqrt(x1 * x2)


@float64
def sample_true_approx(x):
    """Eq. 6: approximate inverse CDF of p, one uniform."""
    return 1.0 - 2.0 * (1.0 - x ** (0.0401885 * x + 1.01938)) ** 0.397225


@float64
def sample_three_term(x):
    """u from |p3|/N by exact inversion, and the sign of p3(u).

    Returns (u, sign); the weight factor of the collision is sign * THREE_TERM_NORM.
    """
    m = _M_POS + _M_NEG
    t = x * m - _M_POS
    sigma = jnp.where(t < 0.0, 1.0, -1.0)  # +1: positive branch, u < u1
    d = jnp.abs(t)
    r_sq = jnp.sqrt(d / _K)
    # a start for Newton, so any cube root will do: in float32 exp(log/3), which XLA's CPU backend vectorises
    # (its float32 cbrt is a scalar libm call, 10 times the cost); exp(-inf) = 0 at d = 0
    r_cb = jnp.exp(jnp.log(d / _EPS) / 3.0) if d.dtype == jnp.float32 else jnp.cbrt(d / _EPS)
    r = jnp.where(sigma > 0, jnp.minimum(r_sq, r_cb), r_sq)
    for _ in range(_NEWTON_STEPS):
        f = r * r * (_K + sigma * _EPS * r) - d
        fp = r * (2.0 * _K + 3.0 * sigma * _EPS * r)
        r = jnp.where(fp > 0.0, r - f / jnp.where(fp > 0.0, fp, 1.0), r)
    u = jnp.clip(U1 - sigma * r, -1.0, 1.0)
    return u, sigma


#: The 'both' sampler: u from p, from |p3|/N, or uniform, with these probabilities.
MIX = (0.49, 0.49, 0.02)


@float64
def mixture_density(u):
    """q(u) = 0.49 p(u) + 0.49 |p3(u)|/N + 0.02/(4 pi) (1/sr): the density of the
    'both' sampler.  p/q <= 1/0.49 and |p3|/q <= N/0.49: one path carries both
    weights, bounded.  Per collision, int (p - p3)^2/q dOmega = 2.6e-4 (the
    variance of the correlated difference; 8.5e-4 without the uniform part,
    which covers the forward cone where p -> 0 but p3 -> -0.0208/(4 pi)), and
    int p^2/q - 1 = 1.5e-3, int p3^2/q - 1 = 2.3e-3 (the single weights)."""
    return MIX[0] * p_true(u) + MIX[1] * jnp.abs(p_three_term(u)) / THREE_TERM_NORM + MIX[2] / (4.0 * jnp.pi)


@float64
def sample_mixture(x1, x2, x3, x4, sel):
    """u from the 'both' sampler's mixture q (``mixture_density``): eq. 5 from
    (x1, x2, x3) when sel < MIX[0], |p3|/N from x4 when sel < MIX[0] + MIX[1],
    else uniform in u from sel itself (uniform on [MIX[0] + MIX[1], 1) there)."""
    u_p = sample_true_exact(x1, x2, x3)
    u_3, _ = sample_three_term(x4)
    lim = MIX[0] + MIX[1]
    u_uni = 2.0 * (sel - lim) / MIX[2] - 1.0
    return jnp.where(sel < MIX[0], u_p, jnp.where(sel < lim, u_3, jnp.clip(u_uni, -1.0, 1.0)))


def _mixture_second_moments() -> tuple:
    """(int p^2/q dOmega, int p3^2/q dOmega) for the mixture q, by Gauss-Legendre
    (200 nodes on each of [-1, u1], [u1, 0.99], [0.99, 1]; plain numpy, no JAX)."""
    x, w = (np.asarray(a) for a in np.polynomial.legendre.leggauss(200))

    def p(u):
        return phase_function(np.clip(u, -1.0, 1.0))

    p3 = three_term_phase_function
    out = [0.0, 0.0]
    for a, b in ((-1.0, U1), (U1, 0.99), (0.99, 1.0)):
        u = a + (b - a) * (x + 1.0) / 2.0
        q = MIX[0] * p(u) + MIX[1] * np.abs(p3(u)) / THREE_TERM_NORM + MIX[2] / (4.0 * math.pi)
        for k, f in enumerate((p, p3)):
            out[k] += 2.0 * math.pi * float(np.sum(f(u) ** 2 / q * w)) * (b - a) / 2.0
    return tuple(out)


#: Per collision, E_q[(p/q)^2] and E_q[(p3/q)^2] of the 'both' sampler (1.0015, 1.0023).
MIXTURE_SECOND_MOMENTS = _mixture_second_moments()

#: The largest single-scattering albedo c at which each walk's estimator has a
#: finite variance (docs/montecarlo.md, "Where the signed weights stop working").
#: three_term: |weight| = (c N)^n after n collisions, bounded by 1 iff c N <= 1,
#: and E|estimate| is infinite for c N > 1 whatever the sampler (int |c p3| = c N).
#: both: the second moment of a weight grows by c^2 E_q[(p3/q)^2] per collision.
C_LIMIT = {
    "true": 1.0,
    "three_term": 1.0 / THREE_TERM_NORM,
    "both": 1.0 / math.sqrt(max(MIXTURE_SECOND_MOMENTS)),
}


def unbounded_reason(phase: str, c: float) -> str | None:
    """Why the walk ``phase`` cannot estimate anything at this c (None: it can).

    One line, for scene errors and :func:`~fitlab.families.lambert_sphere.mc.transport.run_round`.
    """
    lim = C_LIMIT[phase]
    if not c > lim:  # NaN: not judged here
        return None
    if phase == "three_term":
        return (
            f"c = {c:g} > 1/N = {lim:.6f}: the three-term phase function is negative for u > {U1:.5f}, so its "
            f"signed weights grow as (c N)^n with N = int |p3| = {THREE_TERM_NORM:.7f} and the estimate has "
            f"infinite mean and variance (any sampler: the signed series diverges); use c <= {lim:.6f} or "
            f'phase = "true"'
        )
    return (
        f"c = {c:g} > {lim:.6f}: the correlated true/three-term walk (phase_difference) multiplies each "
        f"weight's second moment by c^2 x {max(MIXTURE_SECOND_MOMENTS):.5f} per collision, so its variance "
        f"is infinite; use c <= {lim:.6f}"
    )


@float64
def turn(dx, dy, dz, u, cos_psi, sin_psi):
    """Unit direction at angle acos(u) from (dx, dy, dz), azimuth psi about it (given by its cosine and sine).

    Standard rotation; near the poles (rho = sqrt(dx^2 + dy^2) < 1e-5) the local frame is the lab frame.
    rho is taken from dx and dy, which keep their relative precision near a pole where 1 - dz^2 loses it
    (in float32 the first direction off the pole has 1 - dz = 6e-8).  The result is renormalised (no drift
    over thousands of turns).
    """
    s = jnp.sqrt(jnp.maximum(0.0, 1.0 - u * u))
    cp, sp = cos_psi, sin_psi
    rho = jnp.sqrt(dx * dx + dy * dy)
    polar = rho < 1e-5
    rho_safe = jnp.where(polar, 1.0, rho)
    nx = s * (dx * dz * cp - dy * sp) / rho_safe + dx * u
    ny = s * (dy * dz * cp + dx * sp) / rho_safe + dy * u
    nz = -s * cp * rho + dz * u
    px, py, pz = s * cp, s * sp, jnp.sign(dz) * u
    nx, ny, nz = jnp.where(polar, px, nx), jnp.where(polar, py, ny), jnp.where(polar, pz, nz)
    norm = jnp.sqrt(nx * nx + ny * ny + nz * nz)
    return nx / norm, ny / norm, nz / norm
