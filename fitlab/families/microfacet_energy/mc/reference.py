r"""Deterministic references for the walk's tallies (numpy; no JAX, no sampling).

Single scattering.  The walk's order 1 is the microfacet BRDF with height-correlated Smith
masking-shadowing (Heitz et al. 2016, section 5: for uncorrelated heights the probability that
both w_i and w_o see a facet at height h, averaged over h, is int C1(h)^(Lambda_i + Lambda_o) dC1 =
1 / (1 + Lambda_i + Lambda_o)):

    f_1(w_i, w_o) = F(w_i . h) D(h) G2(w_i, w_o) / (4 mu_i mu_o),  G2 = 1 / (1 + Lambda(w_i) + Lambda(w_o)),

h = (w_i + w_o) / |w_i + w_o|, with D and Lambda of :mod:`fitlab.physics.microfacet` (in numpy; the walk's are the
same functions in JAX).  For isotropic GGX the tests also compare with
:func:`fitlab.families.microfacet_energy.exact.ggx_brdf` (smith="correlated"), an independent code.

Bin averages: the walk's lobe tally estimates the average of f mu_o over a bin
[mu_0, mu_1] x (+-[phi_0, phi_1]); by the symmetry phi -> -phi it is
(1 / ((mu_1 - mu_0)(phi_1 - phi_0))) int int f mu_o dmu_o dphi, computed here by tensor
Gauss-Legendre with ``panels`` x ``panels`` sub-panels of ``nodes`` x ``nodes`` nodes per bin, with
further panel edges graded geometrically towards the lobe's peak (from alpha^2 / 8 away from it, doubling),
so that the peak is resolved down to the scenes' smallest alpha, 1e-3 (the bin sums agree with the integrals
over the normals to 1e-6 there; the fixed panels alone lost 3e-3 of the total at alpha = 0.01).  Totals over
the hemisphere: one such bin of 32 x 32 panels of 16 x 16 nodes.

Details: docs/microsurface.md, section ``fitlab.families.microfacet_energy.mc.reference``."""

from __future__ import annotations

import math

import numpy as np

from fitlab.families.microfacet_energy.exact import (
    FresnelFactor,
    conductor_factor,
    dielectric_factor,
    directional_albedo,
    fresnel_dielectric,
    fresnel_dielectric_transmittance,
    fresnel_schlick,
    ggx_brdf,
)
from fitlab.physics.microfacet import ndf, smith_g2_correlated, smith_lambda
from fitlab.physics.microfacet import smith_g2_transmission as transmission_g2

__all__ = [
    "ndf",
    "single_scattering_brdf",
    "bin_average_single",
    "albedo_single",
    "fresnel_numpy",
    "transmission_g2",
    "btdf",
    "single_transmission_btdf",
    "bin_average_transmission",
    "transmission_single",
    "order_one_by_normals",
    "normal_rule",
    "diffuse_single_brdf",
    "bin_average_diffuse",
    "references",
]


def fresnel_numpy(material):
    """F(cos) of a material (``scene.Material``: a conductor's Fresnel form, or a dielectric's F of its
    eta seen from above) in numpy, from the exact engine; cosines clipped to [0, 1].  A dielectric's and a
    conductor's come as the engine's ``FresnelFactor`` with their kinks (the critical angle when eta < 1)."""
    if material.kind == "dielectric":
        return _clipped_factor(dielectric_factor(material.eta))
    if material.fresnel == "schlick":
        return lambda c: fresnel_schlick(np.clip(c, 0.0, 1.0), material.f0)
    if material.fresnel == "conductor":
        return _clipped_factor(conductor_factor(material.eta, material.k))
    return lambda c: np.ones_like(c)


def _clipped_factor(factor: FresnelFactor) -> FresnelFactor:
    return FresnelFactor(lambda c: factor(np.clip(c, 0.0, 1.0)), factor.kinks)


def single_scattering_brdf(mu_o, phi_o, mu_i, alpha_x, alpha_y, distribution: str, fresnel=None):
    """f_1 (docs/microsurface.md) for w_i = (s_i, 0, mu_i), w_o = (s_o cos phi_o, s_o sin phi_o, mu_o), mu's in (0, 1]."""
    s_i = math.sqrt(1.0 - mu_i * mu_i)
    s_o = np.sqrt(1.0 - mu_o * mu_o)
    ox, oy, oz = s_o * np.cos(phi_o), s_o * np.sin(phi_o), mu_o
    hx, hy, hz = ox + s_i, oy, oz + mu_i
    n = np.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / n, hy / n, hz / n
    g2 = smith_g2_correlated(
        smith_lambda(s_i, 0.0, mu_i, alpha_x, alpha_y, distribution),
        smith_lambda(ox, oy, oz, alpha_x, alpha_y, distribution),
    )
    f = ndf(hx, hy, hz, alpha_x, alpha_y, distribution) * g2 / (4.0 * mu_i * mu_o)
    if fresnel is not None:
        f = f * fresnel(s_i * hx + mu_i * hz)
    return f


def _rule(lo, hi, panels, nodes, breaks=()):
    """Composite Gauss-Legendre on [lo, hi]: ``panels`` equal panels, each split again at the ``breaks``
    inside it (where the integrand jumps)."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    edges = np.linspace(lo, hi, panels + 1)
    edges = np.unique(np.concatenate([edges, [b for b in breaks if lo < b < hi]]))
    a, b = edges[:-1, None], edges[1:, None]
    return ((a + b) / 2 + (b - a) / 2 * x).ravel(), ((b - a) / 2 * w).ravel()


def _peak_breaks(centre: float, alpha: float) -> tuple:
    """Panel edges graded towards a lobe's peak at ``centre``: centre +- alpha^2 2^k / 8, k = 0, 1, ... up to a
    distance of 2 (a peak of width alpha in direction is alpha^2 wide in mu where it meets mu = 1).  Few for a
    rough surface (5 on each side at alpha = 0.6), 23 at alpha = 1e-3: the fixed panels alone lose the peak
    below alpha ~ 0.03 (3e-3 of the order-1 total at alpha = 0.01, 25 % at 0.003)."""
    d = alpha * alpha / 8.0 * 2.0 ** np.arange(int(np.ceil(np.log2(16.0 / (alpha * alpha)))) + 1)
    d = d[d <= 2.0]
    return tuple(np.concatenate([[centre], centre - d, centre + d]))


def bin_average_single(
    mu_edges, phi_edges, mu_i, material, panels: int = 4, nodes: int = 12, use_exact_ggx: bool = True
):
    """Bin averages of f_1 mu_o (1/sr) over the tally's bins: array [mu bin, phi bin].  The panels are graded
    towards the mirror direction (mu_o = mu_i, |phi_o| = pi; :func:`_peak_breaks`).

    ``use_exact_ggx``: for isotropic GGX evaluate f_1 with the exact engine's ggx_brdf (times F)."""
    fres = fresnel_numpy(material)
    alpha = min(material.alpha_x, material.alpha_y)
    out = np.zeros((len(mu_edges) - 1, len(phi_edges) - 1))
    for i in range(len(mu_edges) - 1):
        mu, wmu = _rule(mu_edges[i], mu_edges[i + 1], panels, nodes, breaks=_peak_breaks(mu_i, alpha))
        mu = np.maximum(mu, 1e-300)
        for j in range(len(phi_edges) - 1):
            ph, wph = _rule(phi_edges[j], phi_edges[j + 1], panels, nodes, breaks=_peak_breaks(math.pi, alpha))
            m, p = np.meshgrid(mu, ph, indexing="ij")
            # the exact engine's GGX takes alpha in [0, 1]; scenes go to 2
            if use_exact_ggx and material.distribution == "ggx" and material.isotropic and material.alpha_x <= 1.0:
                f = ggx_brdf(m, mu_i, p, material.alpha_x, smith="correlated")
                s_i, s_o = math.sqrt(1 - mu_i * mu_i), np.sqrt(1 - m * m)
                h = np.stack([s_o * np.cos(p) + s_i, s_o * np.sin(p), m + mu_i])
                f = f * fres(np.clip((s_i * h[0] + mu_i * h[2]) / np.linalg.norm(h, axis=0), 0, 1))
            else:
                f = single_scattering_brdf(m, p, mu_i, material.alpha_x, material.alpha_y, material.distribution, fres)
            integral = np.einsum("i,j,ij->", wmu, wph, f * m)
            out[i, j] = integral / ((mu_edges[i + 1] - mu_edges[i]) * (phi_edges[j + 1] - phi_edges[j]))
    return out


def albedo_single(mu_i, material):
    """The order-1 albedo int f_1 mu_o dw_o, and the name of the method that gave it (conductor and
    dielectric facets: reflection; diffuse facets: :func:`bin_average_diffuse` over the hemisphere)."""
    if material.kind == "diffuse":
        mu_edges, phi_edges = np.linspace(0.0, 1.0, 5), np.linspace(0.0, math.pi, 5)
        avg = bin_average_diffuse(mu_edges, phi_edges, mu_i, material, panels=1, nodes=8)
        return float(np.sum(avg * 2.0 * np.outer(np.diff(mu_edges), np.diff(phi_edges)))), "bin_quadrature"
    if material.distribution == "ggx" and material.isotropic and material.alpha_x <= 1.0:
        fres = fresnel_numpy(material) if material.kind == "dielectric" or material.fresnel != "one" else None
        e = float(directional_albedo(mu_i, material.alpha_x, "ggx_correlated", fresnel=fres))
        return e, "exact_directional_albedo"
    return _hemisphere_total(bin_average_single, mu_i, material), "bin_quadrature"


def _hemisphere_total(bin_average, mu_i, material) -> float:
    """int over the hemisphere of a bin average's integrand: one bin (0, 1) x (0, pi) of 32 x 32 panels of
    16 x 16 nodes, graded towards the peak (1e-5 or better where total internal reflection kinks F, 1e-7
    elsewhere, against 4 times the panels)."""
    return float(bin_average((0.0, 1.0), (0.0, math.pi), mu_i, material, panels=32, nodes=16)[0, 0]) * 2.0 * math.pi


def _unit(x, y, z):
    n = np.sqrt(x * x + y * y + z * z)
    return x / n, y / n, z / n


def btdf(wi, wo, alpha_x, alpha_y, distribution: str, eta: float):
    """f_t(w_i, w_o) of order 1 (docs/microsurface.md) for unit vectors w_i = (x, y, z), z > 0 (above) and w_o,
    z < 0 (below), each a tuple of arrays (broadcast); eta = n_lower / n_upper > 0, != 1."""
    if not (eta > 0.0 and eta != 1.0):
        raise ValueError(f"eta must be positive and not 1 (no interface: a delta), got {eta}")
    ix, iy, iz = (np.asarray(c, float) for c in wi)
    ox, oy, oz = (np.asarray(c, float) for c in wo)
    s = -1.0 if eta > 1.0 else 1.0
    hx, hy, hz = _unit(s * (ix + eta * ox), s * (iy + eta * oy), s * (iz + eta * oz))
    c_i = ix * hx + iy * hy + iz * hz
    c_o = ox * hx + oy * hy + oz * hz
    valid = (hz > 0.0) & (c_i > 0.0) & (c_o < 0.0)
    hz_safe = np.where(valid, hz, 1.0)
    g2 = transmission_g2(
        smith_lambda(ix, iy, iz, alpha_x, alpha_y, distribution),
        smith_lambda(-ox, -oy, -oz, alpha_x, alpha_y, distribution),
    )
    # 1 - F from both cosines the half vector gives (not Snell's sqrt of c_i): free of the cancellation
    # near the critical angle, and the same expression for the path reversed
    transmittance = fresnel_dielectric_transmittance(np.clip(c_i, 0.0, 1.0), np.clip(-c_o, 0.0, 1.0), eta)
    f = (
        c_i
        * -c_o
        * eta
        * eta
        * transmittance
        * ndf(hx, hy, hz_safe, alpha_x, alpha_y, distribution)
        * g2
        / (iz * -oz * (c_i + eta * c_o) ** 2)
    )
    return np.where(valid, f, 0.0)


def single_transmission_btdf(mu_o, phi_o, mu_i, alpha_x, alpha_y, distribution: str, eta: float):
    """f_t for w_i = (s_i, 0, mu_i) and the transmitted w_o = (s_o cos phi_o, s_o sin phi_o, -mu_o),
    mu_o = |mu_o| in (0, 1] (phi_o = pi: straight through)."""
    s_i = math.sqrt(1.0 - mu_i * mu_i)
    s_o = np.sqrt(1.0 - mu_o * mu_o)
    return btdf(
        (s_i, 0.0, mu_i), (s_o * np.cos(phi_o), s_o * np.sin(phi_o), -mu_o), alpha_x, alpha_y, distribution, eta
    )


def bin_average_transmission(mu_edges, phi_edges, mu_i, material, panels: int = 4, nodes: int = 12):
    """Bin averages of f_t |mu_o| (1/sr) over the transmitted bins in (|mu_o|, |phi_o|): array [mu bin, phi bin]."""
    # the facet that refracts w_i into w_o lies in the horizon at |mu_o| = mu_i / eta, where a GGX f_t
    # jumps to 0 (D of a horizontal normal is not 0): a panel edge there; and panels graded towards the
    # peak, the direction refracted by the macro surface (|mu_o| = 0 when there is none: eta < 1 beyond
    # the critical angle)
    alpha = min(material.alpha_x, material.alpha_y)
    refracted = math.sqrt(max(0.0, 1.0 - (1.0 - mu_i * mu_i) / material.eta**2))
    mu_breaks = (mu_i / material.eta,) + _peak_breaks(refracted, alpha)
    out = np.zeros((len(mu_edges) - 1, len(phi_edges) - 1))
    for i in range(len(mu_edges) - 1):
        mu, wmu = _rule(mu_edges[i], mu_edges[i + 1], panels, nodes, breaks=mu_breaks)
        for j in range(len(phi_edges) - 1):
            ph, wph = _rule(phi_edges[j], phi_edges[j + 1], panels, nodes, breaks=_peak_breaks(math.pi, alpha))
            m, p = np.meshgrid(mu, ph, indexing="ij")
            f = single_transmission_btdf(
                m, p, mu_i, material.alpha_x, material.alpha_y, material.distribution, material.eta
            )
            out[i, j] = np.einsum("i,j,ij->", wmu, wph, f * m) / (
                (mu_edges[i + 1] - mu_edges[i]) * (phi_edges[j + 1] - phi_edges[j])
            )
    return out


def normal_rule(alpha_x, alpha_y, distribution: str, radial: int = 96, azimuthal: int = 192):
    """Nodes m (three arrays) and weights w with sum w g(m) ~ int g(m) D(m) m_z dm (docs/microsurface.md, "The
    normal rule"): Gauss-Legendre in v = sqrt(1 - u) on 4 panels and in the azimuth on 8 panels."""
    v, wv = _rule(0.0, 1.0, 4, radial // 4)
    ph, wph = _rule(0.0, 2.0 * math.pi, 8, azimuthal // 8)
    u = 1.0 - v * v
    r = np.sqrt(u) / v if distribution == "ggx" else np.sqrt(-2.0 * np.log(v))
    weight = np.outer(2.0 * v * wv, wph / (2.0 * math.pi))
    sx, sy = alpha_x * np.outer(r, np.cos(ph)), alpha_y * np.outer(r, np.sin(ph))
    mx, my, mz = _unit(-sx, -sy, np.ones_like(sx))
    return (mx.ravel(), my.ravel(), mz.ravel()), weight.ravel()


def order_one_by_normals(mu_i, material, radial: int = 384, azimuthal: int = 768):
    """(R_1, T_1) of a dielectric seen from above, integrated over the facet normals (docs/microsurface.md)."""
    eta = material.eta
    ax, ay, dist = material.alpha_x, material.alpha_y, material.distribution
    (mx, my, mz), w = normal_rule(ax, ay, dist, radial, azimuthal)
    ix, iz = math.sqrt(1.0 - mu_i * mu_i), mu_i
    c = ix * mx + iz * mz
    seen = c > 0.0
    c = np.where(seen, c, 0.0)
    f = fresnel_dielectric(c, eta)
    lam_i = smith_lambda(ix, 0.0, iz, ax, ay, dist)
    # reflected: 2 c m - w_i; refracted: m (c / eta - c_t) - w_i / eta (as the walk's microsurface.refract)
    rx, ry, rz = 2 * c * mx - ix, 2 * c * my, 2 * c * mz - iz
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - (1.0 - c * c) / (eta * eta)))
    a = c / eta - cos_t
    tx, ty, tz = _unit(a * mx - ix / eta, a * my, a * mz - iz / eta)
    up, down = seen & (rz > 0.0), seen & (tz < 0.0) & (f < 1.0)
    g_r = np.where(up, smith_g2_correlated(lam_i, smith_lambda(rx, ry, np.where(up, rz, 1.0), ax, ay, dist)), 0.0)
    g_t = np.where(down, transmission_g2(lam_i, smith_lambda(-tx, -ty, np.where(down, -tz, 1.0), ax, ay, dist)), 0.0)
    base = w * c / (mu_i * mz)
    return float(np.sum(base * f * g_r)), float(np.sum(base * (1.0 - f) * g_t))


def transmission_single(mu_i, material):
    """The order-1 transmitted fraction int f_t |mu_o| dw_o (the bin rule over the lower hemisphere), and its
    method's name.  :func:`order_one_by_normals` is the independent route the tests compare it with."""
    return _hemisphere_total(bin_average_transmission, mu_i, material), "bin_quadrature"


def diffuse_single_brdf(wi, wo, material, rule=None):
    """f_1 of diffuse facets (docs/microsurface.md) for w_i = (x, y, z) (floats, z > 0) and the arrays w_o
    (z > 0); rule: a :func:`normal_rule` (default 96 x 192 nodes)."""
    ax, ay, dist = material.alpha_x, material.alpha_y, material.distribution
    (mx, my, mz), w = rule if rule is not None else normal_rule(ax, ay, dist)
    ix, iy, iz = wi
    ox, oy, oz = (np.asarray(c, float)[..., None] for c in wo)
    ci = np.maximum(0.0, ix * mx + iy * my + iz * mz)
    co = np.maximum(0.0, ox * mx + oy * my + oz * mz)
    integral = np.sum(co * (w * ci / mz), axis=-1)
    oz = oz[..., 0]
    g2 = smith_g2_correlated(
        smith_lambda(ix, iy, iz, ax, ay, dist), smith_lambda(ox[..., 0], oy[..., 0], oz, ax, ay, dist)
    )
    return material.albedo / math.pi * integral * g2 / (iz * oz)


def bin_average_diffuse(mu_edges, phi_edges, mu_i, material, panels: int = 2, nodes: int = 6):
    """Bin averages of the diffuse facets' f_1 mu_o (1/sr) over the reflected bins: array [mu bin, phi bin]."""
    rule = normal_rule(material.alpha_x, material.alpha_y, material.distribution)
    wi = (math.sqrt(1.0 - mu_i * mu_i), 0.0, mu_i)
    out = np.zeros((len(mu_edges) - 1, len(phi_edges) - 1))
    for i in range(len(mu_edges) - 1):
        mu, wmu = _rule(mu_edges[i], mu_edges[i + 1], panels, nodes)
        for j in range(len(phi_edges) - 1):
            ph, wph = _rule(phi_edges[j], phi_edges[j + 1], panels, nodes)
            m, p = np.meshgrid(mu, ph, indexing="ij")
            s = np.sqrt(1.0 - m * m)
            f = diffuse_single_brdf(wi, (s * np.cos(p), s * np.sin(p), m), material, rule)
            out[i, j] = np.einsum("i,j,ij->", wmu, wph, f * m) / (
                (mu_edges[i + 1] - mu_edges[i]) * (phi_edges[j + 1] - phi_edges[j])
            )
    return out


def references(mu_edges, phi_edges, mu_i, material) -> dict:
    """The order-1 references of a job: ``lobe`` (bin averages), ``albedo`` ((value, method)), and for a
    dielectric ``lobe_transmission`` and ``transmission``."""
    if material.kind == "diffuse":
        return {
            "lobe": bin_average_diffuse(mu_edges, phi_edges, mu_i, material),
            "albedo": albedo_single(mu_i, material),
        }
    out = {"lobe": bin_average_single(mu_edges, phi_edges, mu_i, material), "albedo": albedo_single(mu_i, material)}
    if material.kind == "dielectric":
        out["lobe_transmission"] = bin_average_transmission(mu_edges, phi_edges, mu_i, material)
        out["transmission"] = transmission_single(mu_i, material)
    return out
