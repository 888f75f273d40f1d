"""Fit records as strict JSON: non-finite numbers written as the strings "inf", "-inf", "nan", and read back."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

__all__ = ["strict_json", "decode_nonfinite", "refuse_constant"]


def _encode(x):
    if isinstance(x, float) and not math.isfinite(x):
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if isinstance(x, dict):
        return {k: _encode(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_encode(v) for v in x]
    if isinstance(x, np.generic):
        return _encode(x.item())
    return x


_NONFINITE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}


def _decode(x) -> Any:
    if isinstance(x, str) and x in _NONFINITE:
        return _NONFINITE[x]
    if isinstance(x, dict):
        return {k: _decode(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_decode(v) for v in x]
    return x


def strict_json(obj) -> str:
    """JSON text with non-finite numbers as the strings "inf", "-inf", "nan"."""
    return json.dumps(_encode(obj), indent=2, allow_nan=False) + "\n"


def decode_nonfinite(obj):
    """The inverse of :func:`strict_json`'s encoding: the strings "inf", "-inf", "nan" back to floats."""
    return _decode(obj)


def refuse_constant(name):
    """json.loads' ``parse_constant``: refuse NaN, Infinity and -Infinity, which strict JSON lacks."""
    raise ValueError(f'the JSON literal {name} (non-finite numbers are written as the strings "inf", "nan")')
