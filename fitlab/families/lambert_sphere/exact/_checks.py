"""Argument checks for the public functions of the exact engine.

Each check refuses a bad argument with one line that names the argument and its
domain, before any work is done:

* TypeError for a value that is not a real number or an array of real numbers:
  strings (also numeric ones such as "0.5", which numpy would silently convert),
  None, complex numbers and complex arrays (numpy would drop the imaginary part
  with only a warning), booleans, lists holding any of these, other objects;
* ValueError for a real value outside the domain, NaN, or a ragged sequence.

Accepted: Python and numpy integers and floats, Fractions and Decimals, and
(nested) sequences and arrays of them.  The checks return float64 arrays.
"""

from __future__ import annotations

import decimal
import numbers

import numpy as np

__all__ = ["real_array", "real_scalar", "fourier_order", "choice", "positive_int", "characteristic"]

_ACCEPTED_KINDS = "iuf"  # signed and unsigned integers, floats


def _describe(value) -> str:
    """A short description of a refused value for the one-line message."""
    if isinstance(value, np.ndarray):
        return f"an array of dtype {value.dtype}"
    text = repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{type(value).__name__} {text}"


def _real_element(x) -> bool:
    return (isinstance(x, (numbers.Real, decimal.Decimal))) and not isinstance(x, (bool, np.bool_))


def real_array(
    value,
    name: str,
    lo: float = -np.inf,
    hi: float = np.inf,
    *,
    domain: str | None = None,
    allow_inf: bool = True,
    open_ends: bool = False,
) -> np.ndarray:
    """``value`` as a float64 array whose elements lie in [lo, hi] (NaN refused).

    allow_inf=False refuses +-inf even when the interval admits it (phi);
    open_ends=True refuses lo and hi themselves.  domain: the words used in
    messages (default "[lo, hi]").
    """
    if domain is None:
        domain = f"[{lo:g}, {hi:g}]"
    want = f"{name} must be a real number or an array of real numbers in {domain}"
    if value is None or isinstance(value, (str, bytes, complex, bool, np.bool_, np.complexfloating)):
        raise TypeError(f"{want}, got {_describe(value)}")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):  # ragged nesting, objects numpy cannot hold
        raise ValueError(f"{want}, got a ragged sequence (rows of different lengths)") from None
    if arr.dtype.kind == "O":
        for x in arr.ravel():
            if not _real_element(x):
                what = _describe(x) if arr.ndim == 0 else f"a sequence containing {_describe(x)}"
                raise TypeError(f"{want}, got {what}")
    elif arr.dtype.kind not in _ACCEPTED_KINDS:
        if isinstance(value, np.ndarray):
            what = f"an array of dtype {arr.dtype}"
        elif arr.ndim == 0:
            what = _describe(value)
        elif arr.size:
            what = f"a sequence containing {_describe(arr.ravel()[0].item())}"
        else:
            what = f"an empty sequence of dtype {arr.dtype}"
        raise TypeError(f"{want}, got {what}")
    try:
        out = np.asarray(arr, dtype=float)
    except OverflowError:
        raise ValueError(f"{name} must lie in {domain}, got an integer too large for a float") from None
    if out.size:
        nan = np.isnan(out)
        if np.any(nan):
            raise ValueError(f"{name} is NaN; it must lie in {domain}")
        bad = ((out <= lo) | (out >= hi)) if open_ends else ((out < lo) | (out > hi))
        if not allow_inf:
            bad |= np.isinf(out)
        if np.any(bad):
            raise ValueError(f"{name} must lie in {domain}, got {float(out[bad].ravel()[0])!r}")
    return out


def real_scalar(
    value, name: str, lo: float = -np.inf, hi: float = np.inf, *, domain: str | None = None, open_ends: bool = False
) -> float:
    """One real number in [lo, hi] (0-d arrays and numpy scalars included)."""
    out = real_array(value, name, lo, hi, domain=domain, open_ends=open_ends)
    if out.ndim != 0:
        raise TypeError(f"{name} must be one real number, got an array of shape {out.shape}")
    return float(out)


def fourier_order(value, name: str = "order") -> int:
    """The Fourier order m: one integer 0, 1 or 2 (integer-valued floats accepted)."""
    want = f"{name} must be the Fourier order m, one integer 0, 1 or 2"
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, decimal.Decimal)):
        raise TypeError(f"{want}, got {_describe(value)}")
    v = float(value)
    if not np.isfinite(v) or v != int(v) or int(v) not in (0, 1, 2):
        raise ValueError(f"{want}, got {value!r}")
    return int(v)


def choice(value, name: str, options: tuple) -> str:
    """One of the strings ``options``."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be one of {options}, got {_describe(value)}")
    if value not in options:
        raise ValueError(f"{name} must be one of {options}, got {value!r}")
    return value


def positive_int(value, name: str) -> int:
    """A positive integer (quadrature sizes)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be a positive integer, got {_describe(value)}")
    if value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def characteristic(value, cls) -> None:
    """A Characteristic (from lambert_sphere_characteristic or isotropic_characteristic)."""
    if not isinstance(value, cls):
        raise TypeError(
            f"char must be a Characteristic (lambert_sphere_characteristic(order, c) or isotropic_characteristic(c)), "
            f"got {_describe(value)}"
        )
