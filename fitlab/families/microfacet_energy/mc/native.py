r"""A plain C reference of the microsurface walk (GGX, conductor with F = 1), for ``fitlab bench mc``.

The same physics (Lambda printed from :mod:`fitlab.physics.microfacet`) and the same random numbers as :mod:`.walk`,
path by path: path ``id`` starts at the top (h = 1) along -w_i; at its event n the uniforms are the words of
Threefry-2x32 (20 rounds) of the job key and the
counter (id, 3 n + j), j = 0, 1 (words 0, 1, 2 used), (word + 1/2) 2^-32; the next height by Smith's
height-uniform free path (:func:`.microsurface.sample_height`), an escape when it says so, else a visible
normal of GGX (:func:`.microsurface.sample_vndf`, Heitz's stretched sampling) and the mirror reflection about
it, until ``max_bounces`` events.  It keeps the escapes by order (orders 1 to 4 and above, and the capped paths)
and the count of scattering events: no angular tallies.  One thread, double precision, compiled with the strict
flags of :mod:`fitlab.codegen.native`.  On the same key its escapes by order equal the JAX walk's exactly (a
test checks it), so the two time the same work.
"""

from __future__ import annotations

import ctypes
import time

import numpy as np

from fitlab._montecarlo import THREEFRY_C

__all__ = ["SOURCE", "ORDERS", "native_walk"]

#: the orders the C walk counts one by one (escapes above go to one more count)
ORDERS = 4


def _smith_lambda_c() -> str:
    """The C of GGX's Lambda of an upward w = (x, y, mu) (:func:`fitlab.physics.microfacet.smith_lambda`, printed by
    :class:`fitlab.codegen.printers.CPrinter`)."""
    import sympy as sp

    from fitlab.codegen.printers import CPrinter
    from fitlab.physics.microfacet import smith_lambda

    x, y, mu, ax, ay = sp.symbols("x y mu ax ay", real=True)
    return CPrinter("double", lambda name: name).doprint(smith_lambda(x, y, mu, ax, ay, "ggx"))


SOURCE = (
    THREEFRY_C
    + r"""
#include <math.h>

static const double TWO_PI = 6.283185307179586476925;
static double clip(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Smith's Lambda of GGX on the whole sphere: Lambda(|z|) upwards, -1 - Lambda(|z|) downwards; Lambda printed from
   fitlab.physics.microfacet.smith_lambda (0 along the normal, where its azimuth's roughness is 0 / 0) */
static double smith_lambda(double x, double y, double z, double ax, double ay)
{
    const double mu = fabs(z);
    const double lam = x * x + y * y > 0.0 ? SMITH_LAMBDA : 0.0;
    return z >= 0.0 ? lam : -1.0 - lam;
}

/* the next height along w from h, or INFINITY where the ray escapes */
static double sample_height(double x, double y, double z, double h, double u, double ax, double ay)
{
    const double lam = smith_lambda(x, y, z, ax, ay);
    const double c1 = clip(0.5 * (h + 1.0), 0.0, 1.0);
    const double g1 = z > 0.0 ? (lam > 0.0 ? pow(c1, lam) : 1.0) : 0.0;
    if (z > 0.0 && u > 1.0 - g1)
        return INFINITY;
    if (z == 0.0)
        return h;
    const double lam_safe = lam != 0.0 ? lam : 1.0;
    return clip(2.0 * (c1 / pow(1.0 - u, 1.0 / lam_safe)) - 1.0, -1.0, 1.0);
}

static void normalize(double *x, double *y, double *z)
{
    const double n = sqrt(*x * *x + *y * *y + *z * *z);
    *x /= n;
    *y /= n;
    *z /= n;
}

/* a visible normal of GGX seen from w (Heitz 2018's stretched sampling, as microsurface._vndf_ggx) */
static void vndf(double wx, double wy, double wz, double u1, double u2, double ax, double ay, double *m)
{
    double vx = ax * wx, vy = ay * wy, vz = wz;
    normalize(&vx, &vy, &vz);
    const double lensq = vx * vx + vy * vy;
    const double inv = lensq > 0.0 ? 1.0 / sqrt(lensq) : 0.0;
    const double t1x = lensq > 0.0 ? -vy * inv : 1.0, t1y = lensq > 0.0 ? vx * inv : 0.0;
    const double t2x = -vz * t1y, t2y = vz * t1x, t2z = vx * t1y - vy * t1x;
    const double r = sqrt(u1), ang = TWO_PI * u2;
    const double p1 = r * cos(ang);
    double p2 = r * sin(ang);
    const double s = 0.5 * (1.0 + vz);
    p2 = (1.0 - s) * sqrt(fmax(0.0, 1.0 - p1 * p1)) + s * p2;
    const double p3 = sqrt(fmax(0.0, 1.0 - p1 * p1 - p2 * p2));
    m[0] = ax * (p1 * t1x + p2 * t2x + p3 * vx);
    m[1] = ay * (p1 * t1y + p2 * t2y + p3 * vy);
    m[2] = fmax(1e-300, p2 * t2z + p3 * vz);
    normalize(&m[0], &m[1], &m[2]);
}

/* paths lo .. hi-1; out: escapes of orders 1 .. ORDERS and above (ORDERS + 1 counts), capped, bounces */
void microsurface_walk(uint32_t k0, uint32_t k1, double ax, double ay, double mu_i, uint32_t lo, uint32_t hi,
                       int64_t cap, double *out)
{
    int64_t exits[ORDERS + 1] = {0}, capped = 0, bounces = 0;
    const double s_i = sqrt(fmax(0.0, 1.0 - mu_i * mu_i));
    for (uint32_t id = lo; id < hi; ++id) {
        double h = 1.0, wx = -s_i, wy = 0.0, wz = -mu_i;
        for (int64_t order = 0;; ++order) {
            uint32_t a, b, c, d;
            threefry(k0, k1, id, (uint32_t)order * 3u, &a, &b);
            threefry(k0, k1, id, (uint32_t)order * 3u + 1u, &c, &d);
            const double u0 = ((double)a + 0.5) * TWO32, u1 = ((double)b + 0.5) * TWO32;
            const double u2 = ((double)c + 0.5) * TWO32;
            const double h_next = sample_height(wx, wy, wz, h, u0, ax, ay);
            if (isinf(h_next)) {
                ++exits[order < ORDERS + 1 ? order - 1 : ORDERS];
                break;
            }
            if (order >= cap) {
                ++capped;
                break;
            }
            double m[3];
            const double vx = -wx, vy = -wy, vz = -wz;
            vndf(vx, vy, vz, u1, u2, ax, ay, m);
            const double dd = 2.0 * (vx * m[0] + vy * m[1] + vz * m[2]);
            wx = dd * m[0] - vx;
            wy = dd * m[1] - vy;
            wz = dd * m[2] - vz;
            normalize(&wx, &wy, &wz);
            h = h_next;
            ++bounces;
        }
    }
    for (int k = 0; k <= ORDERS; ++k)
        out[k] = (double)exits[k];
    out[ORDERS + 1] = (double)capped;
    out[ORDERS + 2] = (double)bounces;
}
""".replace("ORDERS", str(ORDERS)).replace("SMITH_LAMBDA", _smith_lambda_c())
)


#: the C function's arguments
_ARGTYPES = (
    ctypes.c_uint32,
    ctypes.c_uint32,
    ctypes.c_double,
    ctypes.c_double,
    ctypes.c_double,
    ctypes.c_uint32,
    ctypes.c_uint32,
    ctypes.c_int64,
    ctypes.POINTER(ctypes.c_double),
)


def native_walk(key: tuple[int, int], alpha: float, mu_i: float, n_paths: int, max_bounces: int = 1000) -> dict:
    """Paths 0 .. n_paths - 1 of the job key ``key`` (:func:`.walk.job_key`'s two words) on an isotropic GGX
    conductor with F = 1: {"exits": escapes by order 1 .. ORDERS and above, "capped", "bounces", "seconds"}."""
    if not alpha > 0.0 or not 0.0 < mu_i <= 1.0:
        raise ValueError("alpha must be positive and mu_i in (0, 1]")
    if not 1 <= n_paths < 2**32 or max_bounces < 1:
        raise ValueError("n_paths must lie in [1, 2^32) and max_bounces be at least 1")
    from fitlab.codegen.native import c_function

    walk = c_function(SOURCE, "microsurface_walk", _ARGTYPES)
    out = np.zeros(ORDERS + 3)
    t0 = time.perf_counter()
    walk(
        int(key[0]),
        int(key[1]),
        float(alpha),
        float(alpha),
        float(mu_i),
        0,
        int(n_paths),
        int(max_bounces),
        out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
    )
    seconds = time.perf_counter() - t0
    return {
        "exits": out[: ORDERS + 1].astype(np.int64),
        "capped": int(out[ORDERS + 1]),
        "bounces": int(out[ORDERS + 2]),
        "seconds": seconds,
    }
