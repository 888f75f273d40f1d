r"""Kulla-Conti energy compensation with F = 1, its energy balance, and the blog's claims about it.

The compensation lobe (Kelemen and Szirmay-Kalos 2001, Kulla and Conti 2017, the blog's eq. 6):

    f_ms(mu_o, mu_i) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)),   E_avg = 2 int_0^1 E mu dmu,

the same function as the blog's (1 - E(mu_o)) (1 - E(mu_i)) / (pi - E_avg_blog) with its
E_avg_blog = 2 pi int_0^1 E mu dmu = pi E_avg.  Its directional albedo is
int f_ms mu_i dw_i = (1 - E(mu_o)) 2 pi int_0^1 (1 - E) mu dmu / (pi (1 - E_avg)) = 1 - E(mu_o), so that
f + f_ms passes the white furnace exactly at every mu_o, and its double integral is
int int (f + f_ms) mu_i mu_o dw_i dw_o = pi E_avg + pi (1 - E_avg) = pi (the blog's check).

Which term dominates: the single-scattering energy int int f mu_i mu_o dw dw = pi E_avg against the
compensation's pi (1 - E_avg) (the blog's grey and blue curves), i.e. multiple scattering
dominates where E_avg(alpha) < 1/2; or per direction, where E(mu, alpha) < 1/2, since the lobe's
albedo from mu is 1 - E(mu).  :func:`crossover_alpha` finds the alpha where that happens.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize

from fitlab.families.microfacet_energy.exact._checks import real_array
from fitlab.families.microfacet_energy.exact.albedo import average_albedo, average_nodes, directional_albedo
from fitlab.families.microfacet_energy.exact.models import get_model

__all__ = ["multiple_scattering_brdf", "compensated_albedo", "energy_integrals", "crossover_alpha"]


def _lobe(e_o, e_i, e_avg):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(e_avg != 1, (1 - e_o) * (1 - e_i) / (np.pi * (1 - e_avg)), 0.0)


def multiple_scattering_brdf(mu_o, mu_i, alpha, model: str = "ggx_separable"):
    """The compensation lobe f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)) with F = 1 and the
    exact E, E_avg of ``model`` (module docstring; the blog's eq. 6 is the same function).

    mu_o, mu_i, alpha in [0, 1], broadcast.  Reciprocal, independent of the azimuth, and 0 where
    E_avg = 1 exactly (alpha = 0: no energy is lost).  Its relative accuracy is that of 1 - E_avg, whose
    absolute error is ~1e-12: fine for alpha >= 1e-4 (1 - E_avg ~ 1e-7 there for GGX).

    Oren-Nayar as the blog writes it is not energy conserving at grazing for small roughness (its E
    exceeds 1 there, see :mod:`.oren_nayar`), so f_ms < 0 where E(mu_o) > 1 >= E(mu_i); with the
    footnote's 0.57 even E_avg > 1 for alpha below about 0.0996, and f_ms is unbounded as alpha
    approaches the alpha where E_avg = 1.  The formula is applied as it stands (the furnace identity
    holds regardless); the caller decides what such a lobe is worth.
    """
    get_model(model)
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0)
    mu_i = real_array(mu_i, "mu_i", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    return _lobe(
        directional_albedo(mu_o, alpha, model), directional_albedo(mu_i, alpha, model), average_albedo(alpha, model)
    )


def compensated_albedo(mu_o, alpha, model: str = "ggx_separable"):
    """The white furnace of f + f_ms: E(mu_o) + int f_ms(mu_o, mu_i) mu_i dw_i, the second term
    integrated numerically over mu_i (Gauss-Legendre graded towards mu_i = 0, with E at its nodes), not
    replaced by its closed value 1 - E(mu_o).  Equal to 1 for every mu_o and alpha up to the
    quadrature error (~1e-11).  mu_o, alpha in [0, 1], broadcast."""
    get_model(model)
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    mu_o, alpha = np.broadcast_arrays(mu_o, alpha)
    nodes, weights = average_nodes()
    out = np.empty(mu_o.shape)
    for a in np.unique(alpha):
        sel = alpha == a
        e_nodes = directional_albedo(nodes, a, model)
        e_o = directional_albedo(mu_o[sel], a, model)
        e_avg = average_albedo(a, model)
        lobe = _lobe(e_o[:, None], e_nodes[None, :], e_avg)
        out[sel] = e_o + 2 * np.pi * (lobe @ (weights * nodes))
    return out


def energy_integrals(alpha, model: str = "ggx_separable") -> dict[str, np.ndarray]:
    """The blog's energy check, in its normalisation (maximum pi):

    single = int int f mu_i mu_o dw_i dw_o = 2 pi int_0^1 E(mu) mu dmu (= pi E_avg),
    multiple = int int f_ms mu_i mu_o dw_i dw_o = (2 pi)^2 int int f_ms mu_i mu_o dmu_i dmu_o, integrated
    numerically on a tensor Gauss-Legendre rule (graded towards 0) of the exact f_ms,
    total = single + multiple (= pi).  alpha in [0, 1], any shape; returns arrays of its shape.
    """
    get_model(model)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    nodes, weights = average_nodes()
    single, multiple = np.empty(alpha.shape), np.empty(alpha.shape)
    for idx, a in np.ndenumerate(alpha):
        e = directional_albedo(nodes, a, model)
        wm = weights * nodes
        single[idx] = 2 * np.pi * np.dot(wm, e)
        lobe = _lobe(e[:, None], e[None, :], average_albedo(a, model))
        multiple[idx] = (2 * np.pi) ** 2 * (wm @ lobe @ wm)
    return {"single": single, "multiple": multiple, "total": single + multiple}


def crossover_alpha(model: str = "ggx_separable", mu=None, xtol: float = 1e-12):
    """The roughness at which multiple scattering takes over: the alpha in (0, 1] with E_avg(alpha) = 1/2
    (mu=None: the compensation lobe's share of the energy, pi (1 - E_avg), equals the single scattering's,
    pi E_avg), or E(mu, alpha) = 1/2 at a given mu in [0, 1] (per direction: the lobe's albedo 1 - E(mu)
    equals E(mu)).  Brent's method on [0, 1] on the exact E, to xtol in alpha; None when the value at
    alpha = 1 is still above 1/2 (the value at alpha = 0 is 1).  E_avg decreases with alpha for the GGX
    models (the tests check it on a grid), so the average crossing is unique; per direction E need not
    be monotone in alpha at small mu, and the alpha returned is then one crossing of possibly several."""
    get_model(model)
    if mu is None:

        def excess(a):
            return float(average_albedo(a, model)) - 0.5
    else:
        mu = float(real_array(mu, "mu", 0.0, 1.0))

        def excess(a):
            return float(directional_albedo(mu, a, model)) - 0.5

    if excess(1.0) > 0:
        return None
    return optimize.brentq(excess, 0.0, 1.0, xtol=xtol)
