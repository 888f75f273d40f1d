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
  of the index n(r, g) + i k(r, g) of :func:`fitlab.physics.fresnel.gulbrandsen_index` (reflectivity r, edge tint
  g), :func:`fitlab.physics.fresnel.fresnel_conductor` (docs/fresnel.md).  Preset ``gulbrandsen``:
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
from fitlab.forms import Form
from fitlab.physics import fresnel

__all__ = ["FORMS", "FORM_NAMES", "MU_BAR", "R_MAX", "construction"]

#: Hoffman's F82 angle, as a cosine
MU_BAR = sp.Rational(*fresnel.F82_COSINE)
#: the largest r of the gulbrandsen preset (its map divides by 1 - sqrt r)
R_MAX = 0.999
FORM_NAMES = ("schlick", "schlick_generalised", "lazanyi", "f82_tint", "gulbrandsen")

_mu = MU.symbol
F0, F90, p, a, alpha, tint, r, g = sp.symbols("F0 F90 p a alpha tint r g", real=True)


def _gulbrandsen_expr():
    # k^2 >= 0 for g in [0, 1]; clamped at 0 beyond, where a fit's step may stray (as safe_pow(x, 1): a sympy Max
    # would be objects that sympy orders against 0 when the fit file is read, 20 times the cost of reading it)
    n, k = fresnel.gulbrandsen_index(r, g)
    return fresnel.fresnel_conductor(_mu, n, k)


EXPRESSIONS = {
    "schlick": ((F0,), fresnel.fresnel_schlick(_mu, F0)),
    "schlick_generalised": ((F0, F90, p), fresnel.schlick_generalised(_mu, F0, F90, p)),
    "lazanyi": ((F0, a, alpha), fresnel.lazanyi(_mu, F0, a, alpha)),
    "f82_tint": ((F0, tint), fresnel.f82_tint(_mu, F0, tint)),
    "gulbrandsen": ((r, g), _gulbrandsen_expr()),
}


@cache
def construction(material: str, channel: str) -> dict[str, float]:
    """The published constructions from the exact F of a channel: F0 = F(1), F82's tint, Gulbrandsen's r and
    g (of the measured n, k at the channel's wavelength), and a of the F82 term."""
    c = CHANNELS.index(channel)
    f0, f_bar = (float(v) for v in reflectance(material, np.array([1.0, float(MU_BAR)]))[:, c])
    s_bar = fresnel.fresnel_schlick(float(MU_BAR), f0)
    t = f_bar / s_bar
    eta = get_material(material).index(np.array([channel_wavelength("srgb", c)]))[0]
    _, gg = gulbrandsen_parameters(eta.real, eta.imag)
    a_ = float(fresnel.f82_tint_coefficient(sp.Float(f0), sp.Float(t)))
    return {"F0": f0, "tint": t, "a": a_, "r": min(f0, R_MAX), "g": float(np.clip(gg, 0.0, 1.0))}


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
        Form(
            target,
            name,
            ("mu",),
            tuple(str(s) for s in params),
            expr,
            presets=_presets(name, facts),
            description=_DESCRIPTIONS[name],
            refit_by_default=name == default,
        )
        for name, (params, expr) in EXPRESSIONS.items()
    )


FORMS = tuple(f for m in MATERIALS for c in CHANNELS for f in _forms(m, c))
