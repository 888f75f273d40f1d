r"""The approximations of Fresnel reflectance (RTR4 section 9.5), each a form of every Fresnel target, with its
published construction from the material's exact reflectance as a preset.

With m = 1 - mu:

* ``schlick`` (RTR4 eq. 9.16): F0 + (1 - F0) m^5.  Preset ``normal``: F0 = F(mu = 1) of the channel.
* ``schlick_generalised`` (RTR4 eq. 9.18): F0 + (F90 - F0) m^(1/p).  Preset ``schlick``: F(1), 1, 1/5.
* ``lazanyi`` (Lazanyi and Szirmay-Kalos 2005, the error term as Hoffman writes it): F0 + (1 - F0) m^5 -
  a mu m^alpha.  Preset ``f82``: the F82-tint construction below (alpha = 6).
* ``f82_tint`` (Hoffman 2019, "Generalization of Adobe's Fresnel Model"; OpenPBR's and the Adobe Standard
  Material's metal): Schlick - a mu m^6 with a = S(mu_bar) (1 - tint) / (mu_bar (1 - mu_bar)^6), S the
  Schlick term and mu_bar = 1/7 (82 degrees), so that F(mu_bar) = tint S(mu_bar).  Preset ``f82``: F0 = F(1),
  tint = F(mu_bar) / S(mu_bar) of the exact F: the form then meets the exact F at 0, 82 and 90 degrees.
* ``gulbrandsen`` (Gulbrandsen 2014, "Artist Friendly Metallic Fresnel"): the exact conductor reflectance
  of the index n(r, g) + i k(r, g) of :func:`fitlab.families.fresnel.exact.gulbrandsen_index`
  (reflectivity r, edge tint g), in Born and Wolf's real form (docs/fresnel.md).  Preset ``gulbrandsen``:
  r = F(1) of the channel, as an artist picks the colour at normal incidence (at most :data:`R_MAX`: the
  map needs r < 1, where gold's red channel, out of sRGB's gamut, has F(1) = 1.02), and g of Gulbrandsen's
  inverse map of the measured n, k at the channel's wavelength
  (:func:`fitlab.families.fresnel.exact.channel_wavelength`), clipped to [0, 1].

Every form is exact at mu = 0 (F = 1) but the generalised Schlick with F90 != 1; the forms are fitted in
absolute error (:mod:`..targets`).  ``fitlab refit --all`` refits each target's default form only
(:func:`fitlab.families.fresnel.targets.default_form`); docs/fresnel.md is where every pair is fitted.
"""

from __future__ import annotations

from functools import cache

import numpy as np
import sympy as sp

from fitlab.families.fresnel.exact import (
    CHANNELS,
    MATERIALS,
    channel_wavelength,
    get_material,
    gulbrandsen_parameters,
    reflectance,
)
from fitlab.families.fresnel.targets import MU, default_form, target_name
from fitlab.forms import Form, safe_pow

__all__ = ["FORMS", "FORM_NAMES", "MU_BAR", "R_MAX", "construction", "conductor_reflectance", "schlick_term"]

#: Hoffman's F82 angle, as a cosine
MU_BAR = sp.Rational(1, 7)
#: the largest r of the gulbrandsen preset (its map divides by 1 - sqrt r)
R_MAX = 0.999
FORM_NAMES = ("schlick", "schlick_generalised", "lazanyi", "f82_tint", "gulbrandsen")

_mu = MU.symbol
F0, F90, p, a, alpha, tint, r, g = sp.symbols("F0 F90 p a alpha tint r g", real=True)


def schlick_term(f0, mu):
    """Schlick's F0 + (1 - F0)(1 - mu)^5."""
    return f0 + (1 - f0) * (1 - mu) ** 5


def conductor_reflectance(mu, n, k2):
    """Unpolarised F of the index n + i k (k^2 = k2 >= 0) against air at cos theta = mu, in the real form:
    with s2 = 1 - mu^2, t0 = n^2 - k^2 - s2, z = sqrt(t0^2 + 4 n^2 k^2) = a^2 + b^2, a = sqrt((z + t0)/2),
    R_s = (z - 2 a mu + mu^2)/(z + 2 a mu + mu^2), R_p = R_s (z mu^2 - 2 a mu s2 + s2^2)/(z mu^2 + 2 a mu s2
    + s2^2), F = (R_s + R_p)/2."""
    s2 = 1 - mu**2
    t0 = n**2 - k2 - s2
    z = sp.sqrt(t0**2 + 4 * n**2 * k2)
    a_ = sp.sqrt((z + t0) / 2)
    r_s = (z - 2 * a_ * mu + mu**2) / (z + 2 * a_ * mu + mu**2)
    r_p = r_s * (z * mu**2 - 2 * a_ * mu * s2 + s2**2) / (z * mu**2 + 2 * a_ * mu * s2 + s2**2)
    return (r_s + r_p) / 2


def _gulbrandsen_expr():
    sr = sp.sqrt(r)
    n = g * (1 - r) / (1 + r) + (1 - g) * (1 + sr) / (1 - sr)
    # k^2 >= 0 for g in [0, 1]; clamped at 0 beyond, where a fit's step may stray.  safe_pow(x, 1) is max(0, x)
    # in every back end; a sympy Max would be 60 Max objects in the fit file's expanded expression, each of which
    # sympy orders against 0 when the file is read (20 times the cost of reading it)
    k2 = safe_pow((r * (n + 1) ** 2 - (n - 1) ** 2) / (1 - r), 1)
    return conductor_reflectance(_mu, n, k2)


def _f82_a(f0, t):
    return schlick_term(f0, MU_BAR) * (1 - t) / (MU_BAR * (1 - MU_BAR) ** 6)


EXPRESSIONS = {
    "schlick": ((F0,), schlick_term(F0, _mu)),
    "schlick_generalised": ((F0, F90, p), F0 + (F90 - F0) * safe_pow(1 - _mu, 1 / p)),
    "lazanyi": ((F0, a, alpha), schlick_term(F0, _mu) - a * _mu * safe_pow(1 - _mu, alpha)),
    "f82_tint": ((F0, tint), schlick_term(F0, _mu) - _f82_a(F0, tint) * _mu * (1 - _mu) ** 6),
    "gulbrandsen": ((r, g), _gulbrandsen_expr()),
}


@cache
def construction(material: str, channel: str) -> dict[str, float]:
    """The published constructions from the exact F of a channel: F0 = F(1), F82's tint, Gulbrandsen's r and
    g (of the measured n, k at the channel's wavelength), and a of the F82 term."""
    c = CHANNELS.index(channel)
    f0, f_bar = (float(v) for v in reflectance(material, np.array([1.0, float(MU_BAR)]))[:, c])
    s_bar = schlick_term(f0, float(MU_BAR))
    t = f_bar / s_bar
    eta = get_material(material).index(np.array([channel_wavelength("srgb", c)]))[0]
    _, gg = gulbrandsen_parameters(eta.real, eta.imag)
    return {"F0": f0, "tint": t, "a": float(_f82_a(sp.Float(f0), sp.Float(t))), "r": min(f0, R_MAX),
            "g": float(np.clip(gg, 0.0, 1.0))}


def _presets(name: str, facts: dict) -> dict:
    f0 = facts["F0"]
    return {
        "schlick": {"normal": {"F0": f0}},
        "schlick_generalised": {"schlick": {"F0": f0, "F90": 1.0, "p": 0.2}},
        "lazanyi": {"f82": {"F0": f0, "a": facts["a"], "alpha": 6.0}},
        "f82_tint": {"f82": {"F0": f0, "tint": facts["tint"]}},
        "gulbrandsen": {"gulbrandsen": {"r": facts["r"], "g": facts["g"]}},
    }[name]


_DESCRIPTIONS = {
    "schlick": "Schlick (RTR4 eq. 9.16): F0 + (1 - F0)(1 - mu)^5",
    "schlick_generalised": "generalised Schlick (RTR4 eq. 9.18): F0 + (F90 - F0)(1 - mu)^(1/p)",
    "lazanyi": "Lazanyi-Schlick: Schlick - a mu (1 - mu)^alpha",
    "f82_tint": "Hoffman's F82-tint: Schlick - a(F0, tint) mu (1 - mu)^6, F(82 deg) = tint Schlick(82 deg)",
    "gulbrandsen": "Gulbrandsen's artist-friendly metallic Fresnel: exact F of n(r, g) + i k(r, g)",
}


def _forms(material: str, channel: str) -> tuple[Form, ...]:
    target = target_name(material, channel)
    facts = construction(material, channel)
    default = default_form(material, channel)
    return tuple(
        Form(target, name, ("mu",), tuple(str(s) for s in params), expr, presets=_presets(name, facts),
             description=_DESCRIPTIONS[name], refit_by_default=name == default)
        for name, (params, expr) in EXPRESSIONS.items()
    )


FORMS = tuple(f for m in MATERIALS for c in CHANNELS for f in _forms(m, c))
