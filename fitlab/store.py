r"""The store: the only reader and writer of fit files (fits/TARGET[.FORM].json) and exact tables (data/*.csv).

Fit files
---------
A fit file is self-contained: it holds the form's expression (sympy text), its
inputs, parameters and domain, so :func:`load` evaluates it without the form
registry (fits found by other means, e.g. symbolic regression, load the same
way).  Non-finite numbers are stored as the strings "inf", "-inf", "nan" so the
files stay strict JSON.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

import sympy as sp

from fitlab import __version__
from fitlab._io import atomic_write_many, atomic_write_text
from fitlab.core import get_target
from fitlab.forms import Form
from fitlab.forms.symbolic import lambdify_numpy, parse_expression, symbols

__all__ = [
    "FORMAT", "FitFileError", "FitFunction", "load", "read_fit", "write_fit", "strict_json", "form_from_fit",
    "fit_path", "fit_files", "resolve_form", "Table", "TableError", "format_table", "read_table", "write_tables",
]

FORMAT = "fitlab-fit/1"

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
    try:
        target = get_target(record["target"])
    except (KeyError, TypeError):
        raise FitFileError(f"{path}: unknown target {record['target']!r}") from None
    for name in record["inputs"]:
        if name not in target.domain:
            raise FitFileError(f"{path}: unknown input {name!r}; {target.name}'s inputs are {list(target.inputs)}")
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


# -- where fits live -------------------------------------------------------------
def fit_path(out: Path, target: str, form: str) -> Path:
    """fits/NAME.json for a target's default form, fits/NAME.FORM.json otherwise."""
    default = get_target(target).default_form
    return Path(out) / (f"{target}.json" if form == default else f"{target}.{form}.json")


def fit_files(fits_dir: Path, target: str) -> list[Path]:
    """Every saved fit of ``target`` in ``fits_dir``: TARGET.json first, then TARGET.*.json by name."""
    fits_dir = Path(fits_dir)
    return [p for p in (fits_dir / f"{target}.json",) if p.exists()] + sorted(fits_dir.glob(f"{target}.*.json"))


def resolve_form(target_name: str, form_name: str | None, fits_dir: Path = Path("fits")) -> Form:
    """A target's form by name: from fitlab.forms, else (a form found by ``fitlab discover``) from
    the saved fit fits_dir/TARGET.FORM.json, which holds the form's expression."""
    target = get_target(target_name)
    form_name = form_name or target.default_form
    if form_name in target.forms:
        return target.forms[form_name]
    path = fit_path(fits_dir, target.name, form_name)
    if path.exists():
        return form_from_fit(read_fit(path))
    raise KeyError(
        f"target {target.name} has no form {form_name!r} (and there is no {path}); forms: {', '.join(target.forms)}"
    )


# -- exact tables ----------------------------------------------------------------
@dataclass(frozen=True)
class Table:
    """An exact table: its name, how it was computed, to what tolerance, on which grid, and its rows."""

    name: str
    method: str
    tolerance: str
    columns: tuple[str, ...]
    rows: list
    grid: str = ""


def _fmt(x: float) -> str:
    if np.isinf(x):
        return "inf" if x > 0 else "-inf"
    return repr(float(x))


def format_table(table: Table) -> str:
    """The CSV text of a table: commented header lines (version, method, tolerance, grid), then the columns."""
    buf = io.StringIO()
    buf.write(f"# fitlab {__version__} exact table: {table.name}\n")
    buf.write(f"# method: {table.method}\n")
    buf.write(f"# tolerance: {table.tolerance}\n")
    buf.write(f"# grid: {table.grid}\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(table.columns)
    for row in table.rows:
        w.writerow([_fmt(x) for x in row])
    return buf.getvalue()


class TableError(Exception):
    """A table is missing, malformed, or disagrees with a recomputation."""


def read_table(path: Path, columns: tuple[str, ...] | None = None) -> tuple[list[str], np.ndarray]:
    """Read a table written by :func:`write_tables`; ``columns`` is the header it must have."""
    path = Path(path)
    if not path.exists():
        raise TableError(f"{path}: missing; run `fitlab tabulate` to create it")
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    if not lines:
        raise TableError(f"{path}: empty; run `fitlab tabulate` to rewrite it")
    header = lines[0].split(",")
    if columns is not None and tuple(header) != tuple(columns):
        raise TableError(f"{path}: header {header}, expected {list(columns)}; run `fitlab tabulate` to rewrite it")
    try:
        data = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    except ValueError as exc:
        raise TableError(f"{path}: unreadable number ({exc}); run `fitlab tabulate` to rewrite it") from None
    if data.ndim != 2 or data.shape[1] != len(header):
        raise TableError(f"{path}: rows do not match the header {header}; run `fitlab tabulate`")
    return header, data


def write_tables(out: Path, tables: dict) -> dict[str, str]:
    """Write ``tables`` ({file name: Table}) into ``out`` as one unit; returns file name -> sha256 prefix."""
    texts = {name: format_table(t) for name, t in tables.items()}
    atomic_write_many({Path(out) / name: text.encode() for name, text in texts.items()})
    return {name: hashlib.sha256(text.encode()).hexdigest()[:16] for name, text in texts.items()}
