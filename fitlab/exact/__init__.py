"""Exact reference engine: H-functions, constants, the exact BRDF and albedos.

Everything else in fitlab is measured against this package.  Methods and their
measured accuracy are described in docs/derivation.md; the normalisations of
the published equations are settled in docs/errata.md.
"""

from .albedo import albedo, single_scattering_albedo, spherical_albedo
from .brdf import brdf, brdf_modes, multiple_scattering_modes, single_scattering_modes
from .characteristic import isotropic_characteristic, k_function, psi
from .constants import CONSTANT_NAMES, constants, mode_polynomials
from .doubling import doubling_reflection
from .hfunction import h_fock, h_function, solve_h
from .phase import LEGENDRE_A, phase_function, three_term_phase_function

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
