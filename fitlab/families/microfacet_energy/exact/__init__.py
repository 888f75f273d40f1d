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
  not roughness^2); phi = pi is the mirror configuration.  Conventions: :mod:`._ggx`, :mod:`._oren_nayar`.
* E(mu, alpha) = int f(w_o, w_i) mu_i dw_i (:func:`directional_albedo`), by two independent routes
  (:mod:`._albedo`): for GGX over the half vector with the GGX distribution's own change of variable
  (which follows the peak down to alpha = 1e-6) and over the incident direction on graded panels; for
  Oren-Nayar a closed form and a 2-D quadrature.  The routes agree to 1e-9 or better on [0, 1] x
  [1e-5, 1] (GGX) and [0, 1]^2 (Oren-Nayar).  alpha = 0 is defined as the mirror: E = 1 at every mu.
* E_avg(alpha) (:func:`average_albedo`) in both normalisations: Kulla-Conti's
  E_avg = 2 int_0^1 E mu dmu in [0, 1], with f_ms = (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)); the
  blog's int E mu dw = 2 pi int_0^1 E mu dmu = pi E_avg in [0, pi], with f_ms = (1 - E)(1 - E) / (pi -
  E_avg_blog).  The two f_ms are one function (:func:`multiple_scattering_brdf`).

Properties the tests check, besides the two routes: E(mu, 1) in closed form for GGX (D = 1/pi at
alpha = 1): 2 (1 - ln 2) / (1 + mu) separable, 1 - mu ln((1 + mu)/mu) correlated; E(1, alpha) is the
same for both Smith forms (G1(w_o) = 1 at normal incidence); E(0, alpha) = 1 for height-correlated
Smith (at grazing every visible facet reflects upwards, and G2/G1(w_o) -> 1), while separable Smith
keeps a factor G1(w_i) and E(0, alpha) -> 0.93613 as alpha -> 0, so that its E is discontinuous at
the corner (mu, alpha) = (0, 0); Oren-Nayar has E = 1 at sigma = 0 (Lambert) in the convention stated
in :mod:`._oren_nayar` (the blog's displayed formula already holds the cos(theta_i) of the integrand).

The blog's statements, checked (tests/test_microfacet_energy_exact.py computes each):

* "the multiple scattering BRDF term becomes preponderant over the single scattering term when
  alpha > 0.8": in energy (the compensation's pi (1 - E_avg) against the single scattering's pi E_avg,
  the blog's blue and grey curves), GGX separable crosses at alpha = 0.7732 and GGX height-correlated
  at alpha = 0.8143 (:func:`crossover_alpha`); per direction (E(mu) = 1/2) at normal incidence both
  cross at alpha = 0.7045, at mu = 0.5 at 0.818 (separable) and 0.886 (correlated), and at grazing
  never.  So "about 0.8" holds for the average, a little lower for the blog's own (separable) GGX.
  Oren-Nayar never crosses (E >= A > 0.55).
* "the double integral of f + f_ms is always pi": yes, for every model and alpha, to rounding
  (:func:`energy_integrals`), and the furnace of f + f_ms is 1 at every mu_o (:func:`compensated_albedo`).

E_avg (Kulla-Conti normalisation) at alpha = 0.5 and 1: GGX separable 0.689403, 0.376635 (= 4 (1 - ln 2)^2);
GGX correlated 0.700240, 0.409137; Oren-Nayar 0.758285, 0.651877; with 0.57: 0.824154, 0.686724; gamma:
0.726644, 0.616895; gamma with 0.57: 0.792513, 0.651742.

Oren-Nayar as the blog writes it gains energy for small roughness: E(0, alpha) = A + B/2 > 1 for
alpha < 0.208 (0.33) and < 0.350 (0.57), by up to 1.5 % and 4.4 % (the gamma shortcut: < 0.154, < 0.289,
0.6 %, 2.9 %), so its compensation lobe is negative at grazing there; with the footnote's 0.57 even
E_avg > 1 for alpha < 0.0996, and f_ms is unbounded as alpha approaches that value (:mod:`._oren_nayar`).

Fresnel: :func:`directional_albedo` takes an optional F(w_o . h) applied inside either GGX route (the
two agree with it too); a F with kinks (total internal reflection: a dielectric with eta < 1) comes as a
:class:`FresnelFactor` naming them (:func:`dielectric_factor`, :func:`conductor_factor`), and the routes put
panel edges on the curves w_o . h = c_k (:mod:`._albedo`; a plain function is taken as smooth).
:func:`split_sum` (:mod:`._split_sum`): the split-sum integrals A, B of Karis's DFG table, E_F = F0 A + F90 B
under Schlick's F, by either route.  :mod:`._fresnel` gives the Fresnel factors (Schlick; the exact conductor,
eta + i k; the exact dielectric), their average F_avg = 2 int_0^1 F mu dmu (adaptive Gauss-Legendre, 1e-12; Schlick's (20 F0 + 1) / 21 in closed form) and Kulla-Conti's coloured compensation f_ms_F = f_add
f_ms, f_add = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), derived there from a stated model of the
inter-reflections (each later bounce cosine-distributed with escape E_avg, every reflection weighted by
F_avg), with the form that has one Fresnel factor fewer (F_avg E_avg / (...)) and why it is not the
default.  Exact: the lobe's albedo f_add (1 - E(mu_o)) per direction; the white furnace 1 at F = 1; the
cosine-averaged total E_F,avg + f_add (1 - E_avg), against the model's F_avg E_avg / (1 - F_avg (1 -
E_avg)) (the difference is E_F,avg - F_avg E_avg, the single scattering).  Approximate, and bounded there:
the Fresnel weight F_avg of the energy lost at the first reflection, against :func:`random_walk_albedo`,
which takes the first reflection exactly with :func:`visible_fresnel` (tests/test_microfacet_energy_fresnel.py).

Noticed in the blog on the way: its mu_h = (mu_o + mu_i) / sqrt(2 (1 + mu_o mu_i + (1 - mu_o^2)
(1 - mu_i^2) cos phi)) lacks the square root of (1 - mu_o^2)(1 - mu_i^2) (an error of print:
|w_o + w_i|^2 = 2 (1 + mu_o mu_i + s_o s_i cos phi); test_ggx_against_the_blog_formula_with_vectors); its
displayed Oren-Nayar f_r includes cos(theta_i) (an ambiguity: read literally with its
E = int f_r (w_i . n) dw_i, Lambert would give E = 2/3; the displayed expression is taken as
f cos(theta_i), as its HLSL returns it).
"""

from pathlib import Path

from fitlab import physics
from fitlab.families.microfacet_energy.exact._albedo import CONVENTIONS, METHODS, average_albedo, directional_albedo
from fitlab.families.microfacet_energy.exact._compensation import (
    compensated_albedo,
    crossover_alpha,
    energy_integrals,
    multiple_scattering_brdf,
)
from fitlab.families.microfacet_energy.exact._fresnel import (
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
from fitlab.families.microfacet_energy.exact._fresnel_factor import FresnelFactor
from fitlab.families.microfacet_energy.exact._ggx import SMITH, ggx_brdf, ggx_ndf, smith_g1, smith_g2, smith_lambda
from fitlab.families.microfacet_energy.exact._models import (
    GGX_MODELS,
    MODEL_NAMES,
    MODELS,
    OREN_NAYAR_MODELS,
    Model,
    brdf,
    get_model,
)
from fitlab.families.microfacet_energy.exact._oren_nayar import (
    A_CONSTANTS,
    AZIMUTH,
    oren_nayar_brdf,
    oren_nayar_coefficients,
)
from fitlab.families.microfacet_energy.exact._split_sum import schlick_weight, split_sum

#: the engine's source files, part of the key of every cached exact value (fitlab.cache.cached_arrays): editing
#: any of them recomputes what was cached
SOURCES = (*sorted(Path(__file__).resolve().parent.glob("*.py")),
           *physics.sources("fresnel", "microfacet", "oren_nayar"))

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
