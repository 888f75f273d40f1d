r"""The store: the owner of the fit-file format (fits/TARGET[.FORM].json) and the exact tables' (data/*.csv),
which reads and writes both.  One other writer forms its records here: a user's fit (:mod:`fitlab.fit.user`)
writes the record :func:`check_fit` checked and :func:`strict_json` printed, together with its table, as
one unit.

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
import os
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any, cast

import jsonschema
import jsonschema.exceptions
import numpy as np
import sympy as sp

from fitlab import __version__
from fitlab._io import (
    InputFileError,
    atomic_write_many,
    atomic_write_text,
    decimal,
    read_regular_file,
    text_lines,
    unusual_character,
)
from fitlab.core import get_target, target_names
from fitlab.forms import Form
from fitlab.forms.symbolic import lambdify_numpy, parse_expression, symbols
from fitlab.resources import packaged_fits

__all__ = [
    "FORMAT",
    "FitFileError",
    "FitFunction",
    "load",
    "read_fit",
    "read_checked_fit",
    "check_fit",
    "checked_fit",
    "fit_schema",
    "fit_limits",
    "FitLimits",
    "PARAM_LIMIT",
    "write_fit",
    "write_fits",
    "strict_json",
    "decode_nonfinite",
    "form_from_fit",
    "fits_folder",
    "fit_path",
    "fit_source",
    "fit_origin",
    "fit_files",
    "fit_sha256",
    "resolve_form",
    "Table",
    "TableError",
    "format_table",
    "read_table",
    "write_tables",
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


def write_fits(records: Mapping[Path, Mapping]) -> list[Path]:
    """Write several fit records ({path: record}) as one unit: all or none (see fitlab._io.atomic_write_many)."""
    texts = {Path(p): strict_json(dict(check_fit(dict(r), str(p)))).encode() for p, r in records.items()}
    atomic_write_many(texts)
    return list(texts)


def write_fit(path: Path, record: Mapping) -> None:
    """Check ``record`` (:func:`check_fit`: what fitlab writes, it can read back) and write it as JSON
    atomically (a temporary file, then a rename)."""
    path = Path(path)
    atomic_write_text(path, strict_json(dict(check_fit(dict(record), str(path)))))


#: the largest parameter magnitude a fit file may hold (the committed fits stay below 1e3)
PARAM_LIMIT = 1e12
#: the largest fit file read, in bytes
MAX_FIT_BYTES = 1_000_000


@lru_cache(maxsize=1)
def _validator():
    schema = json.loads(resources.files("fitlab").joinpath("schemas", "fit-1.schema.json").read_text())
    return jsonschema.Draft202012Validator(schema)


def fit_schema() -> dict:
    """The JSON Schema of the fit-file format (fitlab/schemas/fit-1.schema.json)."""
    return dict(cast(Mapping, _validator().schema))  # the schema file holds an object, not a boolean schema


@dataclass(frozen=True)
class FitLimits:
    """The sizes a fit file may have, as its schema states them (:func:`fit_limits`): what a fit must stay within
    to be saved, so what ``fitlab fit`` checks before it starts.

    inputs: inputs of a fit (the schema's ``inputs``, ``domain``, ``user_data.columns`` less the target, and
        ``validation.worst`` less its ``exact`` and ``approx``, whichever is fewest).
    params: parameters (``params``).
    name: characters of a name (target, form, input, parameter): the longest the schema's name pattern accepts.
    expression: characters of the expression text.
    text: characters of a text field (descriptions, the error measure, a grid's description).
    """

    inputs: int
    params: int
    name: int
    expression: int
    text: int


def _longest_match(pattern: str, limit: int = 10_000) -> int:
    """The length of the longest run of ``a`` the regular expression ``pattern`` accepts (0 if none)."""
    import re

    rx = re.compile(pattern)
    lo, hi = 0, limit  # the accepted lengths of a pattern like ^[A-Za-z][A-Za-z0-9_]{0,63}$ are 1..N
    if rx.search("a" * hi):
        return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if rx.search("a" * mid) else (lo, mid)
    return lo


@lru_cache(maxsize=1)
def fit_limits() -> FitLimits:
    """The limits of :class:`FitLimits`, read from the fit-file schema (fitlab/schemas/fit-1.schema.json)."""
    props = fit_schema()["properties"]
    valid, user = props["validation"]["properties"], props["user_data"]["properties"]
    names = [props["target"]["pattern"], props["form"]["pattern"], props["inputs"]["items"]["pattern"],
             props["params"]["propertyNames"]["pattern"], user["columns"]["items"]["pattern"]]  # fmt: skip
    return FitLimits(
        inputs=min(
            props["inputs"]["maxItems"],
            props["domain"]["maxProperties"],
            user["columns"]["maxItems"] - 1,
            valid["worst"]["maxProperties"] - 2,
        ),
        params=props["params"]["maxProperties"],
        name=min(_longest_match(p) for p in names),
        expression=props["expression"]["maxLength"],
        text=min(props[k]["maxLength"] for k in ("target_description", "form_description", "error_measure", "note")),
    )


def _refuse_constant(name):
    raise ValueError(f'the JSON literal {name} (non-finite numbers are written as the strings "inf", "nan")')


def check_fit(record, source: str = "fit") -> dict:
    """:func:`checked_fit` without the expression: the record, with non-finite strings decoded."""
    return checked_fit(record, source)[0]


def checked_fit(record, source: str = "fit") -> tuple[dict, sp.Expr]:
    """Check a fit record against the schema and the registry; returns it with non-finite strings decoded, and its
    expression read by the restricted parser (the one parse of a record).

    Refused with one :class:`FitFileError` line: anything the schema refuses (wrong types, unknown
    fields, names that are not plain identifiers, text a generated source could not quote), an unknown
    target, inputs other than the target's, a domain outside the target's, parameters that are not
    finite or exceed :data:`PARAM_LIMIT`, an expression the restricted parser refuses, and, for a form
    its family registers, parameters or an expression other than the registered form's.  Nothing in
    the record is evaluated as code.

    A record with ``user_data`` (a fit of a user's own table, :mod:`fitlab.fit.user`) is checked against
    its own stated inputs and domain instead of the registry (:func:`_checked_user_fit`); its target may
    not be a registered target's name, so that it is never taken for that target's fit.
    """
    if not isinstance(record, dict):
        raise FitFileError(f"{source}: not a fitlab fit (a JSON object is expected)")
    missing = [k for k in _REQUIRED if k not in record]
    if missing:
        raise FitFileError(f"{source}: not a fitlab fit, missing {missing}; regenerate it with `fitlab refit`")
    if record["format"] != FORMAT:
        raise FitFileError(f"{source}: format {str(record['format'])[:40]!r}, this fitlab reads {FORMAT!r}")
    error = jsonschema.exceptions.best_match(_validator().iter_errors(record))
    if error is not None:
        where = "/".join(str(x) for x in error.absolute_path) or "the top level"
        raise FitFileError(f"{source}: not a valid fit file at {where}: {error.message[:200]}")
    huge = _huge_integer(record)
    if huge is not None:
        raise FitFileError(f"{source}: {huge}; a fit file's numbers are doubles (magnitude below 1.8e308)")
    if "user_data" in record:  # a fit of a user's own table: checked against its own inputs and domain
        return _checked_user_fit(record, source)
    try:
        target = get_target(record["target"])
    except KeyError:
        raise FitFileError(f"{source}: unknown target {record['target']!r}") from None
    if set(record["inputs"]) != set(target.inputs):
        raise FitFileError(f"{source}: inputs {record['inputs']}, {target.name} takes {list(target.inputs)}")
    if set(record["domain"]) != set(record["inputs"]):
        raise FitFileError(f"{source}: the domain must give every input, and only those: {list(target.inputs)}")
    for name, (lo, hi) in record["domain"].items():
        full_lo, full_hi = target.domain[name]
        if not (full_lo <= lo < hi <= full_hi):
            raise FitFileError(f"{source}: domain of {name} [{lo:g}, {hi:g}] is not inside [{full_lo:g}, {full_hi:g}]")
    for group in ("params", "fixed"):
        for name, value in record.get(group, {}).items():
            if not (math.isfinite(value) and abs(value) <= PARAM_LIMIT):
                raise FitFileError(
                    f"{source}: {group} {name} = {value!r} is not a finite number of magnitude <= {PARAM_LIMIT:g}"
                )
    fixed = record.get("fixed", {})
    if not set(fixed) <= set(record["params"]) or any(record["params"][k] != v for k, v in fixed.items()):
        raise FitFileError(f"{source}: fixed parameters must be parameters, with the same values")
    form = target.forms.get(record["form"])
    if form is not None:
        if tuple(record["params"]) != tuple(form.params) and set(record["params"]) != set(form.params):
            raise FitFileError(f"{source}: params {list(record['params'])}, form {form.key} has {list(form.params)}")
        if record["expression"] != form.expression:
            raise FitFileError(f"{source}: the expression is not that of the registered form {form.key}")
    try:
        expr = parse_expression(record["expression"], (*record["inputs"], *record["params"]))
    except ValueError as exc:
        raise FitFileError(f"{source}: {exc}") from None
    return _decode(record), expr


def _huge_integer(value, where: str = "") -> str | None:
    """Where ``value`` (a record, walked) holds an integer too large for a double (JSON integers read as Python
    ints of any size), as "params/a0 is an integer of 401 digits"; None when it holds none."""
    if isinstance(value, int) and not isinstance(value, bool):
        try:
            float(value)
        except OverflowError:
            digits = int(abs(value).bit_length() * math.log10(2)) + 1  # str() of such an int may be refused
            return f"{where or 'the record'} is an integer of about {digits} digits"
        return None
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        found = _huge_integer(item, f"{where}/{key}" if where else str(key))
        if found is not None:
            return found
    return None


def _checked_user_fit(record: dict, source: str) -> tuple[dict, sp.Expr]:
    """:func:`checked_fit` of a record with ``user_data`` (already valid by the schema): its target is no
    registered target's name and is not among its inputs; ``user_data.columns`` are its inputs then its
    target; its domain gives every input, and only those, as finite intervals lo < hi; a relative error
    measure has a finite scale floor > 0 and the held-out rows are every ``holdout_every``-th from
    ``holdout_offset`` < ``holdout_every``; parameters finite and of magnitude <= :data:`PARAM_LIMIT`; the
    expression read by the restricted parser, in its inputs and parameters only."""
    name, inputs, user = record["target"], list(record["inputs"]), record["user_data"]
    if name in target_names():
        raise FitFileError(f"{source}: a fit of a user's table may not take the name of the registered target {name}")
    if name in inputs or set(inputs) & set(record["params"]):
        raise FitFileError(f"{source}: the target {name} and the parameters must not be among the inputs {inputs}")
    if list(user["columns"]) != [*inputs, name]:
        raise FitFileError(f"{source}: user_data.columns must be the inputs then the target: {[*inputs, name]}")
    if set(record["domain"]) != set(inputs):
        raise FitFileError(f"{source}: the domain must give every input, and only those: {inputs}")
    for key, (lo, hi) in record["domain"].items():
        if not (isinstance(lo, (int, float)) and isinstance(hi, (int, float)) and math.isfinite(lo)
                and math.isfinite(hi) and lo < hi):  # fmt: skip
            raise FitFileError(f"{source}: domain of {key} {[lo, hi]} is not a finite interval lo < hi")
    floor = user["scale_floor"]
    if not math.isfinite(floor) or (user["error"] == "relative" and not floor > 0.0):
        raise FitFileError(f"{source}: user_data.scale_floor {floor!r}: a relative error needs a finite floor > 0")
    if user["holdout_offset"] >= user["holdout_every"]:
        raise FitFileError(f"{source}: user_data.holdout_offset must be below holdout_every")
    file = user.get("file")
    if file is not None and (file in (".", "..") or "/" in file):
        raise FitFileError(
            f"{source}: user_data.file {file[:80]!r} is a path; a fit's table is a file beside it, named by its "
            "file name alone (copy the table beside the fit and write its name there, or fit again)"
        )
    for group in ("params", "fixed"):
        for key, value in record.get(group, {}).items():
            if not (math.isfinite(value) and abs(value) <= PARAM_LIMIT):
                raise FitFileError(
                    f"{source}: {group} {key} = {value!r} is not a finite number of magnitude <= {PARAM_LIMIT:g}"
                )
    fixed = record.get("fixed", {})
    if not set(fixed) <= set(record["params"]) or any(record["params"][k] != v for k, v in fixed.items()):
        raise FitFileError(f"{source}: fixed parameters must be parameters, with the same values")
    try:
        expr = parse_expression(record["expression"], (*inputs, *record["params"]))
    except ValueError as exc:
        raise FitFileError(f"{source}: {exc}") from None
    return _decode(record), expr


def read_fit(path: Path, target: str | None = None) -> dict:
    """:func:`read_checked_fit` without the expression."""
    return read_checked_fit(path, target)[0]


def read_checked_fit(path: Path, target: str | None = None) -> tuple[dict, sp.Expr]:
    """Read and check a fit file (:func:`check_fit`); every failure is one :class:`FitFileError` line.

    ``target``: the target the caller expects.  A file named after a registered target
    (TARGET.json, TARGET.FORM.json) must hold a fit of that target and form, so that a fit saved
    under another target's name is never taken for it."""
    path = Path(path)
    try:  # a regular file of at most MAX_FIT_BYTES, checked before it is opened: a FIFO or a device never blocks
        data = read_regular_file(path, MAX_FIT_BYTES)
    except InputFileError as exc:
        raise FitFileError(
            {
                "missing": f"{path}: no such fit file; run `fitlab refit --target NAME` to create it",
                "folder": f"{path}: a folder, not a fit file",
                "too_large": f"{path}: larger than {MAX_FIT_BYTES} bytes; not a fit file",
            }.get(exc.kind, f"{path}: {exc.refusal('fit file')}")
        ) from None
    try:
        record = json.loads(data.decode("utf-8"), parse_constant=_refuse_constant)
    except json.JSONDecodeError as exc:
        raise FitFileError(
            f"{path}: corrupt JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); "
            "regenerate it with `fitlab refit`"
        ) from None
    except (ValueError, RecursionError, UnicodeDecodeError) as exc:
        raise FitFileError(f"{path}: not a fit file ({str(exc)[:120] or type(exc).__name__})") from None
    record, expr = checked_fit(record, str(path))
    named = path.name.split(".")
    if len(named) in (2, 3) and named[-1] == "json" and named[0] in target_names():
        default = get_target(named[0]).default_form
        form = named[1] if len(named) == 3 else default
        if (record["target"], record["form"]) != (named[0], form):
            raise FitFileError(f"{path}: holds a fit of {record['target']}/{record['form']}, not {named[0]}/{form}")
    if target is not None and record["target"] != target:
        raise FitFileError(f"{path}: holds a fit of {record['target']}, not {target}")
    return record, expr


class FitFunction:
    """A saved fit as a callable on numpy arrays.

    ``f(mu=..., c=...)`` or positionally in the order of ``f.inputs``; inputs
    broadcast.  Inputs outside the fit's domain raise ValueError: a fit says
    nothing outside the domain it was validated on.
    """

    def __init__(self, record: dict, path: Path | None = None, *, checked: tuple[dict, sp.Expr] | None = None):
        # ``checked``: the (record, expression) pair :func:`read_checked_fit` already made (``load``)
        record, expr = checked if checked is not None else checked_fit(record, str(path or "fit"))
        self.record = record
        self.path = path
        self.target = record["target"]
        self.form = record["form"]
        self.inputs = tuple(record["inputs"])
        self.params = dict(record["params"])
        self.domain = {k: tuple(float(x) for x in v) for k, v in record["domain"].items()}
        # xreplace, not subs: the same substitution of symbols by numbers, without subs's matching (10x faster)
        expr = expr.xreplace({sp.Symbol(p, real=True): sp.Float(repr(float(v)), 17) for p, v in self.params.items()})
        self.expression = cast(sp.Expr, expr)  # sympy annotates xreplace as giving a Basic
        self._f = None  # the numpy function, made on the first call: codegen reads only the expression
        #: what :func:`fitlab.fit.verify.verify_fit` measured (error figures, the set and domain measured on), or None
        self.measured: dict | None = None

    def __repr__(self) -> str:
        return f"FitFunction({self.target}/{self.form}, inputs={self.inputs})"

    @property
    def physics(self) -> str:
        """The physics the fit was fitted against: the record's ``physics``, else (a file older than the field) its
        target's (:attr:`fitlab.core.Target.physics`)."""
        stated = self.record.get("physics")
        if stated is not None:
            return str(stated)
        try:
            return get_target(self.target).physics
        except KeyError:  # a fit of a table of one's own: its own values
            return "exact"

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
        return self.evaluate(*arrays)

    def evaluate(self, *arrays) -> np.ndarray:
        """The fit's expression at ``arrays`` (positional, in the order of :attr:`inputs`), without the domain
        check of a call: how a fit is measured beyond the domain it was made on."""
        arrays = [np.asarray(a, dtype=float) for a in arrays]
        if self._f is None:
            self._f = lambdify_numpy(symbols(self.inputs), self.expression)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self._f(*arrays)
        return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(a.shape for a in arrays))).copy()


def load(path, *, verify: bool = False, allow_partial_domain: bool = False) -> FitFunction:
    """Load a fit file written by ``fitlab refit`` as a :class:`FitFunction`.

    ``verify``: also re-measure the fit on its target's own validation set over the target's whole
    domain (:func:`fitlab.fit.verify.verify_fit`), and refuse it (one :class:`FitFileError` line naming
    the file) when it is non-finite anywhere there, or its error is more than 10 % worse than the one
    its record states; ``allow_partial_domain`` measures a fit made on part of the domain on that part
    only.  The figures measured are the fit's ``measured`` attribute (None without ``verify``)."""
    checked = read_checked_fit(path)
    fit = FitFunction(checked[0], Path(path), checked=checked)
    if verify:
        from fitlab.fit.verify import verify_fit  # the exact values: JAX and the families' engines, on demand

        verify_fit(fit, allow_partial_domain=allow_partial_domain)
    return fit


def form_from_fit(record: dict):
    """The :class:`fitlab.forms.Form` a fit record defines (its expression, parameters and fixed
    values), starting from the record's parameters: how a form found outside fitlab.forms (by
    ``fitlab discover``) is refitted like any other."""
    return _form(*checked_fit(record, f"{record.get('target')}/{record.get('form')}"))


def _form(record: dict, expr: sp.Expr) -> Form:
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
def fits_folder(fits_dir: Path | str | None = None) -> Path:
    """The folder fits are written to and read from first: ``fits_dir`` when given, else the fits packaged with
    fitlab (:func:`fitlab.resources.packaged_fits`).  Reading goes through :func:`fit_source`, which falls back
    to the packaged fits for what ``fits_dir`` lacks."""
    return Path(fits_dir) if fits_dir is not None else packaged_fits()


def fit_path(out: Path, target: str, form: str) -> Path:
    """fits/NAME.json for a target's default form, fits/NAME.FORM.json otherwise."""
    default = get_target(target).default_form
    return Path(out) / (f"{target}.json" if form == default else f"{target}.{form}.json")


def fit_sha256(path: Path) -> str:
    """The sha256 of a fit file's bytes (what generated code's banner names its sources by)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def fit_source(fits_dir: Path | str | None, target: str, form: str, packaged_folder: str = "") -> Path:
    """The file a fit of ``target`` in ``form`` is read from: ``fits_dir`` overlays the packaged fits, so it is
    fits_dir/NAME when anything of that name exists there (a folder or a FIFO too, which reading then refuses,
    rather than passing it over), else the packaged fit of that name (:func:`fit_path` names it); when neither
    exists, the path in ``fits_dir`` (whose reading then fails naming it).  ``fits_dir`` None: the packaged fits.

    ``packaged_folder``: a subfolder that overlays each folder in turn (a model's, :attr:`fitlab.codegen.Model.folder`:
    the packaged fits hold the parts fitted to the true BRDF in ``true/``): fits_dir/FOLDER/NAME, fits_dir/NAME,
    then the packaged FOLDER/NAME and NAME, the first there."""
    folders = [Path(fits_dir)] if fits_dir is not None else []
    folders.append(packaged_fits())
    if packaged_folder:
        folders = [f for folder in folders for f in (folder / packaged_folder, folder)]
    own = len(folders) - (2 if packaged_folder else 1)  # how many of them are the user's
    for k, folder in enumerate(folders):
        path = fit_path(folder, target, form)
        if os.path.lexists(path) if k < own else path.is_file():
            return path
    return fit_path(folders[0] if own else packaged_fits(), target, form)


def fit_origin(path: Path) -> str:
    """Where a fit file lies, as generated banners say it: "packaged" (the fits shipped with fitlab, wherever
    they are installed, or one of their subfolders: "packaged (true)") or "--fits" (a folder of the user's)."""
    try:
        folder, root = Path(path).resolve().parent, packaged_fits().resolve()
    except OSError:
        return "--fits"
    if folder == root:
        return "packaged"
    return f"packaged ({folder.name})" if folder.parent == root else "--fits"


def fit_files(fits_dir: Path | None, target: str) -> list[Path]:
    """Every saved fit of ``target`` in the folder ``fits_dir`` (None: the packaged fits): TARGET.json first, then
    TARGET.*.json by name.  A listing of one folder (what an inventory shows); a part a program needs is read
    through :func:`fit_source`, which overlays the folder on the packaged fits."""
    fits_dir = packaged_fits() if fits_dir is None else Path(fits_dir)
    return [p for p in (fits_dir / f"{target}.json",) if p.exists()] + sorted(fits_dir.glob(f"{target}.*.json"))


def resolve_form(target_name: str, form_name: str | None, fits_dir: Path | None = None) -> Form:
    """A target's form by name: from fitlab.forms, else (a form found by ``fitlab discover``) from
    the saved fit fits_dir/TARGET.FORM.json (None: the packaged fits), which holds the form's expression."""
    target = get_target(target_name)
    form_name = form_name or target.default_form
    if form_name in target.forms:
        return target.forms[form_name]
    path = fit_source(fits_dir, target.name, form_name)
    if path.exists():
        return _form(*read_checked_fit(path))
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


#: the largest table read, in bytes (the packaged tables stay below 1 MB; a 256 x 256 E table is 3.5 MB)
MAX_TABLE_BYTES = 50_000_000


def _table_error(path: Path, exc: InputFileError) -> TableError:
    if exc.kind == "missing":
        return TableError(f"{path}: missing; run `fitlab tabulate` to create it")
    return TableError(f"{path}: {exc.refusal('table')}")


def read_table(
    path: Path,
    columns: tuple[str, ...] | None = None,
    *,
    grid: str | None = None,
    points: Mapping[str, np.ndarray] | None = None,
    infinite: tuple[str, ...] = (),
) -> tuple[list[str], np.ndarray]:
    """Read a table written by :func:`write_tables`: (its header, its rows as an array of shape (rows, columns)).

    Refused with one :class:`TableError` line naming the table (and the line, for a bad row): a path that is
    not a regular file of at most :data:`MAX_TABLE_BYTES` (checked before it is opened, so that a FIFO or a
    device cannot block the read), text that is not UTF-8, a header other than ``columns`` (when given), no
    rows, a row with another number of fields than the header, a field that is not a number, NaN anywhere,
    an infinity other than +inf in the columns ``infinite`` (the tables write inf where the exact value is
    infinite: H at mu = inf and c = 1, for example); when ``grid`` is given, a "# grid:" header line other
    than ``grid``; when ``points`` ({column: values, one per row}) is given, another number of rows, or a
    row whose grid columns are not those values exactly (tables write a grid's numbers as Python's repr of
    the doubles, which reads back exactly)."""
    path = Path(path)
    try:
        raw = read_regular_file(path, MAX_TABLE_BYTES)
    except InputFileError as exc:
        raise _table_error(path, exc) from None
    rewrite = "run `fitlab tabulate` to rewrite it"
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise TableError(
            f"{path}: not UTF-8 text (byte {raw[exc.start]:#04x} at offset {exc.start}); {rewrite}"
        ) from None
    unusual = unusual_character(text)
    if unusual is not None:
        raise TableError(f"{path} line {unusual[0]}: holds {unusual[1]}; {rewrite}")
    header, stated, rows, first = None, None, [], 0
    allowed: list[bool] = []  # per column, whether +inf may stand there (set with the header)
    for number, line in enumerate(text_lines(text), start=1):
        if header is None and line.startswith("#"):  # comments head the file; below the header, a row is a row
            if stated is None and line.startswith("# grid:"):
                stated = line[len("# grid:") :].strip()
            continue
        if header is None:
            header = line.split(",")
            if columns is not None and tuple(header) != tuple(columns):
                raise TableError(f"{path}: header {str(header)[:300]}, expected {list(columns)}; {rewrite}")
            allowed = [name in infinite for name in header]
            first = number + 1
            continue
        fields = line.split(",")
        if len(fields) != len(header):
            plural = "s" if len(fields) != 1 else ""
            raise TableError(
                f"{path} line {number}: {len(fields)} field{plural}, the header has {len(header)}; {rewrite}"
            )
        try:
            row = [decimal(x) for x in fields]
        except ValueError:
            bad = next(x for x in fields if not _is_float(x))
            raise TableError(f"{path} line {number}: {bad[:40]!r} is not a number; {rewrite}") from None
        for j, x in enumerate(row):
            if not math.isfinite(x) and not (allowed[j] and x == math.inf):
                raise TableError(f"{path} line {number}: {header[j]} is {x!r}, not a finite number; {rewrite}")
        rows.append(row)
    if header is None:
        raise TableError(f"{path}: empty; {rewrite}")
    if not rows:
        raise TableError(f"{path}: no rows below the header; {rewrite}")
    if grid is not None and stated != grid:
        found = "no grid" if stated is None else f"the grid {stated[:200]!r}"
        raise TableError(f"{path}: its header states {found}, not {grid!r}; {rewrite}")
    data = np.array(rows, dtype=float)
    for name, want in (points or {}).items():
        want = np.asarray(want, dtype=float)
        if want.shape != (data.shape[0],):
            raise TableError(f"{path}: {data.shape[0]} rows, the grid its header states has {want.size}; {rewrite}")
        j = header.index(name)
        bad = data[:, j] != want
        if np.any(bad):
            i = int(np.argmax(bad))
            raise TableError(
                f"{path} line {first + i}: {name} is {float(data[i, j])!r}, the grid its header states "
                f"has {float(want[i])!r} there; {rewrite}"
            )
    return header, data


def _is_float(text: str) -> bool:
    try:
        decimal(text)
    except ValueError:
        return False
    return True


def write_tables(out: Path, tables: dict) -> dict[str, str]:
    """Write ``tables`` ({file name: Table}) into ``out`` as one unit; returns file name -> sha256 prefix."""
    texts = {name: format_table(t) for name, t in tables.items()}
    atomic_write_many({Path(out) / name: text.encode() for name, text in texts.items()})
    return {name: hashlib.sha256(text.encode()).hexdigest()[:16] for name, text in texts.items()}
