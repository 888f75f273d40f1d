"""fitlab.numerics: the quadrature rule every family's exact engine builds on (one rule, re-exported)."""

import numpy as np
import pytest

from fitlab.numerics import gauss_legendre


def test_one_gauss_legendre_rule_for_every_family():
    from fitlab.families.lambert_sphere.exact import gauss_legendre as sphere
    from fitlab.families.microfacet_energy.exact._quadrature import gauss_legendre as microfacet

    assert sphere is microfacet is gauss_legendre


@pytest.mark.parametrize("n", [1, 2, 7, 40])
def test_exact_for_degree_2n_minus_1_on_the_unit_interval(n):
    x, w = gauss_legendre(n)
    assert x.shape == w.shape == (n,) and np.all((x > 0) & (x < 1))
    for k in range(2 * n):
        assert float(w @ x**k) == pytest.approx(1.0 / (k + 1), rel=1e-13)
    with pytest.raises(ValueError):  # cached and shared: read-only
        x[0] = 0.0


def test_no_rule_without_nodes():
    with pytest.raises(ValueError, match="n >= 1"):
        gauss_legendre(0)


def _blas_threads() -> list[int]:
    from threadpoolctl import threadpool_info

    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_single_threaded_blas_holds_every_loaded_blas_to_one_thread_and_restores_it():
    """The suite runs with BLAS on one thread (conftest): two threads are set first, so the limit is seen to act;
    scipy's OpenBLAS (the one JAX's CPU LAPACK calls) is among the libraries limited."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from fitlab.numerics import single_threaded_blas

    with single_threaded_blas():  # loads scipy.linalg, so its BLAS is in the list below
        pass
    assert any("scipy" in lib["filepath"] for lib in threadpool_info() if lib["user_api"] == "blas")
    with threadpool_limits(limits=2, user_api="blas"):
        outside = _blas_threads()
        with single_threaded_blas():
            assert _blas_threads() == [1] * len(outside)
        assert _blas_threads() == outside
