r"""The lobe shapes, each written once in sympy: the blog's 5-parameter lobe and its relatives.

Geometry (the walk's frame, :mod:`..mc.walk`): z is the macro normal, light arrives from
w_i = (sqrt(1 - mu_i^2), 0, mu_i), and the outgoing direction is w_o = (s_o cos phi, s_o sin phi, mu_o),
s_o = sqrt(1 - mu_o^2): phi = 0 is the back-scattering side (towards the light), phi = pi the mirror side.
Every shape depends on phi through c = cos(phi) only (the lobes are even in phi), so the inputs of the
shapes are ``mu_o`` and ``cos_phi`` (and ``mu_i``, ``alpha`` where a parameter depends on them).

The blog's lobe (its section "Lobe Model"; docs/microsurface_lobes.md states every reading):

    f(w_o) = sigma ((1 - m) + m G1(mu_i) G1(mu_o)) N(z') L(w_o),
    N(z') = (2 + eta)/(2 pi) max(z', 0)^eta,     eta = 2^(10 (1 - alpha_l)) - 1,
    L(w_o) = 1 / sqrt(x'^2 + y'^2/(1 - a)^2 + z'^2/sigma_n^2),

Details: docs/blog_lobe_model.md, section ``fitlab.families.microfacet_energy.lobes.shapes``."""

from __future__ import annotations

import sympy as sp

from fitlab.forms import Form, safe_pow
from fitlab.forms.symbolic import symbols
from fitlab.physics.microfacet import beckmann_g1_rational, ggx_ndf

__all__ = [
    "mu_o",
    "cos_phi",
    "mu_i",
    "alpha",
    "SHAPE_INPUTS",
    "lobe_frame",
    "blog_lobe",
    "ggx_lobe",
    "tilted_lobe",
    "beckmann_g1",
    "eta_of_lobe_roughness",
    "PER_LOBE_FORMS",
    "per_lobe_form",
    "MU_FLOOR",
]

mu_o, cos_phi, mu_i, alpha = symbols(("mu_o", "cos_phi", "mu_i", "alpha"))
#: the inputs of every lobe shape, in argument order
SHAPE_INPUTS = ("mu_o", "cos_phi", "mu_i", "alpha")
#: cosines are floored here where they divide (G1 at grazing)
MU_FLOOR = sp.Float("1e-12")


def lobe_frame(theta_d) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """(x', y'^2, z') of w_o in the frame of the axis deviated by ``theta_d`` towards the light (module
    docstring); y' enters squared only, as s_o^2 (1 - cos^2 phi)."""
    s2 = 1 - mu_o**2
    s_o = sp.sqrt(sp.Max(s2, 0))
    c = cos_phi
    if theta_d == 0:
        return s_o * c, s2 * (1 - c**2), mu_o
    ct, st = sp.cos(theta_d), sp.sin(theta_d)
    return s_o * c * ct - mu_o * st, s2 * (1 - c**2), s_o * c * st + mu_o * ct


def beckmann_g1(mu) -> sp.Expr:
    """Smith masking of the Beckmann distribution at the surface's alpha, Walter et al.'s (2007) rational form
    (:func:`fitlab.physics.microfacet.beckmann_g1_rational`) in b = alpha tan(theta), finite at mu = 1 and mu = 0."""
    return beckmann_g1_rational(alpha * sp.sqrt(sp.Max(1 - mu**2, 0)) / sp.Max(mu, MU_FLOOR))


def eta_of_lobe_roughness(alpha_l) -> sp.Expr:
    """The blog's exponent of its lobe model, eta = 2^(10 (1 - alpha_l)) - 1."""
    return 2 ** (10 * (1 - alpha_l)) - 1


def blog_lobe(sigma, eta, sigma_n, theta_d=0, a=0, m=0) -> sp.Expr:
    """The blog's lobe f(w_o) (1/sr; docs/blog_lobe_model.md) with the exponent ``eta`` given directly."""
    n_of = lambda z: (2 + eta) / (2 * sp.pi) * safe_pow(z, eta)  # noqa: E731
    if theta_d == 0 and a == 0:
        # undeviated and isotropic: x'^2 + y'^2 = 1 - mu_o^2, no azimuth (the blog's final lobe)
        n = n_of(mu_o)
        radius = 1 / sp.sqrt(sp.Max(1 - mu_o**2, 0) + mu_o**2 / sigma_n**2)
        masking = 1 if m == 0 else (1 - m) + m * beckmann_g1(mu_i) * beckmann_g1(mu_o)
        return sigma * masking * n * radius
    x, y2, z = lobe_frame(theta_d)
    n = n_of(z)
    radius = 1 / sp.sqrt(x**2 + (y2 if a == 0 else y2 / (1 - a) ** 2) + z**2 / sigma_n**2)
    masking = 1 if m == 0 else (1 - m) + m * beckmann_g1(mu_i) * beckmann_g1(mu_o)
    return sigma * masking * n * radius


def tilted_lobe(sigma, eta, sigma_n, b, k) -> sp.Expr:
    r"""The better lobe: the blog's final lobe (undeviated, isotropic) times the azimuthal tilt
    exp(b s_o cos phi + k s_o^2 cos^2 phi), s_o = sqrt(1 - mu_o^2).  b < 0 leans the lobe to the mirror side
    (forward), b > 0 to the light (backward); k narrows (k > 0) or widens (k < 0) it in azimuth about the
    plane of incidence.  The tilt is 1 at the normal and at phi = +-pi/2, positive everywhere, and smooth, so
    that it bends a lobe whose exponent is near 0 (the simulated multiple-scattering lobes are broad), where
    the blog's deviation angle only cuts the lobe off at z' = 0."""
    s2 = sp.Max(1 - mu_o**2, 0)
    return blog_lobe(sigma, eta, sigma_n) * sp.exp(b * sp.sqrt(s2) * cos_phi + k * s2 * cos_phi**2)


def ggx_lobe(sigma, beta, sigma_n, theta_d=0) -> sp.Expr:
    r"""A GGX-shaped lobe about the axis deviated by ``theta_d``: the GGX distribution of width ``beta`` in
    z' (D(z') = beta^2 / (pi (z'^2 (beta^2 - 1) + 1)^2), normalised so that int D z' dw = 1 over the
    lobe's hemisphere), times the blog's normal flattening radius and the scale ``sigma``; nonzero on the
    whole hemisphere z' > -1 (its long tail reaches grazing, which a power cosine about the same axis
    cannot)."""
    x, y2, z = lobe_frame(theta_d)
    d = ggx_ndf(1 - z**2, z**2, beta**2)
    radius = 1 / sp.sqrt(x**2 + y2 + z**2 / sigma_n**2)
    return sigma * d * radius


_alpha_l, _sigma, _theta, _a, _sn, _m, _beta, _w, _b, _k = symbols(
    ("alpha_l", "sigma", "theta_d", "a", "sigma_n", "m", "beta", "w", "b", "k")
)

#: the per-lobe forms: (parameters, expression, start, fixed)
_FORMS = {
    "blog": (
        ("sigma", "theta_d", "a", "alpha_l", "sigma_n", "m"),
        blog_lobe(_sigma, eta_of_lobe_roughness(_alpha_l), _sn, _theta, _a, _m),
        {"sigma": 0.1, "theta_d": 0.0, "a": 0.0, "alpha_l": 0.9, "sigma_n": 1.0, "m": 0.0},
        {"m": 0.0},
        "the blog's lobe, every parameter free but the masking importance m (held at 0, as the blog found)",
    ),
    "blog_masking": (
        ("sigma", "theta_d", "a", "alpha_l", "sigma_n", "m"),
        blog_lobe(_sigma, eta_of_lobe_roughness(_alpha_l), _sn, _theta, _a, _m),
        {"sigma": 0.1, "theta_d": 0.0, "a": 0.0, "alpha_l": 0.9, "sigma_n": 1.0, "m": 0.0},
        {},
        "the blog's lobe with the masking importance m free too (to measure what it adds)",
    ),
    "blog_final": (
        ("sigma", "theta_d", "a", "alpha_l", "sigma_n", "m"),
        blog_lobe(_sigma, eta_of_lobe_roughness(_alpha_l), _sn, _theta, _a, _m),
        {"sigma": 0.1, "theta_d": 0.0, "a": 0.0, "alpha_l": 0.9, "sigma_n": 1.0, "m": 0.0},
        {"theta_d": 0.0, "a": 0.0, "m": 0.0},
        "the blog's final lobe: undeviated and isotropic (theta_d = a = m = 0), scale, exponent and "
        "normal flattening free",
    ),
    "tilted": (
        ("sigma", "alpha_l", "sigma_n", "b", "k"),
        tilted_lobe(_sigma, eta_of_lobe_roughness(_alpha_l), _sn, _b, _k),
        {"sigma": 0.1, "alpha_l": 0.9, "sigma_n": 1.0, "b": 0.0, "k": 0.0},
        {},
        "the blog's final lobe tilted in azimuth, times exp(b s_o cos phi + k s_o^2 cos^2 phi)",
    ),
    "blog_scale": (
        ("sigma", "theta_d", "a", "alpha_l", "sigma_n", "m"),
        blog_lobe(_sigma, eta_of_lobe_roughness(_alpha_l), _sn, _theta, _a, _m),
        {"sigma": 0.1, "theta_d": 0.0, "a": 0.0, "alpha_l": 0.9, "sigma_n": 1.0, "m": 0.0},
        {"theta_d": 0.0, "a": 0.0, "m": 0.0, "alpha_l": 0.9, "sigma_n": 1.0},
        "the blog's final lobe with its shape given (the order-2 lobe's, per lobe): the scale alone free",
    ),
    "ggx": (
        ("sigma", "theta_d", "beta", "sigma_n"),
        ggx_lobe(_sigma, _beta, _sn, _theta),
        {"sigma": 0.1, "theta_d": 0.0, "beta": 1.0, "sigma_n": 1.0},
        {},
        "a GGX-shaped lobe about a deviated axis, with the blog's normal flattening",
    ),
}


def per_lobe_form(name: str) -> Form:
    """The per-lobe form ``name`` (one of :data:`PER_LOBE_FORMS`), inputs :data:`SHAPE_INPUTS`."""
    params, expr, start, fixed, description = _FORMS[name]
    return Form(
        target="ms_lobe",
        name=name,
        inputs=SHAPE_INPUTS,
        params=params,
        expr=expr,
        start=start,
        fixed=fixed,
        description=description,
        refit_by_default=False,
    )


PER_LOBE_FORMS = tuple(_FORMS)
