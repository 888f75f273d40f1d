r"""The targets of the Fresnel family: the reflectance F_c(mu) of one material in one channel of linear sRGB,
named ``F_<material>_<channel>`` (``F_cu_r``: copper, red), mu = cos(theta) in [0, 1].

Errors are absolute, |approx - F|: F is a fraction of energy, and the question an engine programmer asks
("how far is Schlick from copper at grazing?") is answered in those units, as RTR4's Figure 9.22 draws
it.  ACEScg values are computed by the same engine (:func:`fitlab.families.fresnel.exact.reflectance`) and
measured in docs/fresnel.md; the targets are the sRGB channels.

A channel's value can exceed 1 where the material's colour lies outside the gamut of the colour space:
gold's red channel reaches 1.022 at normal incidence in linear sRGB (the sRGB matching functions are
negative in places), which no approximation bounded by 1 (Gulbrandsen's) can follow.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from fitlab.core import Dataset, Input, Target
from fitlab.families.fresnel.exact import CHANNELS, MATERIALS, reflectance
from fitlab.families.fresnel.targets import datasets

__all__ = ["MU", "TARGETS", "DEFAULT_FORM", "OUT_OF_GAMUT_FORM", "PUBLISHED", "target_name", "default_form"]

MU = Input("mu", (0.0, 1.0), "cos theta: the cosine of the angle of incidence (w . h in a microfacet BRDF)")

#: (form, preset) of the published constructions each target's fit is compared with (:mod:`..forms`), by kind
#: of material: Gulbrandsen's map is a construction for metals (for a dielectric, g = 0, it is the exact F)
PUBLISHED = {
    "conductor": (("schlick", "normal"), ("f82_tint", "f82"), ("gulbrandsen", "gulbrandsen")),
    "dielectric": (("schlick", "normal"), ("f82_tint", "f82")),
}
#: the form ``fitlab refit`` fits when none is named: Gulbrandsen's, the exact reflectance of one index n + i k,
#: which refitted is the closest of the five to every channel it can reach (docs/fresnel.md: within 3e-3 of
#: every metal, the exact F of a constant-index dielectric); it is bounded by 1, so a channel whose F exceeds
#: 1 (a colour out of sRGB's gamut: gold's red) takes Lazanyi-Schlick, the closest there
DEFAULT_FORM = "gulbrandsen"
OUT_OF_GAMUT_FORM = "lazanyi"


def target_name(material: str, channel: str) -> str:
    return f"F_{material}_{channel}"


def default_form(material: str, channel: str) -> str:
    """:data:`DEFAULT_FORM`, or :data:`OUT_OF_GAMUT_FORM` where the channel's F(1) is at least 1."""
    f0 = float(reflectance(material, 1.0)[CHANNELS.index(channel)])
    return DEFAULT_FORM if f0 < 1.0 else OUT_OF_GAMUT_FORM


def _absolute(ds: Dataset) -> np.ndarray:
    return np.ones_like(ds.y)


def _target(material: str, channel: str) -> Target:
    name = target_name(material, channel)
    m = MATERIALS[material]
    return Target(
        name,
        f"F(mu) of {m.name}, channel {channel} of linear sRGB (D65, CIE 1931 2-degree observer); mu in [0, 1]",
        (MU,),
        default_form(material, channel),
        PUBLISHED[m.kind],
        partial(datasets.training, material, channel),
        partial(datasets.validation, material, channel),
        datasets.grid(material, channel),
        name,
        error_measure="absolute: |approx - exact| (a fraction of the energy)",
        scale=_absolute,
        note=f"index: {m.source}",
    )


TARGETS: dict[str, Target] = {target_name(m, c): _target(m, c) for m in MATERIALS for c in CHANNELS}
