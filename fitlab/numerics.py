"""Numerics shared by every family: quadrature rules (the families' exact engines build their composite and
graded rules on these), the argument checks of their public functions, and single-threaded BLAS for small
dense linear algebra.

The checks give one line naming the argument and its domain: TypeError for anything that is not a real
number or an array of real numbers (strings, None, booleans, complex values, objects); ValueError for NaN or
a value outside the domain.  They return arrays in the working precision of :func:`working_dtype`.
"""

from __future__ import annotations

import numbers
from contextlib import AbstractContextManager, nullcontext
from functools import cache, lru_cache

import numpy as np

__all__ = ["gauss_legendre", "real_array", "choice", "working_dtype", "single_threaded_blas"]


@cache
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """n-point Gauss-Legendre nodes and weights on [0, 1] (exact for polynomials of degree 2n - 1), as
    read-only arrays (the rule is cached: one shared copy)."""
    if n < 1:
        raise ValueError(f"a Gauss-Legendre rule needs n >= 1 nodes, got {n}")
    x, w = np.polynomial.legendre.leggauss(n)
    nodes, weights = 0.5 * (x + 1.0), 0.5 * w
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


@lru_cache(maxsize=1)
def _blas_controller():
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - a dependency; without it BLAS keeps its threads
        return None
    # JAX's CPU LAPACK calls scipy's: loaded first, its OpenBLAS is in the controller's list of libraries
    import scipy.linalg  # noqa: F401

    return ThreadpoolController()


def single_threaded_blas() -> AbstractContextManager:
    """A context in which the BLAS and LAPACK libraries of the process run on one thread, restored on exit: those
    loaded when it is first called, numpy's and scipy's among them (scipy's is JAX's CPU LAPACK).

    fitlab's dense linear algebra is small or tall and narrow: a Levenberg-Marquardt step's QR of a 4,550 x 30
    Jacobian, the exact engines' matrices of a few hundred rows.  OpenBLAS splits such level-2 work across
    threads whose spin-waits then compete with the other threads (XLA's, the test workers'): on 2 cores the
    H0 refit's solve took 1.5 to 2.5 times as long with two BLAS threads as with one, with identical results.
    One controller per process: creating one scans every loaded library (4 to 60 ms), entering its limit
    takes microseconds."""
    controller = _blas_controller()
    return nullcontext() if controller is None else controller.limit(limits=1, user_api="blas")


def working_dtype(*values) -> type:
    """float32 when every value is a numpy float32 array or scalar (a shader's precision), else float64."""
    if values and all(isinstance(v, (np.ndarray, np.floating)) and np.asarray(v).dtype == np.float32 for v in values):
        return np.float32
    return np.float64


def real_array(
    value, name: str, lo: float, hi: float, *, open_lo: bool = False, dtype=np.float64, domain: str | None = None
) -> np.ndarray:
    """``value`` as an array of ``dtype`` whose elements lie in [lo, hi] ((lo, hi] with open_lo)."""
    domain = domain or f"{'(' if open_lo else '['}{lo:g}, {hi:g}]"
    want = f"{name} must be a real number or an array of real numbers in {domain}"
    if value is None or isinstance(value, (str, bytes, bool, np.bool_, complex, np.complexfloating)):
        raise TypeError(f"{want}, got {type(value).__name__} {value!r:.40}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise ValueError(f"{want}, got a ragged sequence") from None
    if arr.dtype.kind == "O":
        if not all(isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_)) for x in arr.ravel()):
            raise TypeError(f"{want}, got a sequence holding something else")
    elif arr.dtype.kind not in "iuf":
        raise TypeError(f"{want}, got an array of dtype {arr.dtype}")
    out = np.asarray(arr, dtype=dtype)
    if out.size:
        if np.any(np.isnan(out)):
            raise ValueError(f"{want}, got NaN")
        bad = (out < lo) | (out > hi) | ((out == lo) if open_lo else False)
        if np.any(bad):
            raise ValueError(f"{want}, got {out[bad].ravel()[0]!r}")
    return out


def choice(value, name: str, options) -> str:
    """``value`` if it is one of ``options`` (strings), else a one-line ValueError listing them."""
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, options))}, got {value!r:.40}")
    return value
