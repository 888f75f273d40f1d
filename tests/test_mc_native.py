"""The C reference walk of ``fitlab bench mc`` walks the JAX walk's photons: on the same round key it makes the
same collisions and the same escaping weight (to rounding), so its collisions per second time the same work;
and it holds the walk's identities (c = 1 loses nothing but what roulette and escape take)."""

from __future__ import annotations

import numpy as np
import pytest

from fitlab.codegen.native import compiler
from fitlab.families.lambert_sphere.mc.native import native_walk

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler")


@pytest.mark.parametrize("c, mu_i", [(0.9, 0.5), (1.0, 1.0), (0.3, 0.05)])
def test_native_walk_is_the_jax_walk_photon_for_photon(c, mu_i):
    from fitlab.families.lambert_sphere.mc.transport import WalkConfig, round_key, run_round

    n = 3000
    jax_round = run_round(WalkConfig(phase="true", sampler="exact", precision="float64"), 11, (4,), c, mu_i, n)
    key = tuple(int(k) for k in np.asarray(round_key(11, 4)))
    native = native_walk(key, c, mu_i, n)
    assert native["collisions"] == int(jax_round["collisions"])
    assert native["capped"] == int(jax_round["n_capped"])  # at c = 1 a few long paths reach the cap
    escape = float(np.asarray(jax_round["escape"]).ravel()[0]) / n
    assert abs(native["escape"] / escape - 1) < 1e-12


def test_native_walk_statistics_and_refusals():
    """Every photon escapes, is killed by roulette or reaches the cap (at c = 1 in a conservative half space a
    few long paths do: P(n > N) ~ N^(-1/2)); the escaping weight estimates the multiple-scattering albedo, in
    (0, 1); bad inputs are refused."""
    native = native_walk((1, 2), 1.0, 0.5, 20000)
    assert native["escapes"] + native["killed"] + native["capped"] == 20000
    assert 0.0 < native["escape"] < 1.0 and native["collisions"] > 20000
    with pytest.raises(ValueError):
        native_walk((1, 2), 1.5, 0.5, 10)
    with pytest.raises(ValueError):
        native_walk((1, 2), 0.5, 0.5, 0)
