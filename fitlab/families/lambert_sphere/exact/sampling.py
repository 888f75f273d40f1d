r"""The variance-optimal sampling mixture of the Lambert-sphere BRDF: the exact values of the sampler's
targets (docs/model.md, "Importance sampling").

A renderer that shades with f_r draws the outgoing direction w_o from a density p(w_o | w_i) and
weights the sample by f_r cos(theta_o) / p.  fitlab's sampler draws from the mixture

    p(w_o) = (1 - w) mu_o / pi  +  w (n + 1) / (2 pi) max(0, w_i . w_o)^n,   mu_o > 0,

a cosine lobe about the normal (what renderers use for diffuse surfaces) mixed with a power-cosine lobe
about the back-scattering direction w_o = w_i, where the Lambert-sphere BRDF peaks.  w_i . w_o =
mu_i mu_o + S cos phi, S = sqrt((1 - mu_i^2)(1 - mu_o^2)), phi = 0 back-scattering (the exact BRDF's
convention).  The back-scatter lobe is drawn over the whole sphere; a direction below the surface is a
lost sample, so p integrates to 1 - w P(below) <= 1 over the hemisphere, and the estimator stays unbiased.

For one incidence mu_i and albedo c, the one-sample estimator of the directional albedo
a = int g dw_o, g = f_r mu_o, has the relative variance

    V(w, n) = int_{mu_o > 0} g^2 / p dw_o / a^2 - 1,

Details: docs/derivation.md, section ``fitlab.families.lambert_sphere.exact.sampling``."""

from __future__ import annotations

import numpy as np

from fitlab.families.lambert_sphere.exact import _checks
from fitlab.families.lambert_sphere.exact._quadrature import gauss_legendre, graded_gauss
from fitlab.families.lambert_sphere.exact.brdf import brdf
from fitlab.families.lambert_sphere.exact.phase import phase_function

__all__ = [
    "mixture_pdf",
    "relative_variance",
    "variance_function",
    "optimal_mixture",
    "N_MIN",
    "N_MAX",
    "QUADRATURE_NODES",
    "MU_MIN",
]

#: the exponent's search interval
N_MIN, N_MAX = 0.25, 64.0
#: Gauss-Legendre nodes in phi, and per graded panel in mu_o, of the variance quadrature
QUADRATURE_NODES = (48, 8)
#: the smallest incidence of the sampler's domain (docs/derivation.md)
MU_MIN = 1e-3
_N_SCAN = np.geomspace(N_MIN, N_MAX, 49)


def _dot(mu_i, mu_o, cos_phi):
    """w_i . w_o = mu_i mu_o + S cos phi (phi = 0 back-scattering)."""
    return mu_i * mu_o + np.sqrt(np.maximum(0.0, (1.0 - mu_i**2) * (1.0 - mu_o**2))) * cos_phi


def _mixture(cosine, dot, weight, exponent):
    """The mixture from the cosine lobe's density mu_o/pi and max(0, w_i . w_o)."""
    return (1.0 - weight) * cosine + weight * (exponent + 1.0) / (2.0 * np.pi) * dot**exponent


def mixture_pdf(mu_i, mu_o, cos_phi, weight, exponent):
    """The sampling density p(w_o | w_i) (1/sr) of docs/derivation.md; 0 for mu_o <= 0.  Broadcast."""
    mu_i, mu_o, cos_phi, weight, exponent = np.broadcast_arrays(
        *(np.asarray(x, dtype=float) for x in (mu_i, mu_o, cos_phi, weight, exponent))
    )
    density = _mixture(mu_o / np.pi, np.maximum(_dot(mu_i, mu_o, cos_phi), 0.0), weight, exponent)
    return np.where(mu_o > 0.0, density, 0.0)


def _nodes(nodes: tuple):
    x, w = gauss_legendre(nodes[0])
    mu, w_mu = graded_gauss(nodes[1], 0.25, 1e-6)
    mu_o, phi = np.meshgrid(mu, np.pi * x, indexing="ij")
    return mu_o, phi, 2.0 * np.pi * np.outer(w_mu, w)  # 2 int_0^pi dphi: f_r is even in phi


def _integrand(mu_i: np.ndarray, c: float, nodes: tuple):
    """g = f_r mu_o at the quadrature nodes for every mu_i (shape (len(mu_i), nodes, nodes)), with the
    nodes' (mu_o, cos phi) and weights; at c = 0 the limit shape p(u) mu_o / (mu_i + mu_o)."""
    mu_o, phi, weights = _nodes(nodes)
    mi, mo, ph = np.meshgrid(mu_i, mu_o[:, 0], phi[0], indexing="ij")
    if c > 0.0:
        # the mixed reference (three-term multiple scattering, within 3e-3 of the material's BRDF): the
        # packaged sampling tables are optimal for it (docs/derivation.md)
        g = brdf(mi, mo, ph, np.full(mi.shape, c), phase="mixed") * mo
    else:
        g = phase_function(-_dot(mi, mo, np.cos(ph))) / (mi + mo) * mo
    return g, mo, np.cos(ph), weights


def _variance_function(g, mu_i, mu_o, cos_phi, weights):
    a = np.sum(weights * g)
    g2 = weights * g**2 / a**2
    cosine = mu_o / np.pi
    dot = np.maximum(_dot(mu_i, mu_o, cos_phi), 0.0)

    def variance(w, n):
        return float(np.sum(g2 / _mixture(cosine, dot, w, n)) - 1.0)

    return variance


def variance_function(mu_i: float, c: float, nodes: tuple = QUADRATURE_NODES):
    """V(w, n) of docs/derivation.md at one incidence mu_i in [MU_MIN, 1] and albedo c in [0, 1], as a function
    of (weight, exponent) (the BRDF is evaluated once)."""
    mu_i = float(_checks.real_scalar(mu_i, "mu_i", MU_MIN, 1.0, domain="[1e-3, 1] (MU_MIN: V diverges as mu_i -> 0)"))
    c = float(_checks.real_scalar(c, "c", 0.0, 1.0))
    g, mu_o, cos_phi, weights = _integrand(np.array([mu_i]), c, nodes)
    return _variance_function(g[0], mu_i, mu_o[0], cos_phi[0], weights)


def relative_variance(mu_i, c: float, weight, exponent, nodes: tuple = QUADRATURE_NODES) -> np.ndarray:
    """V(w, n) of docs/derivation.md at each mu_i (1-D, in [MU_MIN, 1]) for one albedo c in [0, 1], with the
    mixture (``weight``, ``exponent``: scalars or one per mu_i); weight 0 is cosine sampling.  mu_i in [MU_MIN, 1]."""
    mu_i = _checks.real_array(mu_i, "mu_i", MU_MIN, 1.0, domain="[1e-3, 1] (MU_MIN: V diverges as mu_i -> 0)").ravel()
    c = float(_checks.real_scalar(c, "c", 0.0, 1.0))
    weight, exponent = (np.broadcast_to(np.asarray(x, dtype=float), mu_i.shape) for x in (weight, exponent))
    g, mu_o, cos_phi, weights = _integrand(mu_i, c, nodes)
    return np.array(
        [
            _variance_function(g[k], mi, mu_o[k], cos_phi[k], weights)(weight[k], exponent[k])
            for k, mi in enumerate(mu_i)
        ]
    )


def _optimum(variance):
    """(w, n, V) minimising ``variance(w, n)``: the best w for each n of a geometric scan, then the best
    bracket refined in log n."""
    from scipy.optimize import minimize_scalar  # imported here: see .albedo.single_scattering_albedo

    def best_weight(n):
        r = minimize_scalar(
            lambda w: variance(w, n), bounds=(0.0, 1.0 - 1e-9), method="bounded", options={"xatol": 1e-7}
        )
        return float(r.x), float(r.fun)

    profile = [best_weight(n)[1] for n in _N_SCAN]
    k = int(np.argmin(profile))
    lo, hi = np.log(_N_SCAN[max(k - 1, 0)]), np.log(_N_SCAN[min(k + 1, len(_N_SCAN) - 1)])
    r = minimize_scalar(lambda t: best_weight(np.exp(t))[1], bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
    n = float(np.exp(r.x))
    w, v = best_weight(n)
    if profile[k] < v:  # the refinement can only improve on the scan (flat profiles): keep the better
        n = float(_N_SCAN[k])
        w, v = best_weight(n)
    return w, n, v


def optimal_mixture(mu_i, c: float, nodes: tuple = QUADRATURE_NODES) -> dict:
    """The variance-optimal mixture at each mu_i (1-D, in [MU_MIN, 1]) for one albedo c in [0, 1]:
    {"weight", "exponent", "relvar_optimal", "relvar_cosine"}, arrays like mu_i (see the module
    docstring)."""
    mu_i = _checks.real_array(mu_i, "mu_i", MU_MIN, 1.0, domain="[1e-3, 1] (MU_MIN: V diverges as mu_i -> 0)").ravel()
    c = float(_checks.real_scalar(c, "c", 0.0, 1.0))
    g, mu_o, cos_phi, weights = _integrand(mu_i, c, nodes)
    out = {k: np.empty(mu_i.shape) for k in ("weight", "exponent", "relvar_optimal", "relvar_cosine")}
    for k, mi in enumerate(mu_i):
        variance = _variance_function(g[k], mi, mu_o[k], cos_phi[k], weights)
        w, n, v = _optimum(variance)
        out["weight"][k], out["exponent"][k], out["relvar_optimal"][k] = w, n, v
        out["relvar_cosine"][k] = variance(0.0, 1.0)
    return out
