"""Exact reference engine: H-functions, constants, the exact BRDF and albedos.

Everything else in fitlab is measured against this package.  Methods and their
measured accuracy are described in docs/derivation.md; the normalisations of
the published equations are settled in docs/errata.md.
"""

from pathlib import Path

from fitlab import physics
from fitlab.families.lambert_sphere.exact import true_phase
from fitlab.families.lambert_sphere.exact._quadrature import gauss_legendre, graded_gauss
from fitlab.families.lambert_sphere.exact.albedo import (
    albedo,
    single_albedo_nodes,
    single_scattering_albedo,
    spherical_albedo,
    three_term_single_albedo,
)
from fitlab.families.lambert_sphere.exact.brdf import (
    DEFAULT_PHASE,
    PHASES,
    brdf,
    brdf_modes,
    check_phase,
    multiple_scattering_modes,
    single_scattering_modes,
)
from fitlab.families.lambert_sphere.exact.characteristic import (
    isotropic_characteristic,
    k_function,
    lambert_sphere_characteristic,
    psi,
)
from fitlab.families.lambert_sphere.exact.constants import CONSTANT_NAMES, constants, mode_polynomials
from fitlab.families.lambert_sphere.exact.doubling import doubling_reflection
from fitlab.families.lambert_sphere.exact.hfunction import _solve_cached, h_fock, h_function, solve_h
from fitlab.families.lambert_sphere.exact.inverse import albedo_inverse, solve_albedo
from fitlab.families.lambert_sphere.exact.phase import LEGENDRE_A, phase_function, three_term_phase_function
from fitlab.families.lambert_sphere.exact.true_phase import (
    legendre_moments,
    multiple_scattering_albedo,
    multiple_scattering_orders,
    multiple_scattering_sum,
    needed_orders,
)

#: the engine's source files, part of the key of every cached exact value (fitlab.cache.cached_arrays): editing
#: any of them recomputes what was cached
SOURCES = (*sorted(Path(__file__).resolve().parent.glob("*.py")), *physics.sources("lambert_sphere"))

__all__ = [
    "SOURCES",
    "DEFAULT_PHASE",
    "PHASES",
    "true_phase",
    "legendre_moments",
    "multiple_scattering_albedo",
    "multiple_scattering_orders",
    "multiple_scattering_sum",
    "needed_orders",
    "albedo",
    "albedo_inverse",
    "brdf",
    "brdf_modes",
    "check_phase",
    "clear_h_cache",
    "CONSTANT_NAMES",
    "constants",
    "doubling_reflection",
    "gauss_legendre",
    "graded_gauss",
    "h_fock",
    "h_function",
    "isotropic_characteristic",
    "k_function",
    "lambert_sphere_characteristic",
    "LEGENDRE_A",
    "mode_polynomials",
    "multiple_scattering_modes",
    "phase_function",
    "psi",
    "single_albedo_nodes",
    "single_scattering_albedo",
    "single_scattering_modes",
    "solve_h",
    "solve_albedo",
    "solve_h_uncached",
    "spherical_albedo",
    "three_term_phase_function",
    "three_term_single_albedo",
]


def solve_h_uncached(char, nodes_per_panel: int = 16, ratio: float = 0.25):
    """:func:`solve_h` without its cache: a fresh Nystrom/Newton solve on every call (for timing it)."""
    return _solve_cached.__wrapped__(tuple(float(p) for p in char.coefficients), float(char.k0), nodes_per_panel, ratio)


def clear_h_cache() -> None:
    """Empty :func:`solve_h`'s cache (the next solve of every H-function is fresh)."""
    _solve_cached.cache_clear()
