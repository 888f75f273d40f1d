"""The Lambert-sphere forms, each defined once as a sympy expression.

Every published approximation (d'Eon 2021; docs/model.md) is here with its
coefficients as a named preset ("paper", and "renderer" where the author's
renderer plugin differs); richer forms of the same shapes sit beside them.
"""

from fitlab.families.lambert_sphere.forms import albedo_maps, brdf, constants, h_functions, sampling
from fitlab.families.lambert_sphere.forms.brdf import (
    AZIMUTH,
    ORDER2_PART,
    RUNTIME_PARTS,
    RUNTIME_TERMS,
    SINGLE,
    runtime_brdf,
    runtime_sum,
    runtime_terms,
)

FORMS = (*h_functions.FORMS, *constants.FORMS, *albedo_maps.FORMS, *brdf.FORMS, *sampling.FORMS)

__all__ = [
    "FORMS",
    "AZIMUTH",
    "ORDER2_PART",
    "RUNTIME_PARTS",
    "RUNTIME_TERMS",
    "SINGLE",
    "runtime_brdf",
    "runtime_sum",
    "runtime_terms",
]
