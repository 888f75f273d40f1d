r"""Fresnel reflectance of an interface between air (index 1) and a material of complex index eta = n + i k.

Unpolarised light at cos(theta) = mu in [0, 1]: :func:`fitlab.physics.fresnel.fresnel_conductor`, the amplitudes of
Born and Wolf (section 1.5 and 13.2; RTR4 section 9.5) in real form, evaluated without cancellation.  Limits:
F(mu = 1) = ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2), F(mu = 0) = 1 for every eta but the matched eta = 1, which the
materials here never are.  A real eta > 1 is a dielectric seen from air (no total internal reflection).

The arithmetic is float64, or float32 when mu is float32 (a shader's precision).  tests/test_fresnel_exact.py
compares it with the complex amplitudes r_s = (mu - w) / (mu + w), r_p = (eta^2 mu - w) / (eta^2 mu + w), w =
sqrt(eta^2 - 1 + mu^2), an independent evaluation.
"""

from __future__ import annotations

import numpy as np

from fitlab.numerics import real_array, working_dtype
from fitlab.physics import fresnel

__all__ = ["fresnel_reflectance", "normal_reflectance", "gulbrandsen_index", "gulbrandsen_parameters"]


def fresnel_reflectance(mu, eta):
    """F(mu; eta) of the module docstring; mu in [0, 1] and eta (complex, Re > 0, Im >= 0, not 1) broadcast."""
    dtype = working_dtype(mu)
    mu = real_array(mu, "mu", 0.0, 1.0, dtype=dtype, domain="[0, 1] (cos theta)")
    eta = np.asarray(eta, dtype=np.complex64 if dtype == np.float32 else np.complex128)
    if np.any(eta.real <= 0) or np.any(eta.imag < 0) or np.any(eta == 1):
        raise ValueError("eta must have a positive real part, a non-negative imaginary part and differ from 1")
    return np.asarray(fresnel.fresnel_conductor(mu, eta.real, eta.imag), dtype=dtype)


def normal_reflectance(eta):
    """F at normal incidence, ((n - 1)^2 + k^2) / ((n + 1)^2 + k^2), of eta = n + i k."""
    eta = np.asarray(eta, dtype=complex)
    return fresnel.normal_reflectance(eta.real, eta.imag)


def gulbrandsen_index(r, g):
    """Gulbrandsen's (2014) map from reflectivity r in [0, 1) and edge tint g in [0, 1] to (n, k)
    (:func:`fitlab.physics.fresnel.gulbrandsen_index`); g = 0 gives the dielectric (k = 0) of reflectance r, g = 1
    the conductor of the least n."""
    return fresnel.gulbrandsen_index(np.asarray(r, dtype=float), np.asarray(g, dtype=float))


def gulbrandsen_parameters(n, k):
    """The inverse of :func:`gulbrandsen_index`: r = F(mu = 1) and g = (n_max - n) / (n_max - n_min) of
    eta = n + i k (g outside [0, 1] where n lies outside [n_min(r), n_max(r)])."""
    return fresnel.gulbrandsen_parameters(np.asarray(n, dtype=float), np.asarray(k, dtype=float))
