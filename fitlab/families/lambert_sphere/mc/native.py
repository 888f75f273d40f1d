r"""A plain C reference of the half-space walk (``phase="true"``, ``sampler="exact"``), for ``fitlab bench mc``.

The same physics and the same random numbers as :mod:`.transport`, photon by photon: the words of photon ``id``
at collision ``n`` are Threefry-2x32 (20 rounds, as ``jax.random``'s) of the round key and the counter (id,
3 n + j), j < 3, uniforms (word + 1/2) 2^-32; u by eq. 5 from the first three, the azimuth, the free path and
Russian roulette from the last three; entry along -w_i, the flight after the first collision forced inside
(weight times 1 - exp(-L)), weight c per collision, roulette below ``rr_weight``, a cap of ``max_collisions``.
What it keeps is one sum, the escaping weight (the multiple-scattering albedo times the photons), besides the
counts: no tallies by bin or order.  One thread, double precision, compiled with the strict flags of
:mod:`fitlab.codegen.native`.  Its escaping weight equals the JAX walk's to rounding on the same key (a test
checks it), so the two time the same work.
"""

from __future__ import annotations

import ctypes
import time

import numpy as np

from fitlab._montecarlo import THREEFRY_C

__all__ = ["SOURCE", "native_walk"]

SOURCE = (
    THREEFRY_C
    + r"""
#include <math.h>

static const double TWO_PI = 6.283185307179586476925;

static void turn(double *dx, double *dy, double *dz, double u, double psi)
{
    const double s = sqrt(fmax(0.0, 1.0 - u * u)), cp = cos(psi), sp = sin(psi);
    const double rho = sqrt(*dx * *dx + *dy * *dy);
    double nx, ny, nz;
    if (rho < 1e-5) {
        nx = s * cp;
        ny = s * sp;
        nz = (*dz > 0.0 ? 1.0 : (*dz < 0.0 ? -1.0 : 0.0)) * u;
    } else {
        nx = s * (*dx * *dz * cp - *dy * sp) / rho + *dx * u;
        ny = s * (*dy * *dz * cp + *dx * sp) / rho + *dy * u;
        nz = -s * cp * rho + *dz * u;
    }
    const double norm = sqrt(nx * nx + ny * ny + nz * nz);
    *dx = nx / norm;
    *dy = ny / norm;
    *dz = nz / norm;
}

/* photons lo .. hi-1; out: escaping weight, collisions, escapes, capped, roulette kills */
void lambert_sphere_walk(uint32_t k0, uint32_t k1, double c, double mu_i, uint32_t lo, uint32_t hi, int64_t cap,
                         double rr_weight, double *out)
{
    double escaped_weight = 0.0;
    int64_t collisions = 0, escapes = 0, capped = 0, killed = 0;
    for (uint32_t id = lo; id < hi; ++id) {
        double z = 0.0, dx = 0.0, dy = 0.0, dz = -1.0, w = 1.0;
        for (int64_t n = 0;; ++n) {
            double x[6];
            for (uint32_t j = 0; j < 3; ++j) {
                uint32_t a, b;
                threefry(k0, k1, id, (uint32_t)n * 3u + j, &a, &b);
                x[j] = ((double)a + 0.5) * TWO32;
                x[3 + j] = ((double)b + 0.5) * TWO32;
            }
            if (n == 0) {
                dx = -sqrt(fmax(0.0, 1.0 - mu_i * mu_i));
                dy = 0.0;
                dz = -mu_i;
            } else {
                const double u = sqrt((1.0 - x[0]) * (1.0 - x[1])) * sin(TWO_PI * x[2]) - sqrt(x[0] * x[1]);
                turn(&dx, &dy, &dz, u, TWO_PI * x[3]);
                w *= c;
                ++collisions;
                if (fabs(w) < rr_weight) {
                    if (x[5] * rr_weight < fabs(w)) {
                        w *= rr_weight / fabs(w);
                    } else {
                        ++killed;
                        break;
                    }
                }
            }
            const int up = dz > 0.0;
            const double dist = up ? -z / dz : INFINITY;
            double flight;
            if (n == 1) {
                const double e_l = expm1(-dist);
                flight = -log1p(x[4] * e_l);
                w *= -e_l;
            } else {
                flight = -log(x[4]);
            }
            if (n >= 2 && up && flight > dist) {
                escaped_weight += w;
                ++escapes;
                break;
            }
            z += flight * dz;
            if (n + 1 > cap) {
                ++capped;
                break;
            }
        }
    }
    out[0] = escaped_weight;
    out[1] = (double)collisions;
    out[2] = (double)escapes;
    out[3] = (double)capped;
    out[4] = (double)killed;
}
"""
)


#: the C function's arguments
_ARGTYPES = (
    ctypes.c_uint32,
    ctypes.c_uint32,
    ctypes.c_double,
    ctypes.c_double,
    ctypes.c_uint32,
    ctypes.c_uint32,
    ctypes.c_int64,
    ctypes.c_double,
    ctypes.POINTER(ctypes.c_double),
)


def native_walk(
    key: tuple[int, int], c: float, mu_i: float, n_photons: int, max_collisions: int = 100_000, rr_weight: float = 0.125
) -> dict:
    """Photons 0 .. n_photons - 1 of the round key ``key`` (:func:`.transport.round_key`'s two words) through the
    C walk: {"escape": escaping weight per photon, "collisions", "escapes", "capped", "killed", "seconds"}."""
    if not 0.0 <= c <= 1.0 or not 0.0 <= mu_i <= 1.0:
        raise ValueError("c and mu_i must lie in [0, 1]")
    if not 1 <= n_photons < 2**32:
        raise ValueError("n_photons must lie in [1, 2^32)")
    from fitlab.codegen.native import c_function

    walk = c_function(SOURCE, "lambert_sphere_walk", _ARGTYPES)
    out = np.zeros(5)
    t0 = time.perf_counter()
    walk(
        int(key[0]),
        int(key[1]),
        float(c),
        float(mu_i),
        0,
        int(n_photons),
        int(max_collisions),
        float(rr_weight),
        out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
    )
    seconds = time.perf_counter() - t0
    return {
        "escape": out[0] / n_photons,
        "collisions": int(out[1]),
        "escapes": int(out[2]),
        "capped": int(out[3]),
        "killed": int(out[4]),
        "seconds": seconds,
    }
