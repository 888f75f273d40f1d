r"""The stochastic microsurface random walk of Heitz, Hanika, d'Eon and Dachsbacher (2016),
"Multiple-Scattering Microfacet BSDFs with the Smith Model": light scattered any number of times on
a Smith microsurface (uncorrelated uniform heights, GGX or Beckmann slopes, isotropic or anisotropic
alpha), by scattering order, in JAX (jit, float64 within fitlab's calls only, counter-based random
numbers: results depend on (seed, material, incident direction, path id) only).

Materials: conductors (F = 1, Schlick F0, the exact conductor Fresnel of eta + i k) and diffuse
(Lambertian) facets.  Not yet: dielectric facets (reflection and transmission).

Modules: ``microsurface`` (heights C1/invC1, Lambda, G1, the free path of heights, visible-normal
sampling), ``fresnel``, ``walk`` (the jitted walk and its tallies), ``scene`` (TOML scene files and
their validation), ``reference`` (the analytic single scattering, height-correlated Smith, and its
bin averages), ``simulate`` (driver: stopping rule, CSV and PNG; ``simulate_file``, ``summary_table``,
``unconverged``, ``SceneError``: the family's future "simulate" hook), ``bench`` (bounces per second).
"""

from fitlab.families.microfacet_energy.microsurface.scene import Material, Scene, SceneError, load_scene, parse_scene
from fitlab.families.microfacet_energy.microsurface.simulate import (
    SimulationResult,
    simulate,
    simulate_file,
    summary_table,
    unconverged,
)
from fitlab.families.microfacet_energy.microsurface.walk import MaterialParams, WalkConfig, job_key, run_round

__all__ = [
    "Material",
    "MaterialParams",
    "Scene",
    "SceneError",
    "SimulationResult",
    "WalkConfig",
    "job_key",
    "load_scene",
    "parse_scene",
    "run_round",
    "simulate",
    "simulate_file",
    "summary_table",
    "unconverged",
]
