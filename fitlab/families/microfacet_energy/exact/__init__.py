r"""Exact engine of the microfacet_energy family: directional and average albedos of single-scattering
BRDFs and their Kulla-Conti energy compensation, with F = 1 (a white furnace), in numpy and scipy.

What is implemented (the source is the blog article on multiple-scattering BRDFs whose section
"Energy Compensation" follows Kelemen and Szirmay-Kalos 2001 and Kulla and Conti 2017, and RTR4 ch. 9
for the height-correlated Smith function; nothing here reads those texts at run time):

* BRDFs (:func:`brdf`, :data:`MODELS`): GGX with separable Smith masking-shadowing, exactly the
  blog's f = D / ((mu_i + S_i)(mu_o + S_o)), S = sqrt(alpha^2 + (1 - alpha^2) mu^2); GGX with
  height-correlated Smith G2 = 1 / (1 + Lambda_i + Lambda_o) (RTR4 eq. 9.31); Oren-Nayar as the blog
  writes it (A with 0.33 or the footnote's 0.57, sigma = (pi/2) alpha, the exact cos(phi) or the
  HLSL's unnormalised gamma).  alpha in [0, 1] is the GGX parameter itself (the blog uses alpha in D,
  not roughness^2); phi = pi is the mirror configuration.  Conventions: :mod:`.ggx`, :mod:`.oren_nayar`.
* E(mu, alpha) = int f(w_o, w_i) mu_i dw_i (:func:`directional_albedo`), by two independent routes
  (:mod:`.albedo`): for GGX over the half vector with the GGX distribution's own change of variable
  (which follows the peak down to alpha = 1e-6) and over the incident direction on graded panels; for
  Oren-Nayar a closed form and a 2-D quadrature.  The routes agree to 1e-9 or better on [0, 1] x
  [1e-5, 1] (GGX) and [0, 1]^2 (Oren-Nayar).  alpha = 0 is defined as the mirror: E = 1 at every mu.
* E_avg(alpha) (:func:`average_albedo`) in both normalisations: Kulla-Conti's
  E_avg = 2 int_0^1 E mu dmu in [0, 1], with f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)); the
  blog's int E mu dw = 2 pi int_0^1 E mu dmu = pi E_avg in [0, pi], with f_ms = (1 - E)(1 - E) / (pi -
  E_avg_blog).  The two f_ms are one function (:func:`multiple_scattering_brdf`).

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.exact``."""

from pathlib import Path

from fitlab import physics
from fitlab.families.microfacet_energy.exact.albedo import CONVENTIONS, METHODS, average_albedo, directional_albedo
from fitlab.families.microfacet_energy.exact.compensation import (
    compensated_albedo,
    crossover_alpha,
    energy_integrals,
    multiple_scattering_brdf,
)
from fitlab.families.microfacet_energy.exact.fresnel import (
    COMPENSATION_FORMS,
    FIRST_BOUNCE,
    average_fresnel,
    average_fresnel_conductor,
    average_fresnel_dielectric,
    average_fresnel_schlick,
    compensated_fresnel_albedo,
    conductor_factor,
    dielectric_factor,
    fresnel_compensation_factor,
    fresnel_conductor,
    fresnel_dielectric,
    fresnel_dielectric_transmittance,
    fresnel_multiple_scattering_brdf,
    fresnel_schlick,
    random_walk_albedo,
    visible_fresnel,
)
from fitlab.families.microfacet_energy.exact.fresnel_factor import FresnelFactor
from fitlab.families.microfacet_energy.exact.ggx import SMITH, ggx_brdf, ggx_ndf, smith_g1, smith_g2, smith_lambda
from fitlab.families.microfacet_energy.exact.models import (
    GGX_MODELS,
    MODEL_NAMES,
    MODELS,
    OREN_NAYAR_MODELS,
    Model,
    brdf,
    get_model,
)
from fitlab.families.microfacet_energy.exact.oren_nayar import (
    A_CONSTANTS,
    AZIMUTH,
    oren_nayar_brdf,
    oren_nayar_coefficients,
)
from fitlab.families.microfacet_energy.exact.split_sums import schlick_weight, split_sum

#: the engine's source files, part of the key of every cached exact value (fitlab.cache.cached_arrays): editing
#: any of them recomputes what was cached
SOURCES = (
    *sorted(Path(__file__).resolve().parent.glob("*.py")),
    *physics.sources("fresnel", "microfacet", "oren_nayar"),
)

__all__ = [
    "SOURCES",
    "A_CONSTANTS",
    "AZIMUTH",
    "COMPENSATION_FORMS",
    "CONVENTIONS",
    "FIRST_BOUNCE",
    "FresnelFactor",
    "GGX_MODELS",
    "METHODS",
    "MODEL_NAMES",
    "MODELS",
    "Model",
    "OREN_NAYAR_MODELS",
    "SMITH",
    "average_albedo",
    "average_fresnel",
    "average_fresnel_conductor",
    "average_fresnel_dielectric",
    "average_fresnel_schlick",
    "brdf",
    "compensated_albedo",
    "compensated_fresnel_albedo",
    "conductor_factor",
    "crossover_alpha",
    "dielectric_factor",
    "directional_albedo",
    "energy_integrals",
    "fresnel_compensation_factor",
    "fresnel_conductor",
    "fresnel_dielectric",
    "fresnel_dielectric_transmittance",
    "fresnel_multiple_scattering_brdf",
    "fresnel_schlick",
    "get_model",
    "ggx_brdf",
    "ggx_ndf",
    "multiple_scattering_brdf",
    "oren_nayar_brdf",
    "oren_nayar_coefficients",
    "random_walk_albedo",
    "schlick_weight",
    "smith_g1",
    "smith_g2",
    "smith_lambda",
    "split_sum",
    "visible_fresnel",
]
