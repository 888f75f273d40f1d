r"""Directional albedo E(mu, alpha) = int f(w_o, w_i) mu_i dw_i and its average, by two independent routes.

GGX, route "half_vector" (the default): over the half vector m.  With dw_i = 4 (w_o.m) dw_m and
D(m) mu_m dw_m = dxi dphi / (2 pi), xi = tan^2(theta_m) / (alpha^2 + tan^2(theta_m)) (the GGX
cumulative distribution, which absorbs the peak of D whatever alpha is),

    E(mu_o) = (1/pi) int_0^pi dphi int dxi  4 (w_o.m / mu_m) mu_i V(mu_o, mu_i) F(w_o.m),

equivalently E = int D_o(m) G2/G1(w_o) F dw_m over the visible normals D_o = G1 (w_o.m) D / mu_o
(phi is the azimuth of m from w_o's; the integrand is even in phi).  xi is traded for
tau = log(tan(theta_m) / alpha) (dxi = 2 dtau / (t + 1/t)^2, t = e^tau): D's peak sits at tau ~ 0 for
every alpha, both tails decay exponentially (as e^(2 tau) and e^(-2 tau), or e^(-tau) for the
correlated form at mu_o = 0), and every other feature is at a breakpoint below.  The reflected
direction, mu_i = s_o sin(2 theta_m) cos(phi) + mu_o cos(2 theta_m), is above the horizon

* for every phi while tan(theta_m) <= t1 = mu_o / (1 + s_o) (panel 1: phi in [0, pi]);
* for phi < phi_max = arccos(-mu_o cos(2 theta_m) / (s_o sin(2 theta_m))) while t1 <= tan(theta_m) <= 1/t1
  (panel 2: phi in [0, phi_max], the integrand vanishing linearly at phi_max);
* for no phi beyond.

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.exact.albedo``."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache, lru_cache

import numpy as np

from fitlab.families.microfacet_energy.exact._checks import choice, real_array
from fitlab.families.microfacet_energy.exact._quadrature import composite, gauss_legendre, graded_edges
from fitlab.families.microfacet_energy.exact.fresnel_factor import kinks_of
from fitlab.families.microfacet_energy.exact.models import get_model
from fitlab.families.microfacet_energy.exact.oren_nayar import (
    albedo_closed_form,
    average_albedo_closed_form,
    oren_nayar_coefficients,
)
from fitlab.physics.microfacet import ggx_ndf, ggx_visibility
from fitlab.physics.oren_nayar import oren_nayar

__all__ = ["METHODS", "CONVENTIONS", "directional_albedo", "average_albedo", "average_nodes"]

#: the routes of each kind of model, the default first
METHODS = {"ggx": ("half_vector", "direction"), "oren_nayar": ("closed_form", "direction")}
CONVENTIONS = ("kulla_conti", "blog")


#: sub-panel edges in tau away from the horizon breakpoints: width 1 across the peak of D (tau in
#: [-7, 7]) and growing into the tails as the integrand falls (as e^(2 tau) on the left, no slower
#: than e^(-tau) on the right), so that every sub-panel's error stays below 1e-12; clipped to each
#: stretch, the ones outside collapse to zero length
TAU_EDGES = (
    -19.0,
    -14.5,
    -12.0,
    -10.0,
    -8.5,
    *np.arange(-7.0, 8.0),
    8.0,
    9.0,
    10.0,
    11.5,
    13.0,
    15.0,
    17.5,
    20.5,
    24.0,
    28.5,
    34.0,
    40.0,
    47.0,
    55.0,
)


@dataclass(frozen=True)
class HalfVectorRule:
    """Sizes of the half-vector route (docs/microfacet_energy_derivation.md): nodes per tau sub-panel, the graded stretches
    next to the horizon breakpoints, azimuthal panels."""

    graded: int = 6  # geometric sub-panels of each graded stretch (ratio below)
    stretch: float = 1.5  # length in tau of a graded stretch (at most)
    nodes_tau: int = 10
    panels_phi: int = 6  # azimuthal panels graded towards the horizon end of the azimuth range
    nodes_phi: int = 10
    ratio: float = 0.2
    edges: tuple = TAU_EDGES
    tau_lo: float = -19.0  # D's mass below: < 1e-16
    tau_hi_margin: float = 38.0  # tau_hi = margin + log(1/alpha): the e^-tau tail of mu_o = 0 below 1e-16
    kink_graded: int = 8  # geometric sub-panels on each side of a tau where a kink of F meets the azimuths' ends


@dataclass(frozen=True)
class DirectionRule:
    """Sizes of the direction route: graded panels per segment, nodes per panel, grading ratio."""

    panels: int = 19
    nodes: int = 12
    ratio: float = 0.2  # smallest mu_i panel 0.2^18 ~ 3e-13 of its segment
    panels_psi: int = 24  # smallest psi panel pi 0.2^23 ~ 3e-16: the peak's width alpha mu_i at mu_o = 0


HALF_VECTOR = HalfVectorRule()
DIRECTION = DirectionRule()
_CHUNK = 200_000  # integrand values per numpy pass (1.6 MB arrays: larger ones cost page faults)


def _clipped(lo, hi, edges):
    """lo, the fixed ``edges`` clipped to [lo, hi], hi: shape (P, len(edges) + 2)."""
    inner = np.clip(np.asarray(edges)[None, :], lo[:, None], hi[:, None])
    return np.concatenate((lo[:, None], inner, hi[:, None]), axis=1)


def _panels(edges):
    """(lo, hi) of the panels between consecutive edges."""
    return edges[:, :-1], edges[:, 1:]


def _compact(lo, hi, *flags):
    """Drop the zero-length panels of each row (keeping the order), padding rows to the longest."""
    keep = hi > lo
    width = max(1, int(keep.sum(axis=1).max()))
    order = np.argsort(~keep, axis=1, kind="stable")[:, :width]
    rows = np.arange(lo.shape[0])[:, None]
    return tuple(a[rows, order] for a in (lo, hi, *flags))


def _panel_rule(lo, hi, squash_lo, squash_hi, n):
    """Composite Gauss-Legendre on panels (lo, hi) of shape (P, K); a panel flagged squash_lo
    (squash_hi) is mapped by t = lo + w u^2 (hi - w u^2), which turns a (distance)^(3/2) behaviour at
    that end into a smooth function of u.  Returns nodes and weights of shape (P, K n)."""
    x, w = gauss_legendre(n)
    lo, hi, squash_lo, squash_hi = (a[..., None] for a in (lo, hi, squash_lo, squash_hi))
    width = hi - lo
    nodes = np.where(squash_lo, lo + width * x * x, np.where(squash_hi, hi - width * x * x, lo + width * x))
    weights = width * np.where(squash_lo | squash_hi, 2 * x * w, w)
    return nodes.reshape(lo.shape[0], -1), weights.reshape(lo.shape[0], -1)


def _tau_rule(tau_lo, tau_1, tau_2, rule: HalfVectorRule, kinks=None):
    """tau nodes of panel 1 [tau_lo, tau_1] (graded towards tau_1) and of panel 2 [tau_1, tau_2]
    (graded towards both ends, the sub-panels touching them squashed); zero-length sub-panels (the
    fixed edges outside a stretch) are dropped.  kinks: further edges (shape (P, K), any values: each is
    clipped to each panel, those outside collapsing to zero-length sub-panels), where the azimuthal
    integral of a Fresnel factor with kinks bends (:func:`_kink_taus`)."""
    g1 = np.minimum(rule.stretch, tau_1 - tau_lo)
    edges_1 = np.concatenate(
        (
            _clipped(tau_lo, tau_1 - g1, rule.edges)[:, :-1],
            graded_edges(tau_1 - g1, tau_1, rule.graded, rule.ratio, "hi"),
        ),
        axis=1,
    )
    g2 = np.minimum(rule.stretch, (tau_2 - tau_1) / 3)
    edges_2 = np.concatenate(
        (
            graded_edges(tau_1, tau_1 + g2, rule.graded, rule.ratio, "lo")[:, :-1],
            _clipped(tau_1 + g2, tau_2 - g2, rule.edges)[:, :-1],
            graded_edges(tau_2 - g2, tau_2, rule.graded, rule.ratio, "hi"),
        ),
        axis=1,
    )
    if kinks is not None and kinks.shape[1]:
        # geometric stretches on both sides of each kink (absent ones, -inf, moved below tau_lo)
        k = np.where(np.isfinite(kinks), kinks, (tau_lo - 2 * rule.stretch)[:, None]).ravel()
        stretches = np.concatenate(
            (
                graded_edges(k - rule.stretch, k, rule.kink_graded, rule.ratio, "hi"),
                graded_edges(k, k + rule.stretch, rule.kink_graded, rule.ratio, "lo"),
            ),
            axis=1,
        )
        extra = stretches.reshape(kinks.shape[0], -1)
        edges_1 = np.sort(np.concatenate((edges_1, np.clip(extra, tau_lo[:, None], tau_1[:, None])), axis=1), axis=1)
        edges_2 = np.sort(np.concatenate((edges_2, np.clip(extra, tau_1[:, None], tau_2[:, None])), axis=1), axis=1)
    lo, hi = _panels(edges_1)
    no = np.zeros(lo.shape, dtype=bool)
    rule_1 = _panel_rule(*_compact(lo, hi, no, no), rule.nodes_tau)
    lo, hi = _panels(edges_2)
    # the sub-panels touching tau_1 and tau_2 (zero-length ones give no weight either way)
    first, last = lo == tau_1[:, None], hi == tau_2[:, None]
    rule_2 = _panel_rule(*_compact(lo, hi, first, last), rule.nodes_tau)
    return rule_1, rule_2


def _kink_taus(mu_o, alpha, kinks, horizon: bool):
    """tau = log(tan(theta_m) / alpha) where the curve w_o . m = c_k (a kink of F) meets an end of the
    azimuthal range: the plane of w_o, phi = 0 or pi, where w_o . m = cos(theta_o -+ theta_m), i.e.
    theta_m = theta_o + theta_k and |theta_o - theta_k| (theta_k = arccos c_k; there the azimuthal integral
    bends: it grows linearly from 0 on one side); with ``horizon``, the end phi_end where the reflected
    direction reaches the horizon (mu_i = 2 (w_o . m) mu_m - mu_o = 0, so cos(theta_m) = mu_o / (2 c_k)), which
    the curve crosses.  Shape (len(mu_o), 2 or 3 per kink); -inf where there is no such half vector."""
    theta_o = np.arccos(mu_o)
    columns = []
    for c_k in kinks:
        theta_k = np.arccos(c_k)
        angles = [theta_o + theta_k, np.abs(theta_o - theta_k)]
        if horizon:
            angles.append(np.arccos(np.minimum(mu_o / (2 * c_k), 1.0)))
        for theta in angles:
            inside = (theta > 0) & (theta < np.pi / 2)
            columns.append(np.where(inside, np.log(np.tan(np.where(inside, theta, 1.0)) / alpha), -np.inf))
    return np.stack(columns, axis=1)


@cache
def _phi_unit_rule(panels: int, nodes: int, ratio: float):
    """Nodes and weights on [0, 1] graded towards 1 (azimuths are phi_end * node)."""
    edges = graded_edges(np.array([0.0]), np.array([1.0]), panels, ratio, "hi")
    x, w = composite(edges, nodes)
    return x[0], w[0]


@cache
def _kinked_unit_rule(
    panels: int, nodes: int, ratio: float, grade_lo: bool, grade_hi: bool, kink_lo: bool, kink_hi: bool
):
    """Nodes and weights on [0, 1] of one part of an inner range split at kinks of F: graded geometrically
    towards 0 and/or 1 (each half on its own when towards both), the sub-panel touching a kink end mapped by
    u^2 (a square-root edge of F becomes smooth).  A kink end is always graded towards: near the point where
    the kink curve touches an end of the range, w_o . h - c_k = a (x_k^2 - x^2) also vanishes at -x_k, a
    singularity as near the kink x_k as x_k is to the range's end."""
    grade_lo, grade_hi = grade_lo or kink_lo, grade_hi or kink_hi
    zero, half, one = np.array([0.0]), np.array([0.5]), np.array([1.0])
    if grade_lo and grade_hi:
        edges = np.concatenate(
            (graded_edges(zero, half, panels, ratio, "lo")[:, :-1], graded_edges(half, one, panels, ratio, "hi")),
            axis=1,
        )
    else:
        edges = graded_edges(zero, one, panels, ratio, "lo" if grade_lo else "hi")
    lo, hi = _panels(edges)
    first, last = np.zeros(lo.shape, dtype=bool), np.zeros(lo.shape, dtype=bool)
    first[:, 0], last[:, -1] = kink_lo, kink_hi
    x, w = _panel_rule(lo, hi, first, last, nodes)
    return x[0], w[0]


def _split_rule(end, splits, panels: int, nodes: int, ratio: float, grade_lo: bool, grade_hi: bool):
    """Nodes and weights on [0, end] split at ``splits`` (a list of arrays of end's shape, clipped to the
    range; the last axis of length 1): each part a :func:`_kinked_unit_rule`, graded towards the range's own
    ends as grade_lo, grade_hi say and towards every kink.  Shapes (..., parts * panels-rule nodes)."""
    end = np.broadcast_to(end, splits[0].shape)
    inner = np.minimum(np.sort(np.concatenate(splits, axis=-1), axis=-1), end)
    bounds = np.concatenate((np.zeros(end.shape), inner, end), axis=-1)
    out_x, out_w, last = [], [], bounds.shape[-1] - 2
    for j in range(last + 1):
        x, w = _kinked_unit_rule(panels, nodes, ratio, grade_lo and j == 0, grade_hi and j == last, j > 0, j < last)
        lo, width = bounds[..., j : j + 1], bounds[..., j + 1 : j + 2] - bounds[..., j : j + 1]
        out_x.append(lo + width * x)
        out_w.append(width * w)
    return np.concatenate(out_x, axis=-1), np.concatenate(out_w, axis=-1)


def _kink_azimuths(mu_o, s_o, tan_m, kinks):
    """Azimuths phi_k of m where w_o . m = c_k for each kink (w_o . m = (mu_o + s_o tan_m cos phi) cos(theta_m),
    decreasing in phi): arrays of tan_m's shape, 0 where w_o . m < c_k for every phi, pi where > c_k."""
    sec = np.sqrt(1 + tan_m * tan_m)
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for c_k in kinks:
            cos_phi = (c_k * sec - mu_o) / (s_o * tan_m)
            out.append(np.arccos(np.clip(np.nan_to_num(cos_phi, nan=1.0), -1, 1)))
    return out


def _half_vector_nodes(rule: HalfVectorRule, kinks: int) -> int:
    """Integrand values per point of the half-vector rule (at most) with ``kinks`` kinks of F: each adds 3 tau
    edges to both tau panels and a part to every azimuthal range."""
    n_tau = (2 * len(rule.edges) + 3 * rule.graded + 3 + 2 * 3 * (2 * rule.kink_graded + 1) * kinks) * rule.nodes_tau
    return n_tau * (1 + 2 * kinks) * rule.panels_phi * rule.nodes_phi


def _ggx_half_vector(mu_o, alpha, smith, fresnel, rule: HalfVectorRule = HALF_VECTOR):
    """E for 1-D arrays mu_o, alpha (alpha > 0) by the half-vector route (docs/microfacet_energy_derivation.md)."""
    out = np.empty(mu_o.shape)
    per_point = _half_vector_nodes(rule, len(kinks_of(fresnel)))
    step = max(1, _CHUNK // per_point)
    # points of similar (tau_1, tau_2) in one pass need similar numbers of sub-panels
    order = np.lexsort((alpha, mu_o))
    for start in range(0, mu_o.size, step):
        sl = order[start : start + step]
        out[sl] = _ggx_half_vector_chunk(mu_o[sl], alpha[sl], smith, fresnel, rule)
    return out


def _ggx_half_vector_chunk(mu_o, alpha, smith, fresnel, rule):
    s_o = np.sqrt(1 - mu_o * mu_o)
    log_a = np.log(alpha)
    with np.errstate(divide="ignore", over="ignore"):  # mu_o = 0 or subnormal: tau_2 = inf, clipped below
        tau_1 = np.log(mu_o / (1 + s_o)) - log_a  # tan(theta_1) = mu_o / (1 + s_o)
        tau_2 = np.log((1 + s_o) / mu_o) - log_a  # tan(theta_2) = 1 / tan(theta_1)
    tau_hi = rule.tau_hi_margin - log_a
    tau_1 = np.clip(tau_1, rule.tau_lo, tau_hi)
    tau_2 = np.clip(tau_2, tau_1, tau_hi)
    kinks = kinks_of(fresnel)
    kink_taus = _kink_taus(mu_o, alpha, kinks, horizon=True) if kinks else None
    (tau_a, w_a), (tau_b, w_b) = _tau_rule(np.full(mu_o.shape, rule.tau_lo), tau_1, tau_2, rule, kink_taus)
    mu_o_, s_o_, a_ = mu_o[:, None, None], s_o[:, None, None], alpha[:, None, None]
    x_phi, w_phi = _phi_unit_rule(rule.panels_phi, rule.nodes_phi, rule.ratio)

    def panel(tau, w_tau, full: bool):
        t = np.exp(tau)[..., None]
        tan_m = alpha[:, None, None] * t
        tan2 = tan_m * tan_m
        cos_2m, sin_2m = (1 - tan2) / (1 + tan2), 2 * tan_m / (1 + tan2)
        dxi = 2 / (t + 1 / t) ** 2  # dxi / dtau
        if full:
            phi_end = np.pi
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                threshold = np.where(s_o_ > 0, -mu_o_ * cos_2m / (s_o_ * sin_2m), 1.0)
            phi_end = np.arccos(np.clip(np.nan_to_num(threshold, nan=1.0), -1, 1))
        if kinks:
            # each part graded towards its upper end, as _phi_unit_rule is, and towards its kinks
            phi, w_phi_ = _split_rule(
                phi_end,
                _kink_azimuths(mu_o_, s_o_, tan_m, kinks),
                rule.panels_phi,
                rule.nodes_phi,
                rule.ratio,
                False,
                True,
            )
            cos_phi = np.cos(phi)
        else:
            cos_phi = np.cos(phi_end * x_phi)
        om_over_mu_m = s_o_ * tan_m * cos_phi + mu_o_  # (w_o . m) / mu_m
        mu_i = np.maximum(s_o_ * sin_2m * cos_phi + mu_o_ * cos_2m, 0)
        value = 4 * om_over_mu_m * ggx_visibility(mu_o_, mu_i, a_ * a_, smith, times_mu_i=True)
        if fresnel is not None:
            value = value * fresnel(om_over_mu_m / np.sqrt(1 + tan2))
        inner = np.sum(value * w_phi_, axis=-1) * dxi[..., 0] if kinks else (value @ w_phi) * (phi_end * dxi)[..., 0]
        return np.sum(inner * w_tau, axis=1)

    return (panel(tau_a, w_a, True) + panel(tau_b, w_b, False)) / np.pi


@cache
def _direction_psi(rule: DirectionRule):
    edges = graded_edges(np.array([0.0]), np.array([np.pi]), rule.panels_psi, rule.ratio, "lo")
    psi, w = composite(edges, rule.nodes)
    half_sin2 = np.sin(psi[0] / 2) ** 2
    return half_sin2, w[0]


def _direction_mu_nodes(mu_o, rule: DirectionRule, breaks=None):
    """Nodes of [0, mu_o/2] (graded towards 0), [mu_o/2, mu_o] and [mu_o, 1] (graded towards mu_o):
    mu_i, 1 - mu_i and mu_i - mu_o, each computed from the node's offset to its graded end, so that
    the peak (within alpha^2 of mu_i = 1 at normal incidence) is resolved below the spacing of
    floats near 1; and the weights.  breaks (shape (P, K), in [0, 1]): further points where the integrand
    bends (:func:`_kink_mu_i`), between which the segments are halved the same way (each half graded towards
    its end), [b_last, 1] graded towards b_last."""
    x, w = gauss_legendre(rule.nodes)
    # offsets d_k + L_k x from the graded end, on panels [L r^(k+1), L r^k] (the last one [0, L r^(K-1)])
    unit = graded_edges(np.array([0.0]), np.array([1.0]), rule.panels, rule.ratio, "lo")[0]
    lo, hi = unit[:-1, None], unit[1:, None]
    offsets, weights = (lo + (hi - lo) * x).ravel(), ((hi - lo) * w).ravel()
    mo = mu_o[:, None]
    ends = mo if breaks is None else np.sort(np.concatenate((mo, breaks), axis=1), axis=1)
    # (end, length, direction) of every graded piece: halves of [0, e_0], [e_0, e_1], ..., then [e_last, 1]
    pieces = []
    for a, b in zip(
        (np.zeros_like(mo), *(ends[:, j : j + 1] for j in range(ends.shape[1] - 1))),
        (ends[:, j : j + 1] for j in range(ends.shape[1])),
    ):
        half = (b - a) / 2
        pieces += [(a, half, 1.0), (b, half, -1.0)]
    last = ends[:, -1:]
    pieces.append((last, 1 - last, 1.0))
    mu_i, one_minus, minus_mu_o, w_mu = [], [], [], []
    for end, length, sign in pieces:
        d = length * offsets
        mu_i.append(end + d if sign > 0 else end - d)
        one_minus.append((1 - end) - d if sign > 0 else (1 - end) + d)
        minus_mu_o.append((end - mo) + d if sign > 0 else (end - mo) - d)
        w_mu.append(length * weights)
    return tuple(np.concatenate(v, axis=1) for v in (mu_i, one_minus, minus_mu_o, w_mu))


def _kink_mu_i(mu_o, kinks):
    """mu_i where the curve w_o . h = c_k of a kink meets psi = 0 or pi, i.e. where the angle between w_o and
    w_i, 2 arccos(w_o . h), is theta_o + theta_i or |theta_o - theta_i|: theta_i = 2 theta_k - theta_o,
    theta_o +- 2 theta_k (theta_k = arccos c_k); those outside (0, pi/2) replaced by mu_o.  Shape (P, 3 K)."""
    theta_o = np.arccos(mu_o)
    columns = []
    for c_k in kinks:
        theta_k = np.arccos(c_k)
        for theta in (2 * theta_k - theta_o, theta_o + 2 * theta_k, theta_o - 2 * theta_k):
            columns.append(np.where((theta > 0) & (theta < np.pi / 2), np.cos(theta), mu_o))
    return np.stack(columns, axis=1)


def _kink_psi(mu_o, s_o, mu_i, s_i, kinks):
    """psi_k where w_o . h = c_k: |w_o + w_i|^2 = 2 (1 + mu_o mu_i - s_o s_i cos psi) = 4 c_k^2, w_o . h growing
    with psi; 0 where w_o . h > c_k for every psi, pi where < c_k.  A list of arrays of mu_i's shape + (1,)."""
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for c_k in kinks:
            cos_psi = (mu_o * mu_i - (2 * c_k * c_k - 1)) / (s_o * s_i)
            out.append(np.arccos(np.clip(np.nan_to_num(cos_psi, nan=1.0), -1, 1))[..., None])
    return out


def _ggx_direction(mu_o, alpha, smith, fresnel, rule: DirectionRule = DIRECTION):
    """E for 1-D arrays mu_o, alpha (alpha > 0) by the direction route (docs/microfacet_energy_derivation.md)."""
    half_sin2, w_psi = _direction_psi(rule)
    kinks = kinks_of(fresnel)
    out = np.empty(mu_o.shape)
    # with kinks: 3 more mu_i breakpoints per kink (2 pieces each), each psi part graded at both ends
    per_point = (3 + 6 * len(kinks)) * rule.panels * rule.nodes * half_sin2.size * (1 + 2 * len(kinks))
    step = max(1, _CHUNK // per_point)
    for start in range(0, mu_o.size, step):
        sl = slice(start, start + step)
        mo, a = mu_o[sl, None], alpha[sl, None]
        breaks = _kink_mu_i(mu_o[sl], kinks) if kinks else None
        mu_i, one_minus, minus_mu_o, w_mu = _direction_mu_nodes(mu_o[sl], rule, breaks)
        so, si = np.sqrt((1 - mo) * (1 + mo)), np.sqrt(one_minus * (1 + mu_i))
        if kinks:
            # each psi part graded towards 0 (the peak) as _direction_psi is, and towards its kinks
            psi, w_psi_ = _split_rule(
                np.pi, _kink_psi(mo, so, mu_i, si, kinks), rule.panels_psi, rule.nodes, rule.ratio, True, False
            )
            half_sin2_ = np.sin(psi / 2) ** 2
        else:
            half_sin2_ = half_sin2
        with np.errstate(divide="ignore", invalid="ignore"):
            diff = np.where(so + si > 0, minus_mu_o * (mu_i + mo) / (so + si), 0)  # s_o - s_i
        x = (diff * diff)[..., None] + (4 * so * si)[..., None] * half_sin2_  # X = |w_o,t + w_i,t|^2
        z = ((mo + mu_i) ** 2)[..., None]
        d = ggx_ndf(x, z, (a * a)[..., None])
        if fresnel is not None:
            d = d * fresnel(np.sqrt(x + z) / 2)  # w_o . h = |w_o + w_i| / 2
        azimuthal = np.sum(d * w_psi_, axis=-1) if kinks else d @ w_psi
        out[sl] = 2 * np.sum(w_mu * ggx_visibility(mo, mu_i, a * a, smith, times_mu_i=True) * azimuthal, axis=1)
    return out


def _oren_nayar_direction(mu_o, alpha, a_constant, azimuth, nodes: int = 24):
    """E by Gauss-Legendre in (theta_i, phi), split at theta_o and pi/2 (docs/microfacet_energy_derivation.md)."""
    x, w = gauss_legendre(nodes)
    theta_o = np.arccos(mu_o)[:, None]
    theta_i = np.concatenate((theta_o * x, theta_o + (np.pi / 2 - theta_o) * x), axis=1)
    w_theta = np.concatenate((theta_o * w, (np.pi / 2 - theta_o) * w), axis=1)
    phi = np.concatenate((np.pi / 2 * x, np.pi / 2 + np.pi / 2 * x))
    w_phi = np.concatenate((np.pi / 2 * w, np.pi / 2 * w))
    a, b = oren_nayar_coefficients(alpha, a_constant)
    mu_i = np.cos(theta_i)
    f = oren_nayar(mu_o[:, None, None], mu_i[..., None], np.cos(phi), a[:, None, None], b[:, None, None], azimuth)
    # 2: phi in [0, pi] stands for [0, 2 pi]
    return 2 * np.sum(w_theta * np.sin(theta_i) * mu_i * (f @ w_phi), axis=1)


def _albedo_1d(mu, alpha, model, method, fresnel):
    """E on 1-D float64 arrays of equal length (checked, method resolved)."""
    m = get_model(model)
    if m.kind == "oren_nayar":
        if method == "closed_form":
            return albedo_closed_form(mu, alpha, m.a_constant, m.azimuth)
        return _oren_nayar_direction(mu, alpha, m.a_constant, m.azimuth)
    out = np.empty(mu.shape)
    mirror = alpha == 0
    out[mirror] = 1.0 if fresnel is None else fresnel(mu[mirror])
    route = _ggx_half_vector if method == "half_vector" else _ggx_direction
    rough = ~mirror
    if np.any(rough):
        out[rough] = route(mu[rough], alpha[rough], m.smith, fresnel)
    return out


def _resolve(model, method, fresnel):
    m = get_model(model)
    methods = METHODS[m.kind]
    method = methods[0] if method is None else choice(method, "method", methods)
    if fresnel is not None and m.kind != "ggx":
        raise ValueError(f"a Fresnel factor applies to the GGX models, not to {model}")
    if fresnel is not None and not callable(fresnel):
        raise TypeError("fresnel must be a function of cos(theta_d) = w_o . h (arrays in, arrays out)")
    return m, method


def directional_albedo(mu, alpha, model: str = "ggx_separable", method: str | None = None, fresnel=None):
    """Directional albedo E(mu, alpha) = int f(w_o, w_i) mu_i dw_i of ``model`` (F = 1), mu = mu_o.

    mu, alpha in [0, 1], broadcast; returns float64 of their broadcast shape.  method: for GGX
    "half_vector" (default) or "direction", for Oren-Nayar "closed_form" (default) or "direction"
    (the two independent routes of docs/microfacet_energy_derivation.md; they agree to 1e-9 or better).  By
    reciprocity E is also the albedo seen from w_i.  fresnel (GGX only): a function F(cos theta_d) of
    w_o . h applied inside the integral (e.g. Schlick's); alpha = 0 gives F(mu).  A F with kinks (a
    dielectric with eta < 1: total internal reflection) must come as a :class:`FresnelFactor` that names them
    (:func:`dielectric_factor`, :func:`conductor_factor`), whose curves the routes then follow (module
    docstring); a plain function is taken as smooth.
    """
    m, method = _resolve(model, method, fresnel)
    mu = real_array(mu, "mu", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    mu, alpha = np.broadcast_arrays(mu, alpha)
    flat = _albedo_1d(mu.ravel().copy(), alpha.ravel().copy(), m.name, method, fresnel)
    return flat.reshape(mu.shape)


@dataclass(frozen=True)
class AverageRule:
    """mu nodes of E_avg: composite Gauss-Legendre on [0, 1/2] graded towards 0 (where GGX's E changes
    on the scale alpha and has a mu log mu term) and on [1/2, 1] graded towards 1 (where Oren-Nayar's E
    has a sqrt(1 - mu) term: its sin(theta_max) tan(theta_min) has a cusp at normal incidence)."""

    panels_0: int = 14
    panels_1: int = 10
    nodes: int = 10
    ratio: float = 0.2  # smallest panels 0.5 * 0.2^13 ~ 6e-10 at 0, 0.5 * 0.2^9 ~ 3e-7 at 1


AVERAGE = AverageRule()


@cache
def average_nodes(rule: AverageRule = AVERAGE) -> tuple[np.ndarray, np.ndarray]:
    """mu nodes and weights on [0, 1] of the E_avg quadrature (:class:`AverageRule`), read-only."""
    edges = np.concatenate(
        (
            graded_edges(np.array([0.0]), np.array([0.5]), rule.panels_0, rule.ratio, "lo")[0, :-1],
            graded_edges(np.array([0.5]), np.array([1.0]), rule.panels_1, rule.ratio, "hi")[0],
        )
    )
    nodes, weights = composite(edges, rule.nodes)
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


def average_albedo(alpha, model: str = "ggx_separable", convention: str = "kulla_conti", method: str | None = None):
    """Average (hemispherical, cosine-weighted) albedo of ``model`` (F = 1).

    convention "kulla_conti": E_avg = 2 int_0^1 E(mu) mu dmu, in [0, 1] (Kulla and Conti 2017; with
    it f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg))).  "blog": int E(mu) mu dw
    = 2 pi int_0^1 E(mu) mu dmu = pi times the former, in [0, pi] (the blog's eq. 4; with it
    f_ms = (1 - E)(1 - E) / (pi - E_avg), the same function).  alpha in [0, 1], any shape;
    method as for :func:`directional_albedo` ("closed_form" for Oren-Nayar is exact).
    """
    convention = choice(convention, "convention", CONVENTIONS)
    m, method = _resolve(model, method, None)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    scale = 1.0 if convention == "kulla_conti" else np.pi
    if m.kind == "oren_nayar" and method == "closed_form":
        return scale * average_albedo_closed_form(alpha, m.a_constant, m.azimuth)
    uniq, inverse = np.unique(alpha.ravel(), return_inverse=True)
    values = np.array([_average_cached(float(a), m.name, method) for a in uniq])
    return scale * values[inverse].reshape(alpha.shape)


@lru_cache(maxsize=4096)
def _average_cached(alpha: float, model: str, method: str) -> float:
    mu, w = average_nodes()
    e = _albedo_1d(mu.copy(), np.full(mu.shape, alpha), model, method, None)
    return float(2 * np.dot(w * mu, e))
