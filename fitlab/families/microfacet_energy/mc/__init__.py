r"""The stochastic microsurface random walk of Heitz, Hanika, d'Eon and Dachsbacher (2016),
"Multiple-Scattering Microfacet BSDFs with the Smith Model": light scattered any number of times on
a Smith microsurface (uncorrelated uniform heights, GGX or Beckmann slopes, isotropic or anisotropic
alpha), by scattering order, in JAX (jit, float64 within fitlab's calls only, counter-based random
numbers: results depend on (seed, material, incident direction, path id) only).

Materials: conductors (F = 1, Schlick F0, the exact conductor Fresnel of eta + i k), diffuse
(Lambertian) facets, and dielectrics (reflection and transmission through an interface of relative
index eta, on both sides of the microsurface as in the paper's MicrosurfaceDielectric).

Modules: ``microsurface`` (heights C1/invC1, Lambda, G1, the free path of heights, visible-normal
sampling, reflection and refraction), ``fresnel``, ``walk`` (the jitted walk, its tallies, and its
sharding over devices), ``scene`` (the schema of its TOML scene files, read and checked by the shared
:mod:`fitlab.scenes`), ``reference`` (the analytic single scattering with height-correlated Smith: BRDF,
Walter's BTDF, diffuse facets; bin averages and totals), ``simulate`` (the walk the shared runner drives:
jobs, stopping rule, rows and PNGs; the family's Monte Carlo), ``bench`` (bounces and paths per second).
docs/microsurface.md states the walk, the references and their derivations, and the figures measured.
"""

from fitlab.families.microfacet_energy.mc.scene import Material, Scene, SceneError, load_scene, parse_scene
from fitlab.families.microfacet_energy.mc.simulate import (
    SimulationResult,
    simulate,
    simulate_file,
    summary_table,
    unconverged,
)
from fitlab.families.microfacet_energy.mc.walk import (
    MaterialParams,
    WalkConfig,
    default_mesh,
    job_key,
    run_round,
)

__all__ = [
    "Material",
    "MaterialParams",
    "Scene",
    "SceneError",
    "SimulationResult",
    "WalkConfig",
    "default_mesh",
    "job_key",
    "load_scene",
    "parse_scene",
    "run_round",
    "simulate",
    "simulate_file",
    "summary_table",
    "unconverged",
]
