"""Monte Carlo ground truth for the Lambert-sphere half space (docs/model.md, "Monte Carlo model").

Independent of the H-function route of :mod:`fitlab.families.lambert_sphere.exact`: photons are
followed through the half space in JAX (jit, vectorised over photons,
float64, counter-based random numbers), with the true phase function or its
three-term truncation.  Single scattering is never simulated (it has the closed
form of docs/model.md, "Single scattering"); tallies start at the second collision.

Modules: ``sampling`` (phase sampling, eqs. 5 and 6, the signed three-term
sampler), ``transport`` (the jitted random walk, its tallies and sharding),
``scene`` (the schema of its scene files, read and checked by the shared
:mod:`fitlab.scenes`), ``effects`` (which tallies each effect needs, estimates
and exact values), ``simulate`` (the walk the shared runner drives: jobs,
stopping rule, rows; the family's Monte Carlo), ``plots`` (a PNG per effect),
``bench`` (photons and collisions per second).
See docs/montecarlo.md.
"""

from fitlab.families.lambert_sphere.mc.phase_sampling import (
    THREE_TERM_NORM,
    p_three_term,
    p_true,
    sample_three_term,
    sample_true_approx,
    sample_true_exact,
)
from fitlab.families.lambert_sphere.mc.scene import Scene, SceneError, load_scene, parse_scene
from fitlab.families.lambert_sphere.mc.transport import WalkConfig, run_round

__all__ = [
    "THREE_TERM_NORM",
    "Scene",
    "SceneError",
    "WalkConfig",
    "load_scene",
    "parse_scene",
    "p_three_term",
    "p_true",
    "run_round",
    "sample_three_term",
    "sample_true_approx",
    "sample_true_exact",
]
