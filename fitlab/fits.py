r"""Saved fits: the coefficient JSON written by ``fitlab refit``, and ``load``.

A fit file is self-contained: it holds the form's expression (sympy text), its
inputs, parameters and domain, so :func:`load` evaluates it without the form
registry (fits found by other means, e.g. symbolic regression, load the same
way).  Non-finite numbers are stored as the strings "inf", "-inf", "nan" so the
files stay strict JSON.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Mapping

import numpy as np

from ._io import atomic_write_text
from .forms.symbolic import lambdify_numpy, parse_expression, symbols

__all__ = [
    "FORMAT", "FitFileError", "FitFunction", "load", "read_fit", "write_fit", "strict_json", "DEFAULT_DOMAINS",
    "form_from_fit",
]

FORMAT = "fitlab-fit/1"

#: the domain of every input fitlab knows; a fit's domain must lie inside
DEFAULT_DOMAINS = {
    "mu": (0.0, 1.0),
    "mu_i": (0.0, 1.0),
    "mu_o": (0.0, 1.0),
    "c": (0.0, 1.0),
    "kd": (0.0, 1.0),
    "phi": (-math.pi, math.pi),
}

_REQUIRED = ("format", "target", "form", "inputs", "expression", "params", "domain")


class FitFileError(Exception):
    """A fit file is missing, unreadable, or not a fitlab fit."""


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


def _decode(x):
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


def write_fit(path: Path, record: Mapping) -> None:
    """Write ``record`` as JSON atomically (a temporary file, then a rename)."""
    path = Path(path)
    atomic_write_text(path, strict_json(dict(record)))


def read_fit(path: Path) -> dict:
    """Read and check a fit file; every failure is one :class:`FitFileError` line."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise FitFileError(f"{path}: no such fit file; run `fitlab refit --target NAME` to create it") from None
    except OSError as exc:
        raise FitFileError(f"{path}: cannot read ({exc.strerror})") from None
    try:
        record = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FitFileError(
            f"{path}: corrupt JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); "
            "regenerate it with `fitlab refit`"
        ) from None
    if not isinstance(record, dict):
        raise FitFileError(f"{path}: not a fitlab fit (a JSON object is expected)")
    record = _decode(record)
    missing = [k for k in _REQUIRED if k not in record]
    if missing:
        raise FitFileError(f"{path}: not a fitlab fit, missing {missing}; regenerate it with `fitlab refit`")
    if record["format"] != FORMAT:
        raise FitFileError(f"{path}: format {record['format']!r}, this fitlab reads {FORMAT!r}")
    params = record["params"]
    if not isinstance(params, dict) or not all(isinstance(v, (int, float)) for v in params.values()):
        raise FitFileError(f"{path}: params must map names to numbers")
    for name in record["inputs"]:
        if name not in DEFAULT_DOMAINS:
            raise FitFileError(f"{path}: unknown input {name!r}; inputs are {sorted(DEFAULT_DOMAINS)}")
        if name not in record["domain"]:
            raise FitFileError(f"{path}: no domain for input {name!r}")
    return record


class FitFunction:
    """A saved fit as a callable on numpy arrays.

    ``f(mu=..., c=...)`` or positionally in the order of ``f.inputs``; inputs
    broadcast.  Inputs outside the fit's domain raise ValueError: a fit says
    nothing outside the domain it was validated on.
    """

    def __init__(self, record: dict, path: Path | None = None):
        self.record = record
        self.path = path
        self.target = record["target"]
        self.form = record["form"]
        self.inputs = tuple(record["inputs"])
        self.params = dict(record["params"])
        self.domain = {k: tuple(float(x) for x in v) for k, v in record["domain"].items()}
        try:
            expr = parse_expression(record["expression"], (*self.inputs, *self.params))
        except ValueError as exc:
            raise FitFileError(f"{path or 'fit'}: {exc}") from None
        import sympy as sp

        expr = expr.subs({sp.Symbol(p, real=True): sp.Float(repr(float(v)), 17) for p, v in self.params.items()})
        self.expression = expr
        self._f = lambdify_numpy(symbols(self.inputs), expr)

    def __repr__(self) -> str:
        return f"FitFunction({self.target}/{self.form}, inputs={self.inputs})"

    def __call__(self, *args, **kwargs):
        if len(args) > len(self.inputs):
            raise TypeError(f"{self!r} takes {len(self.inputs)} inputs {self.inputs}")
        values = dict(zip(self.inputs, args))
        for k, v in kwargs.items():
            if k in values:
                raise TypeError(f"input {k!r} given twice")
            if k not in self.inputs:
                raise TypeError(f"unknown input {k!r}; this fit takes {self.inputs}")
            values[k] = v
        missing = [n for n in self.inputs if n not in values]
        if missing:
            raise TypeError(f"missing inputs {missing}; this fit takes {self.inputs}")
        arrays = []
        for name in self.inputs:
            a = np.asarray(values[name], dtype=float)
            lo, hi = self.domain[name]
            if np.any(np.isnan(a)) or np.any((a < lo) | (a > hi)):
                raise ValueError(f"{name} must lie in [{lo}, {hi}] (the domain this fit was validated on)")
            arrays.append(a)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self._f(*arrays)
        return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(a.shape for a in arrays))).copy()


def load(path) -> FitFunction:
    """Load a fit file written by ``fitlab refit`` as a :class:`FitFunction`."""
    return FitFunction(read_fit(path), Path(path))


def form_from_fit(record: dict):
    """The :class:`fitlab.forms.Form` a fit record defines (its expression, parameters and fixed
    values), starting from the record's parameters: how a form found outside fitlab.forms (by
    ``fitlab discover``) is refitted like any other."""
    from .forms import Form

    names = (*record["inputs"], *record["params"])
    try:
        expr = parse_expression(record["expression"], names)
    except ValueError as exc:
        raise FitFileError(f"{record.get('target')}/{record.get('form')}: {exc}") from None
    return Form(
        target=record["target"],
        name=record["form"],
        inputs=tuple(record["inputs"]),
        params=tuple(record["params"]),
        expr=expr,
        start={k: float(v) for k, v in record["params"].items()},
        fixed={k: float(v) for k, v in record.get("fixed", {}).items()},
        description=record.get("form_description", ""),
        refit_by_default=False,
    )
