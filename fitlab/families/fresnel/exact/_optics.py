r"""Fresnel reflectance of an interface between air (index 1) and a material of complex index eta = n + i k.

Unpolarised light at cos(theta) = mu in [0, 1], from the complex amplitude coefficients (Born and Wolf,
section 1.5 and 13.2; RTR4 section 9.5): with w = eta cos(theta_t) = sqrt(eta^2 - sin^2 theta), the
principal root (Im w >= 0 for k >= 0, so that the transmitted wave decays),

    r_s = (mu - w) / (mu + w),    r_p = (eta^2 mu - w) / (eta^2 mu + w),    F = (|r_s|^2 + |r_p|^2) / 2.

Limits: F(mu = 1) = ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2) (r_s = -r_p there; RTR4 eq. 9.17 with the
modulus for a complex index), F(mu = 0) = 1 (r_s = r_p = -1) for every eta but the matched eta = 1, which
the materials here never are.  A real eta > 1 is a dielectric seen from air (no total internal reflection).

The arithmetic is complex128, or complex64 when mu is float32 (a shader's precision).  The microfacet family
evaluates the same reflectance in Born and Wolf's real form; tests/test_fresnel_exact.py compares the two.
"""

from __future__ import annotations

import numpy as np

from fitlab.numerics import real_array, working_dtype

__all__ = ["fresnel_reflectance", "normal_reflectance", "gulbrandsen_index", "gulbrandsen_parameters"]


def fresnel_reflectance(mu, eta):
    """F(mu; eta) of the module docstring; mu in [0, 1] and eta (complex, Re > 0, Im >= 0, not 1) broadcast."""
    dtype = working_dtype(mu)
    mu = real_array(mu, "mu", 0.0, 1.0, dtype=dtype, domain="[0, 1] (cos theta)")
    eta = np.asarray(eta, dtype=np.complex64 if dtype == np.float32 else np.complex128)
    if np.any(eta.real <= 0) or np.any(eta.imag < 0) or np.any(eta == 1):
        raise ValueError("eta must have a positive real part, a non-negative imaginary part and differ from 1")
    s2 = (1 - mu) * (1 + mu)
    e2 = eta * eta
    w = np.sqrt(e2 - s2)
    r_s = (mu - w) / (mu + w)
    r_p = (e2 * mu - w) / (e2 * mu + w)
    return (0.5 * (np.abs(r_s) ** 2 + np.abs(r_p) ** 2)).astype(dtype)


def normal_reflectance(eta):
    """F at normal incidence, ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2), of eta = n + i k."""
    eta = np.asarray(eta, dtype=complex)
    n, k = eta.real, eta.imag
    return ((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k)


def gulbrandsen_index(r, g):
    """Gulbrandsen's (2014) map from reflectivity r in [0, 1) and edge tint g in [0, 1] to (n, k):
    n = g n_min + (1 - g) n_max with n_min = (1 - r) / (1 + r), n_max = (1 + sqrt r) / (1 - sqrt r), and
    k^2 = (r (n + 1)^2 - (n - 1)^2) / (1 - r), so that F(mu = 1) = r.  g = 0 gives the dielectric
    (k = 0) of reflectance r, g = 1 the conductor of the least n."""
    r, g = np.asarray(r, dtype=float), np.asarray(g, dtype=float)
    sr = np.sqrt(r)
    n = g * (1 - r) / (1 + r) + (1 - g) * (1 + sr) / (1 - sr)
    k2 = (r * (n + 1) ** 2 - (n - 1) ** 2) / (1 - r)
    return n, np.sqrt(np.maximum(k2, 0.0))


def gulbrandsen_parameters(n, k):
    """The inverse of :func:`gulbrandsen_index`: r = F(mu = 1) and g = (n_max - n) / (n_max - n_min) of
    eta = n + i k (g outside [0, 1] where n lies outside [n_min(r), n_max(r)])."""
    n, k = np.asarray(n, dtype=float), np.asarray(k, dtype=float)
    r = normal_reflectance(n + 1j * k)
    sr = np.sqrt(r)
    n_min, n_max = (1 - r) / (1 + r), (1 + sr) / (1 - sr)
    return r, (n_max - n) / (n_max - n_min)
