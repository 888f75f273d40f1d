"""Exact reference engine: H-functions, constants, the exact BRDF and albedos.

Everything else in fitlab is measured against this package.  Methods and their
measured accuracy are described in docs/derivation.md; the normalisations of
the published equations are settled in docs/errata.md.
"""

from fitlab.families.lambert_sphere.exact.albedo import albedo, single_scattering_albedo, spherical_albedo
from fitlab.families.lambert_sphere.exact.brdf import brdf, brdf_modes, multiple_scattering_modes, single_scattering_modes
from fitlab.families.lambert_sphere.exact.characteristic import isotropic_characteristic, k_function, psi
from fitlab.families.lambert_sphere.exact.constants import CONSTANT_NAMES, constants, mode_polynomials
from fitlab.families.lambert_sphere.exact.doubling import doubling_reflection
from fitlab.families.lambert_sphere.exact.hfunction import h_fock, h_function, solve_h
from fitlab.families.lambert_sphere.exact.phase import LEGENDRE_A, phase_function, three_term_phase_function

__all__ = [
    "albedo",
    "brdf",
    "brdf_modes",
    "CONSTANT_NAMES",
    "constants",
    "doubling_reflection",
    "h_fock",
    "h_function",
    "isotropic_characteristic",
    "k_function",
    "LEGENDRE_A",
    "mode_polynomials",
    "multiple_scattering_modes",
    "phase_function",
    "psi",
    "single_scattering_albedo",
    "single_scattering_modes",
    "solve_h",
    "spherical_albedo",
    "three_term_phase_function",
]
