r"""Deterministic references for the walk's tallies (numpy; no JAX, no sampling).

Single scattering.  The walk's order 1 is the microfacet BRDF with height-correlated Smith
masking-shadowing (Heitz et al. 2016, section 5: for uncorrelated heights the probability that
both w_i and w_o see a facet at height h, averaged over h, is int C1(h)^(Lambda_i + Lambda_o) dC1 =
1 / (1 + Lambda_i + Lambda_o)):

    f_1(w_i, w_o) = F(w_i . h) D(h) G2(w_i, w_o) / (4 mu_i mu_o),  G2 = 1 / (1 + Lambda(w_i) + Lambda(w_o)),

h = (w_i + w_o) / |w_i + w_o|, with D and Lambda of the module :mod:`.microsurface` (written here
again in numpy from the formulas, not imported).  For isotropic GGX the tests also compare with
:func:`fitlab.families.microfacet_energy.exact.ggx_brdf` (smith="correlated"), an independent code.

Bin averages: the walk's lobe tally estimates the average of f mu_o over a bin
[mu_0, mu_1] x (+-[phi_0, phi_1]); by the symmetry phi -> -phi it is
(1 / ((mu_1 - mu_0)(phi_1 - phi_0))) int int f mu_o dmu_o dphi, computed here by tensor
Gauss-Legendre with ``panels`` x ``panels`` sub-panels of ``nodes`` x ``nodes`` nodes per bin
(the integrand is smooth inside a bin; its peak is resolved when the sub-panels are narrower
than alpha).

Albedo of order 1: for isotropic GGX, the exact engine's E(mu_i, alpha) of "ggx_correlated"
(:func:`fitlab.families.microfacet_energy.exact.directional_albedo`, with the Fresnel factor inside
its integral); otherwise the same bin rule over the whole hemisphere.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc

from fitlab.families.microfacet_energy.exact import (
    directional_albedo,
    fresnel_conductor,
    fresnel_schlick,
    ggx_brdf,
)

__all__ = ["ndf", "lambda_", "single_scattering_brdf", "bin_average_single", "albedo_single", "fresnel_numpy"]


def fresnel_numpy(material):
    """F(cos) of a conductor material (``scene.Material``) in numpy, from the exact engine."""
    if material.fresnel == "schlick":
        return lambda c: fresnel_schlick(np.clip(c, 0.0, 1.0), material.f0)
    if material.fresnel == "conductor":
        return lambda c: fresnel_conductor(np.clip(c, 0.0, 1.0), material.eta, material.k)
    return lambda c: np.ones_like(c)


def ndf(mx, my, mz, alpha_x, alpha_y, distribution: str):
    """D(m) for m_z > 0 (1/sr, normalised by int D m_z dw = 1)."""
    mz2 = mz * mz
    e = ((mx / alpha_x) ** 2 + (my / alpha_y) ** 2) / mz2
    if distribution == "ggx":
        return 1.0 / (math.pi * alpha_x * alpha_y * mz2 * mz2 * (1.0 + e) ** 2)
    return np.exp(-e) / (math.pi * alpha_x * alpha_y * mz2 * mz2)


def lambda_(x, y, z, alpha_x, alpha_y, distribution: str):
    """Smith Lambda of an upward direction (z > 0)."""
    t2 = ((alpha_x * x) ** 2 + (alpha_y * y) ** 2) / (z * z)
    if distribution == "ggx":
        return (np.sqrt(1.0 + t2) - 1.0) / 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 1.0 / np.sqrt(t2)
        lam = (np.exp(-a * a) / (a * math.sqrt(math.pi)) - erfc(a)) / 2.0
    return np.where(t2 > 0, lam, 0.0)


def single_scattering_brdf(mu_o, phi_o, mu_i, alpha_x, alpha_y, distribution: str, fresnel=None):
    """f_1 (module docstring) for w_i = (s_i, 0, mu_i), w_o = (s_o cos phi_o, s_o sin phi_o, mu_o), mu's in (0, 1]."""
    s_i = math.sqrt(1.0 - mu_i * mu_i)
    s_o = np.sqrt(1.0 - mu_o * mu_o)
    ox, oy, oz = s_o * np.cos(phi_o), s_o * np.sin(phi_o), mu_o
    hx, hy, hz = ox + s_i, oy, oz + mu_i
    n = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / n, hy / n, hz / n
    g2 = 1.0 / (1.0 + lambda_(s_i, 0.0, mu_i, alpha_x, alpha_y, distribution)
                + lambda_(ox, oy, oz, alpha_x, alpha_y, distribution))
    f = ndf(hx, hy, hz, alpha_x, alpha_y, distribution) * g2 / (4.0 * mu_i * mu_o)
    if fresnel is not None:
        f = f * fresnel(s_i * hx + mu_i * hz)
    return f


def _rule(lo, hi, panels, nodes):
    x, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.linspace(lo, hi, panels + 1)
    a, b = edges[:-1, None], edges[1:, None]
    return ((a + b) / 2 + (b - a) / 2 * x).ravel(), ((b - a) / 2 * w).ravel()


def bin_average_single(mu_edges, phi_edges, mu_i, material, panels: int = 4, nodes: int = 12,
                       use_exact_ggx: bool = True):
    """Bin averages of f_1 mu_o (1/sr) over the tally's bins: array [mu bin, phi bin].

    ``use_exact_ggx``: for isotropic GGX evaluate f_1 with the exact engine's ggx_brdf (times F)."""
    fres = fresnel_numpy(material)
    out = np.zeros((len(mu_edges) - 1, len(phi_edges) - 1))
    for i in range(len(mu_edges) - 1):
        mu, wmu = _rule(mu_edges[i], mu_edges[i + 1], panels, nodes)
        mu = np.maximum(mu, 1e-300)
        for j in range(len(phi_edges) - 1):
            ph, wph = _rule(phi_edges[j], phi_edges[j + 1], panels, nodes)
            m, p = np.meshgrid(mu, ph, indexing="ij")
            if use_exact_ggx and material.distribution == "ggx" and material.isotropic:
                f = ggx_brdf(m, mu_i, p, material.alpha_x, smith="correlated")
                s_i, s_o = math.sqrt(1 - mu_i * mu_i), np.sqrt(1 - m * m)
                h = np.stack([s_o * np.cos(p) + s_i, s_o * np.sin(p), m + mu_i])
                f = f * fres(np.clip((s_i * h[0] + mu_i * h[2]) / np.linalg.norm(h, axis=0), 0, 1))
            else:
                f = single_scattering_brdf(m, p, mu_i, material.alpha_x, material.alpha_y, material.distribution,
                                           fres)
            integral = np.einsum("i,j,ij->", wmu, wph, f * m)
            out[i, j] = integral / ((mu_edges[i + 1] - mu_edges[i]) * (phi_edges[j + 1] - phi_edges[j]))
    return out


def albedo_single(mu_i, material):
    """The order-1 albedo int f_1 mu_o dw_o, and the name of the method that gave it."""
    if material.distribution == "ggx" and material.isotropic:
        fres = fresnel_numpy(material) if material.fresnel != "one" else None
        e = float(directional_albedo(mu_i, material.alpha_x, "ggx_correlated", fresnel=fres))
        return e, "exact_directional_albedo"
    mu_edges = np.linspace(0.0, 1.0, 17)
    phi_edges = np.linspace(0.0, math.pi, 17)
    avg = bin_average_single(mu_edges, phi_edges, mu_i, material, panels=2, nodes=16)
    omega = 2.0 * np.outer(np.diff(mu_edges), np.diff(phi_edges))
    return float(np.sum(avg * omega)), "bin_quadrature"
