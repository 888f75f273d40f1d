"""The single-scattering BRDFs whose energy is compensated, by name.

=====================  =========================================================================
name                   BRDF
=====================  =========================================================================
ggx_separable          GGX, separable Smith G2 = G1(mu_i) G1(mu_o): the blog's GGX
ggx_correlated         GGX, height-correlated Smith G2 = 1 / (1 + Lambda_i + Lambda_o) (RTR4 9.31)
oren_nayar             Oren-Nayar, A with 0.33, cos(phi): the blog's displayed formula
oren_nayar_057         Oren-Nayar, A with 0.57 (1992 footnote), cos(phi)
oren_nayar_gamma       Oren-Nayar, A with 0.33, the blog's HLSL shortcut gamma = s_o s_i cos(phi)
oren_nayar_gamma_057   Oren-Nayar, A with 0.57, gamma
=====================  =========================================================================

alpha in [0, 1] for all of them: the GGX roughness parameter, and sigma = (pi/2) alpha for Oren-Nayar.
"""

from __future__ import annotations

from dataclasses import dataclass

from fitlab.families.microfacet_energy.exact._checks import choice
from fitlab.families.microfacet_energy.exact.ggx import ggx_brdf
from fitlab.families.microfacet_energy.exact.oren_nayar import oren_nayar_brdf

__all__ = ["Model", "MODELS", "MODEL_NAMES", "GGX_MODELS", "OREN_NAYAR_MODELS", "get_model", "brdf"]


@dataclass(frozen=True)
class Model:
    """A named single-scattering BRDF: kind "ggx" (with ``smith``) or "oren_nayar" (with ``a_constant``
    and ``azimuth``), and one line saying what it is."""

    name: str
    kind: str
    description: str
    smith: str = ""
    a_constant: float = 0.0
    azimuth: str = ""


MODELS = {
    m.name: m
    for m in (
        Model("ggx_separable", "ggx", "GGX, separable Smith G1(mu_i) G1(mu_o) (the blog's GGX)", smith="separable"),
        Model(
            "ggx_correlated",
            "ggx",
            "GGX, height-correlated Smith 1/(1 + Lambda_i + Lambda_o) (RTR4 eq. 9.31)",
            smith="correlated",
        ),
        Model(
            "oren_nayar",
            "oren_nayar",
            "Oren-Nayar, A with 0.33, cos(phi) (the blog's formula)",
            a_constant=0.33,
            azimuth="cos_phi",
        ),
        Model(
            "oren_nayar_057",
            "oren_nayar",
            "Oren-Nayar, A with 0.57 (1992 footnote), cos(phi)",
            a_constant=0.57,
            azimuth="cos_phi",
        ),
        Model(
            "oren_nayar_gamma",
            "oren_nayar",
            "Oren-Nayar, A with 0.33, the blog's HLSL gamma = s_o s_i cos(phi)",
            a_constant=0.33,
            azimuth="gamma",
        ),
        Model(
            "oren_nayar_gamma_057",
            "oren_nayar",
            "Oren-Nayar, A with 0.57, the blog's HLSL gamma",
            a_constant=0.57,
            azimuth="gamma",
        ),
    )
}
MODEL_NAMES = tuple(MODELS)
GGX_MODELS = tuple(n for n, m in MODELS.items() if m.kind == "ggx")
OREN_NAYAR_MODELS = tuple(n for n, m in MODELS.items() if m.kind == "oren_nayar")


def get_model(name: str) -> Model:
    """The :class:`Model` called ``name`` (one of :data:`MODEL_NAMES`)."""
    return MODELS[choice(name, "model", MODEL_NAMES)]


def brdf(mu_o, mu_i, phi, alpha, model: str):
    """The BRDF of ``model`` (F = 1, rho = 1): :func:`ggx_brdf` (alpha in (0, 1]) or
    :func:`oren_nayar_brdf` (alpha in [0, 1]); phi = pi is the mirror configuration."""
    m = get_model(model)
    if m.kind == "ggx":
        return ggx_brdf(mu_o, mu_i, phi, alpha, smith=m.smith)
    return oren_nayar_brdf(mu_o, mu_i, phi, alpha, a_constant=m.a_constant, azimuth=m.azimuth)
