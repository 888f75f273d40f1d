"""The exact Lambert-sphere BRDF for tests whose exact values cost seconds (a solve of about a second at each
new albedo): :func:`brdf` is ``exact.brdf`` through fitlab's cache of exact values (:mod:`fitlab.cache`), keyed
by its inputs, the phase function and the bytes of the exact engine, so an edit of the engine recomputes it.

tools/seed_test_cache.py runs the tests of :data:`SEEDED_TESTS` and keeps the entries they write
(``tests-exact-brdf-*``) in tests/data/exact_values, which tests/conftest.py copies into the run's cache: on a
fresh machine those tests start warm.  Each entry holds its inputs (``in_*``) beside the values, so that
tests/test_exact_value_seed.py can recompute a sample of each with the engine.
"""

from __future__ import annotations

import numpy as np

from fitlab.cache import cached_at
from fitlab.families.lambert_sphere import exact

#: the entries' names start with this
NAME = "tests-exact-brdf"
#: the inputs of exact.brdf, in its order (the entries hold them as in_NAME: fitlab.cache.cached_at)
INPUTS = ("mu_i", "mu_o", "phi", "c")
#: the tests whose calls of :func:`brdf` the seed holds (pytest node ids, from the project root)
SEEDED_TESTS = (
    "tests/test_table_export.py::test_accuracy_against_the_exact_engine_within_the_stated_figure",
    "tests/test_brdf.py::test_reference_brdf_edges",
    "tests/test_properties.py::test_exact_true_brdf_increases_with_c",
)


def brdf(mu_i, mu_o, phi, c, phase: str | None = None) -> np.ndarray:
    """``exact.brdf(mu_i, mu_o, phi, c, phase)`` (phase None: the engine's default), broadcast, from the cache
    where it holds this call."""
    phase = exact.DEFAULT_PHASE if phase is None else phase
    inputs = dict(zip(INPUTS, np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (mu_i, mu_o, phi, c)))))

    def compute():
        return {"f": exact.brdf(*inputs.values(), phase=phase)}

    key = {"family": "lambert_sphere", "phase": phase}
    return cached_at(f"{NAME}-{phase}", key, inputs, compute, ("f",), sources=exact.SOURCES)["f"]
