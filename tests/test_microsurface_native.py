"""The C reference walk of ``fitlab bench mc --family microfacet_energy`` walks the JAX walk's paths: on the same
job key its escapes by order, capped paths and bounces are the JAX walk's exactly (F = 1: every weight is 1)."""

from __future__ import annotations

import numpy as np
import pytest

from fitlab.codegen.native import compiler
from fitlab.families.microfacet_energy.mc.native import ORDERS, native_walk

pytestmark = pytest.mark.skipif(compiler() is None, reason="no C compiler")


@pytest.mark.parametrize("alpha, mu_i, cap", [(0.6, 0.5, 1000), (1.0, 0.05, 1000), (0.02, 1.0, 1000), (0.8, 0.3, 2)])
def test_native_walk_is_the_jax_walk_path_for_path(alpha, mu_i, cap):
    from fitlab.families.microfacet_energy.mc.walk import MaterialParams, WalkConfig, job_key, run_round

    key = job_key(3, 1, 2)
    n = 4000
    jax_round = run_round(
        WalkConfig(orders=ORDERS, precision="float64"), key, MaterialParams(alpha, alpha), mu_i, 0, n, cap
    )
    native = native_walk(tuple(int(k) for k in key), alpha, mu_i, n, cap)
    assert np.array_equal(native["exits"], jax_round["albedo"].astype(np.int64))
    assert native["capped"] == int(jax_round["capped"])
    assert native["bounces"] == int(jax_round["bounces"])
    assert native["exits"].sum() + native["capped"] == n  # energy, path by path


def test_native_walk_refuses_bad_inputs():
    for args in ((0.0, 0.5, 10), (0.5, 0.0, 10), (0.5, 0.5, 0)):
        with pytest.raises(ValueError):
            native_walk((1, 2), *args)
