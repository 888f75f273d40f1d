r"""Fresnel factors and Kulla-Conti's coloured energy compensation (the blog's "With varying Fresnel",
left as a TODO there), with what it conserves and what it approximates.

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.exact.fresnel``."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from fitlab.families.microfacet_energy.exact._checks import choice, real_array, working_dtype
from fitlab.families.microfacet_energy.exact._quadrature import gauss_legendre
from fitlab.families.microfacet_energy.exact.albedo import (
    HALF_VECTOR,
    _half_vector_nodes,
    _kink_azimuths,
    _kink_taus,
    _phi_unit_rule,
    _split_rule,
    _tau_rule,
    average_albedo,
    average_nodes,
    directional_albedo,
)
from fitlab.families.microfacet_energy.exact.compensation import _lobe, multiple_scattering_brdf
from fitlab.families.microfacet_energy.exact.fresnel_factor import FresnelFactor, kinks_of
from fitlab.families.microfacet_energy.exact.models import get_model
from fitlab.physics import fresnel
from fitlab.physics.microfacet import ggx_root_term

__all__ = [
    "COMPENSATION_FORMS",
    "FIRST_BOUNCE",
    "average_fresnel",
    "average_fresnel_conductor",
    "average_fresnel_dielectric",
    "average_fresnel_schlick",
    "compensated_fresnel_albedo",
    "conductor_factor",
    "dielectric_factor",
    "fresnel_compensation_factor",
    "fresnel_conductor",
    "fresnel_dielectric",
    "fresnel_dielectric_transmittance",
    "fresnel_multiple_scattering_brdf",
    "fresnel_schlick",
    "random_walk_albedo",
    "visible_fresnel",
]

#: the two forms of the coloured factor (docs/microfacet_energy_derivation.md): Kulla-Conti's F_avg^2 E_avg / (1 - F_avg (1 - E_avg))
#: (the default) and the one with a Fresnel factor fewer, F_avg E_avg / (1 - F_avg (1 - E_avg))
COMPENSATION_FORMS = ("kulla_conti", "unweighted_first")
#: the first reflection of :func:`random_walk_albedo`: exact, or as the model A1-A3 takes it
FIRST_BOUNCE = ("exact", "averaged")

_ROUNDING_ULPS = 16  # a cosine this many ulp outside [0, 1] is clipped, not refused
_AVERAGE_NODES = 16  # Gauss-Legendre nodes per panel of the adaptive F_avg
_AVERAGE_TOL = 1e-14  # accepted difference between a panel's coarse and fine values
_AVERAGE_MAX_LEVELS = 60  # bisections at most (a panel of 2^-60 is below the spacing of floats near 1)
_AVERAGE_MAX_PANELS = 4096  # panels refined at once at most (a function that is nowhere smooth stops there)


# -- Fresnel factors ------------------------------------------------------------------------------------
def _cosine(cos, dtype):
    """cos as an array of dtype clipped to [0, 1]: refused beyond [-1, 1 + 16 ulp] (docs/microfacet_energy_derivation.md)."""
    slack = _ROUNDING_ULPS * float(np.finfo(dtype).eps)
    c = real_array(cos, "cos", -1.0, 1 + slack, dtype=dtype, domain="[-1, 1] (cos(theta_d) = w . m)")
    return np.clip(c, 0, 1)


def _index(value, name, dtype, open_lo):
    # k^2 and eta^2 must stay finite: below sqrt(max) / 4
    hi = float(np.sqrt(np.finfo(dtype).max)) / 4
    return real_array(
        value,
        name,
        0.0,
        hi,
        open_lo=open_lo,
        dtype=dtype,
        domain=f"{'(0' if open_lo else '[0'}, {hi:.3g}] (a refractive index)",
    )


def fresnel_schlick(cos, f0):
    """Schlick's Fresnel F = F0 + (1 - F0) (1 - cos)^5; cos in [0, 1], F0 in [0, 1] (scalar or an array, e.g.
    RGB: numpy broadcasting).  float32 when every argument is float32, else float64."""
    dtype = working_dtype(cos, f0)
    c = _cosine(cos, dtype)
    f0 = real_array(f0, "f0", 0.0, 1.0, dtype=dtype)
    return np.asarray(fresnel.fresnel_schlick(c, f0), dtype=dtype)


def fresnel_conductor(cos, eta, k):
    """Exact unpolarised Fresnel reflectance of a conductor of relative index eta + i k (docs/microfacet_energy_derivation.md:
    R_s, R_p in Born and Wolf's real form, PBRT-v3's FrConductor; :func:`fitlab.physics.fresnel.fresnel_conductor`).
    cos in [0, 1]; eta > 0, k >= 0 (k = 0: a dielectric, with total internal reflection for eta < 1); numpy
    broadcasting, so eta and k may be RGB arrays.  F(1) = ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2), F(0) = 1 (0 for
    the matched eta = 1, k = 0).  float32 when every argument is float32, else float64."""
    dtype = working_dtype(cos, eta, k)
    c = _cosine(cos, dtype)
    eta = _index(eta, "eta", dtype, True)
    k = _index(k, "k", dtype, False)
    c, eta, k = np.broadcast_arrays(c, eta, k)
    return np.asarray(fresnel.fresnel_conductor(c, eta, k), dtype=dtype)


def fresnel_dielectric(cos, eta):
    """Exact unpolarised Fresnel reflectance at a dielectric interface of relative index eta = n_t / n_i > 0,
    seen from the incident side: cos_t = sqrt(1 - (1 - cos^2) / eta^2), F = 1 beyond the critical angle
    (eta < 1).  cos in [0, 1]; numpy broadcasting.  The conductor's k = 0 in another form
    (:func:`fitlab.physics.fresnel.fresnel_dielectric`).  float32 when every argument is float32, else float64."""
    dtype = working_dtype(cos, eta)
    c = _cosine(cos, dtype)
    eta = _index(eta, "eta", dtype, True)
    c, eta = np.broadcast_arrays(c, eta)
    return np.asarray(fresnel.fresnel_dielectric(c, eta), dtype=dtype)


def fresnel_dielectric_transmittance(cos_i, cos_t, eta):
    """1 - F at a dielectric interface of relative index eta = n_t / n_i > 0 for a refraction whose both
    cosines are known (cos_i on the incident side, cos_t on the transmitted side, both in [0, 1], with
    eta sin_t = sin_i): :func:`fitlab.physics.fresnel.fresnel_dielectric_transmittance`, equal to
    ``1 - fresnel_dielectric(cos_i, eta)`` where cos_t is Snell's and without its cancellation at grazing and
    near the critical angle; a BTDF whose half vector gives both cosines uses this.  0 where either cosine is 0.
    numpy broadcasting; float32 when every argument is float32."""
    dtype = working_dtype(cos_i, cos_t, eta)
    c_i, c_t = _cosine(cos_i, dtype), _cosine(cos_t, dtype)
    eta = _index(eta, "eta", dtype, True)
    return np.asarray(fresnel.fresnel_dielectric_transmittance(c_i, c_t, eta), dtype=dtype)


# -- average Fresnel ------------------------------------------------------------------------------------
def average_fresnel(fresnel, breakpoints=()) -> float:
    """F_avg = 2 int_0^1 F(mu) mu dmu of a function ``fresnel`` (1-D float64 arrays of cos in [0, 1] in, arrays
    of their shape out), by the adaptive Gauss-Legendre rule of docs/microfacet_energy_derivation.md (1e-12 or better).
    breakpoints: points of [0, 1] where F is not smooth (or nearly so), made panel edges, besides the kinks
    of a :class:`FresnelFactor`."""
    if not callable(fresnel):
        raise TypeError("fresnel must be a function of cos(theta) (arrays in, arrays out)")
    given = [float(b) for b in np.ravel(np.asarray(breakpoints, dtype=float))]
    inner = sorted({b for b in (*given, *kinks_of(fresnel)) if 0 < b < 1})
    edges = np.array([0.0, *inner, 1.0])
    x, w = gauss_legendre(_AVERAGE_NODES)
    n = x.size
    lo, hi = edges[:-1], edges[1:]
    parts = []
    for level in range(_AVERAGE_MAX_LEVELS + 1):
        if lo.size == 0:
            break
        h = hi - lo
        mid = lo + h / 2
        nodes = np.concatenate(
            (lo[:, None] + h[:, None] * x, lo[:, None] + (h / 2)[:, None] * x, mid[:, None] + (h / 2)[:, None] * x),
            axis=1,
        )
        values = np.asarray(fresnel(nodes.ravel()), dtype=float).reshape(nodes.shape) * 2 * nodes
        if not np.all(np.isfinite(values)):
            raise ValueError("fresnel returned a value that is not finite on [0, 1]")
        coarse = h * (values[:, :n] @ w)
        fine = (h / 2) * (values[:, n : 2 * n] @ w + values[:, 2 * n :] @ w)
        last = level == _AVERAGE_MAX_LEVELS or lo.size > _AVERAGE_MAX_PANELS
        done = (np.abs(fine - coarse) <= _AVERAGE_TOL) | last
        parts.append(fine[done])
        lo, hi = np.concatenate((lo[~done], mid[~done])), np.concatenate((mid[~done], hi[~done]))
    return float(np.sum(np.sort(np.concatenate(parts))))


def average_fresnel_schlick(f0):
    """F_avg of Schlick's Fresnel in closed form, (20 F0 + 1) / 21 (docs/microfacet_energy_derivation.md); F0 in [0, 1], any shape."""
    return fresnel.schlick_average(real_array(f0, "f0", 0.0, 1.0))


def _scalar_index(value, name, open_lo):
    if np.ndim(value) != 0:
        raise ValueError(
            f"{name} must be one number (one colour channel: its kinks are numbers), got shape {np.shape(value)}"
        )
    return float(_index(value, name, np.float64, open_lo))


def dielectric_factor(eta) -> FresnelFactor:
    """:func:`fresnel_dielectric` of one relative index eta > 0 as a :class:`FresnelFactor`, with its kink at the
    critical angle, cos = sqrt(1 - eta^2), when eta < 1 (the quadratures follow it there)."""
    e = _scalar_index(eta, "eta", True)
    return FresnelFactor(lambda c: fresnel_dielectric(c, e), fresnel.conductor_bend(e, 0.0))


def conductor_factor(eta, k) -> FresnelFactor:
    """:func:`fresnel_conductor` of one complex index eta + i k as a :class:`FresnelFactor`, with its bend where
    t0 = eta^2 - k^2 - (1 - cos^2) = 0 when that cosine lies in (0, 1) (a kink when k = 0)."""
    e, kk = _scalar_index(eta, "eta", True), _scalar_index(k, "k", False)
    return FresnelFactor(lambda c: fresnel_conductor(c, e, kk), fresnel.conductor_bend(e, kk))


def average_fresnel_conductor(eta, k):
    """F_avg of :func:`fresnel_conductor` by :func:`average_fresnel` (with the bend at t0 = 0 as a panel
    edge); eta > 0, k >= 0, broadcast (e.g. RGB); float64 of their broadcast shape."""
    eta = _index(eta, "eta", np.float64, True)
    k = _index(k, "k", np.float64, False)
    eta, k = np.broadcast_arrays(eta, k)
    out = np.empty(eta.shape)
    for idx in np.ndindex(eta.shape):
        e, kk = float(eta[idx]), float(k[idx])
        out[idx] = average_fresnel(lambda c, e=e, kk=kk: fresnel_conductor(c, e, kk), fresnel.conductor_bend(e, kk))
    return out


def average_fresnel_dielectric(eta):
    """F_avg of :func:`fresnel_dielectric` by :func:`average_fresnel` (with the critical angle as a panel
    edge when eta < 1); eta > 0, any shape; float64."""
    eta = _index(eta, "eta", np.float64, True)
    out = np.empty(eta.shape)
    for idx in np.ndindex(eta.shape):
        e = float(eta[idx])
        out[idx] = average_fresnel(lambda c, e=e: fresnel_dielectric(c, e), fresnel.conductor_bend(e, 0.0))
    return out


# -- the coloured compensation --------------------------------------------------------------------------
def fresnel_compensation_factor(f_avg, e_avg, form: str = "kulla_conti"):
    """The factor f_add of the coloured lobe f_ms_F = f_add f_ms (docs/microfacet_energy_derivation.md):

    "kulla_conti": F_avg^2 E_avg / (1 - F_avg (1 - E_avg)); "unweighted_first": F_avg E_avg / (1 - F_avg
    (1 - E_avg)).  f_avg, e_avg in [0, 1], broadcast (f_avg may be RGB); the denominator is formed as
    (1 - F_avg) + F_avg E_avg, so F_avg = 1 gives exactly 1 (also at E_avg = 0, the limit along F_avg = 1;
    the series does not converge there).  In [0, F_avg^2] (resp. [0, F_avg])."""
    form = choice(form, "form", COMPENSATION_FORMS)
    f_avg = real_array(f_avg, "f_avg", 0.0, 1.0)
    e_avg = real_array(e_avg, "e_avg", 0.0, 1.0)
    den = (1 - f_avg) + f_avg * e_avg
    num = f_avg * e_avg * (f_avg if form == "kulla_conti" else 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(f_avg == 1, 1.0, num / np.where(den > 0, den, 1))


def fresnel_multiple_scattering_brdf(mu_o, mu_i, alpha, f_avg, model: str = "ggx_separable", form: str = "kulla_conti"):
    """The coloured compensation lobe f_ms_F = f_add(F_avg, E_avg(alpha)) f_ms(mu_o, mu_i, alpha) with the F = 1
    lobe of :func:`multiple_scattering_brdf` and E_avg of ``model``.  mu_o, mu_i, alpha in [0, 1], f_avg in
    [0, 1] (e.g. :func:`average_fresnel_schlick`), all broadcast by numpy's rules (for RGB against arrays of
    directions give the directions a trailing axis).  Reciprocal, independent of the azimuth."""
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    f_add = fresnel_compensation_factor(f_avg, average_albedo(alpha, model), form)
    return f_add * multiple_scattering_brdf(mu_o, mu_i, alpha, model)


@lru_cache(maxsize=64)
def _albedo_at_average_nodes(alpha: float, model: str) -> np.ndarray:
    """E (F = 1) at the nodes of :func:`average_nodes`, read-only (every coloured lobe of a model and alpha
    integrates against the same values)."""
    nodes, _ = average_nodes()
    e = directional_albedo(nodes, alpha, model)
    e.setflags(write=False)
    return e


def _f_avg_of(fresnel, f_avg):
    return average_fresnel(fresnel) if f_avg is None else float(real_array(f_avg, "f_avg", 0.0, 1.0))


def compensated_fresnel_albedo(
    mu_o, alpha, fresnel, model: str = "ggx_separable", f_avg=None, form: str = "kulla_conti"
):
    """The albedo of f_F + f_ms_F: E_F(mu_o) + int f_ms_F(mu_o, mu_i) mu_i dw_i, E_F by
    :func:`directional_albedo` with ``fresnel`` and the lobe integrated numerically over mu_i (the rule of
    :func:`compensated_albedo`), not replaced by its value f_add (1 - E(mu_o)).

    fresnel: a function F(cos theta_d) with scalar parameters (one colour channel); f_avg: its F_avg, computed
    by :func:`average_fresnel` when None.  mu_o, alpha in [0, 1], broadcast; GGX models.  With F = 1 this is
    :func:`compensated_albedo` (1 at every mu_o)."""
    get_model(model)
    form = choice(form, "form", COMPENSATION_FORMS)
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    mu_o, alpha = np.broadcast_arrays(mu_o, alpha)
    f_avg = _f_avg_of(fresnel, f_avg)
    nodes, weights = average_nodes()
    out = np.empty(mu_o.shape)
    for a in np.unique(alpha):
        sel = alpha == a
        e_nodes = _albedo_at_average_nodes(float(a), model)
        e_o = directional_albedo(mu_o[sel], a, model)
        e_f = directional_albedo(mu_o[sel], a, model, fresnel=fresnel)
        e_avg = average_albedo(a, model)
        lobe = fresnel_compensation_factor(f_avg, e_avg, form) * _lobe(e_o[:, None], e_nodes[None, :], e_avg)
        out[sel] = e_f + 2 * np.pi * (lobe @ (weights * nodes))
    return out


# -- the first reflection and the random-walk references ------------------------------------------------
_CHUNK = 200_000


def _visible_fresnel_chunk(mu_o, alpha, fresnel, rule=HALF_VECTOR):
    s_o = np.sqrt((1 - mu_o) * (1 + mu_o))
    log_a = np.log(alpha)
    tau_hi = rule.tau_hi_margin - log_a
    with np.errstate(divide="ignore"):
        tau_c = np.log(mu_o) - np.log(s_o) - log_a  # tan(theta_c) = mu_o / s_o
    tau_c = np.clip(tau_c, rule.tau_lo, tau_hi)
    kinks = kinks_of(fresnel)
    # the kink curves w_o . m = c_k > 0 stay away from the end phi_end (w_o . m = 0) of panel 2
    kink_taus = _kink_taus(mu_o, alpha, kinks, horizon=False) if kinks else None
    (tau_a, w_a), (tau_b, w_b) = _tau_rule(np.full(mu_o.shape, rule.tau_lo), tau_c, tau_hi, rule, kink_taus)
    mu_o_, s_o_ = mu_o[:, None, None], s_o[:, None, None]
    x_phi, w_phi = _phi_unit_rule(rule.panels_phi, rule.nodes_phi, rule.ratio)

    def panel(tau, w_tau, full: bool):
        t = np.exp(tau)[..., None]
        tan_m = alpha[:, None, None] * t
        dxi = 2 / (t + 1 / t) ** 2
        if full:
            phi_end = np.pi
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                threshold = np.where(s_o_ > 0, -mu_o_ / (s_o_ * tan_m), -1.0)
            phi_end = np.arccos(np.clip(np.nan_to_num(threshold, nan=-1.0), -1, 1))
        if kinks:
            phi, w_phi_ = _split_rule(
                phi_end,
                _kink_azimuths(mu_o_, s_o_, tan_m, kinks),
                rule.panels_phi,
                rule.nodes_phi,
                rule.ratio,
                False,
                True,
            )
        else:
            phi = phi_end * x_phi
        om_over_mu_m = np.maximum(mu_o_ + s_o_ * tan_m * np.cos(phi), 0)  # (w_o . m) / mu_m
        cos_d = np.minimum(om_over_mu_m / np.sqrt(1 + tan_m * tan_m), 1)
        value = om_over_mu_m if fresnel is None else om_over_mu_m * fresnel(cos_d)
        inner = np.sum(value * w_phi_, axis=-1) * dxi[..., 0] if kinks else (value @ w_phi) * (phi_end * dxi)[..., 0]
        return np.sum(inner * w_tau, axis=1)

    root = ggx_root_term(mu_o, alpha * alpha)
    return 2 * (panel(tau_a, w_a, True) + panel(tau_b, w_b, False)) / (np.pi * (mu_o + root))


def visible_fresnel(mu_o, alpha, fresnel=None):
    """R(mu_o) = int D_o(m) F(w_o . m) dw_m: the Fresnel factor averaged over GGX's visible normals
    D_o = G1(mu_o) max(0, w_o . m) D(m) / mu_o, i.e. what the first reflection reflects in all, before
    masking decides whether it leaves (docs/microfacet_energy_derivation.md).  The same for both Smith forms (G1 is).

    mu_o, alpha in [0, 1], broadcast; fresnel as for :func:`directional_albedo` (None: F = 1, R = 1 exactly,
    to the quadrature's 1e-10 or better); alpha = 0 (the mirror) gives F(mu_o)."""
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    if fresnel is not None and not callable(fresnel):
        raise TypeError("fresnel must be a function of cos(theta_d) = w_o . h (arrays in, arrays out)")
    mu_o, alpha = np.broadcast_arrays(mu_o, alpha)
    mu, a = mu_o.ravel().copy(), alpha.ravel().copy()
    out = np.empty(mu.shape)
    mirror = a == 0
    out[mirror] = 1.0 if fresnel is None else fresnel(mu[mirror])
    rough = np.flatnonzero(~mirror)
    rule = HALF_VECTOR
    step = max(1, _CHUNK // _half_vector_nodes(rule, len(kinks_of(fresnel))))
    for start in range(0, rough.size, step):
        sl = rough[start : start + step]
        out[sl] = _visible_fresnel_chunk(mu[sl], a[sl], fresnel)
    return out.reshape(mu_o.shape)


def random_walk_albedo(mu_o, alpha, fresnel, model: str = "ggx_separable", f_avg=None, first_bounce: str = "exact"):
    """Total albedo from mu_o of the inter-reflection model of docs/microfacet_energy_derivation.md, a reference for the
    compensated albedo (:func:`compensated_fresnel_albedo`); g = F_avg E_avg / (1 - F_avg (1 - E_avg)) is the
    fraction of the energy meeting the microsurface a second time that eventually leaves (A2-A3):

    first_bounce "exact": E_F(mu_o) + g (R(mu_o) - E_F(mu_o)), R of :func:`visible_fresnel` (A2-A3 for the
    second and later reflections only); "averaged": F_avg E(mu_o) + g F_avg (1 - E(mu_o)) (A1-A3 throughout;
    its cosine-weighted average is F_avg E_avg / (1 - F_avg (1 - E_avg))).  fresnel: F(cos theta_d) with
    scalar parameters; f_avg its F_avg (computed when None).  mu_o, alpha in [0, 1], broadcast; GGX models.
    Both are 1 at F = 1."""
    get_model(model)
    first_bounce = choice(first_bounce, "first_bounce", FIRST_BOUNCE)
    mu_o = real_array(mu_o, "mu_o", 0.0, 1.0)
    alpha = real_array(alpha, "alpha", 0.0, 1.0)
    mu_o, alpha = np.broadcast_arrays(mu_o, alpha)
    f_avg = _f_avg_of(fresnel, f_avg)
    e_avg = average_albedo(alpha, model)
    den = (1 - f_avg) + f_avg * e_avg
    g = np.where(f_avg == 1, 1.0, f_avg * e_avg / np.where(den > 0, den, 1))
    if first_bounce == "averaged":
        e = directional_albedo(mu_o, alpha, model)
        return f_avg * e + g * f_avg * (1 - e)
    e_f = directional_albedo(mu_o, alpha, model, fresnel=fresnel)
    return e_f + g * (visible_fresnel(mu_o, alpha, fresnel) - e_f)
