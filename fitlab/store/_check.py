"""The checks of a fit record: the fit-file schema (fitlab/schemas/fit-1.schema.json), its limits, and the
registry (or, for a fit of a user's own table, the record's own inputs and domain)."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import cast

import jsonschema
import jsonschema.exceptions
import sympy as sp

from fitlab.core import get_target, target_names
from fitlab.forms.symbolic import parse_expression
from fitlab.store._json import decode_nonfinite

__all__ = ["FORMAT", "FitFileError", "PARAM_LIMIT", "FitLimits", "fit_schema", "fit_limits", "check_fit", "checked_fit"]

FORMAT = "fitlab-fit/1"

_REQUIRED = ("format", "target", "form", "inputs", "expression", "params", "domain")


class FitFileError(Exception):
    """A fit file is missing, unreadable, or not a fitlab fit."""


#: the largest parameter magnitude a fit file may hold (the committed fits stay below 1e3)
PARAM_LIMIT = 1e12


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
    return decode_nonfinite(record), expr


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
    return decode_nonfinite(record), expr
