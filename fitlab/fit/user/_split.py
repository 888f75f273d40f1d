"""The rows a fit of one's own table uses: checked, restricted to a domain, and split into the rows fitted and the
rows held out; the error measure on them."""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fitlab.fit.user._limits import (
    HOLDOUT_EVERY,
    MAX_ROW_PARAMETERS,
    SCALE_FLOOR,
    VALUE_RANGE,
    UserDataError,
    power,
)
from fitlab.fit.user._names import check_name, not_registered
from fitlab.fit.user._table import UserTable

if TYPE_CHECKING:  # imported where used: importing fitlab.fit.user stays light
    from fitlab.core import Dataset

__all__ = [
    "Rows",
    "prepare_rows",
    "held_out_rows",
    "split_text",
    "not_comparable",
    "error_scale",
    "safe_text",
    "check_domain",
    "check_row_parameters",
    "box_text",
]


def _selected(xs: Mapping[str, np.ndarray], domain: Mapping[str, tuple[float, float]] | None) -> np.ndarray:
    keep = np.ones(len(next(iter(xs.values()))), dtype=bool)
    for name, (lo, hi) in (domain or {}).items():
        keep &= (xs[name] >= lo) & (xs[name] <= hi)
    return keep


def _sorted_order(xs: Mapping[str, np.ndarray], names) -> np.ndarray:
    """Row indices sorted by the inputs, the first input slowest (lexicographic)."""
    return np.lexsort([xs[n] for n in reversed(tuple(names))])


def held_out_rows(xs: Mapping[str, np.ndarray], names, every: int, offset: int) -> np.ndarray:
    """A mask of the held-out rows: sorted by the inputs ``names``, the rows at positions offset, offset +
    every, offset + 2 every, ..."""
    order = _sorted_order(xs, names)
    held = np.zeros(len(order), dtype=bool)
    held[order[offset::every]] = True
    return held


def split_text(every: int, offset: int, names) -> str:
    """The split in words: ``rows sorted by (mu, alpha), every 4th from the 3rd held out``."""
    return f"rows sorted by ({', '.join(names)}), every {_ordinal(every)} from the {_ordinal(offset + 1)} held out"


def _ordinal(n: int) -> str:
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


def error_scale(y: np.ndarray, error: str, floor: float) -> np.ndarray:
    return np.maximum(np.abs(y), floor) if error == "relative" else np.ones_like(y)


def measure_text(error: str, floor: float, target: str) -> str:
    if error == "relative":
        return (
            f"relative with a floor: |approx - {target}| / max(|{target}|, {floor:.6g}), the floor being "
            f"{SCALE_FLOOR:g} x the largest |{target}| of the rows used"
        )
    return f"absolute: |approx - {target}|"


def not_comparable(record: Mapping, rows: Rows) -> str | None:
    """Why the user fit ``record`` cannot be compared with a fit of ``rows`` on their held-out rows (another
    table, inputs, domain, split or error measure), or None when its held-out rows and error are theirs."""
    user, mine = record["user_data"], rows.user_data()
    if user["sha256"] != mine["sha256"]:
        return f"a fit of another table (sha256 {user['sha256'][:16]}..., this one {mine['sha256'][:16]}...)"
    if list(user["columns"]) != list(mine["columns"]):
        return f"a fit of the columns {', '.join(user['columns'])}, not {', '.join(mine['columns'])}"
    theirs = {k: (float(lo), float(hi)) for k, (lo, hi) in record["domain"].items()}
    if theirs != rows.domain:
        return f"a fit over {box_text(theirs)}, this one over {box_text(rows.domain)}"
    if (user["holdout_every"], user["holdout_offset"]) != (mine["holdout_every"], mine["holdout_offset"]):
        return f"a fit validated on other held-out rows (every {user['holdout_every']} from {user['holdout_offset']})"
    if (user["error"], float(user["scale_floor"])) != (mine["error"], float(mine["scale_floor"])):
        return f"a fit measured by another error ({user['error']}, floor {float(user['scale_floor']):g})"
    return None


def safe_text(text: str) -> str:
    """``text`` with every character a fit file's text fields refuse replaced by ?."""
    text = re.sub(r"[\x00-\x1f\x7f\"\\`]", "?", text)
    return text.replace("*/", "*?")


def check_domain(domain, inputs) -> dict[str, tuple[float, float]]:
    out: dict[str, tuple[float, float]] = {}
    for name, interval in (domain or {}).items():
        if name not in inputs:
            raise UserDataError(f"domain: {name!r} is not an input; the inputs are {', '.join(inputs)}")
        try:
            lo, hi = (float(x) for x in interval)
        except (TypeError, ValueError):
            raise UserDataError(f"domain {name}: give (LO, HI), two numbers") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise UserDataError(f"domain {name}={lo:g}:{hi:g}: need finite LO < HI")
        out[name] = (lo, hi)
    return out


@dataclass(frozen=True, eq=False)
class Rows:
    """The rows of a table a fit uses, checked and split: ``train`` and ``valid`` (:class:`fitlab.core.Dataset`),
    the domain (the bounding box of the rows used), the error measure and its floor, the split, and where
    the rows came from (``table``; ``train_rows``: the table's row index of each training point)."""

    target: str
    inputs: tuple[str, ...]
    train: Dataset
    valid: Dataset
    domain: dict
    floor: float
    error: str
    every: int
    offset: int
    table: UserTable
    used: int
    train_rows: np.ndarray

    def check_size(self, p: int, boxed: bool = False) -> None:
        """Refuse (one line) when a form of ``p`` parameters has fewer than 2p rows to fit or p held out, or more
        rows to fit times ``p`` than :data:`MAX_ROW_PARAMETERS`."""
        n_train, n_held = len(self.train), len(self.valid)
        check_row_parameters(self.table, n_train, p)
        if n_train < 2 * p or n_held < p:
            raise UserDataError(
                f"{self.table.name}: {self.used} rows{' in the domain' if boxed else ''}, {n_train} to "
                f"fit and {n_held} held out; a form of {p} parameters needs at least {2 * p} to fit "
                f"and {p} held out"
            )

    def user_data(self) -> dict:
        """The record's ``user_data`` (less ``file``, which the writer sets)."""
        t = self.table
        return {
            "source": t.source,
            "sha256": t.sha256,
            "rows": t.rows,
            "columns": [*self.inputs, self.target],
            "holdout_every": self.every,
            "holdout_offset": self.offset,
            "error": self.error,
            "scale_floor": self.floor,
            **({"function": safe_text(t.function)[:2000]} if t.function else {}),
        }

    def target_object(self, form_name: str):
        """An unregistered :class:`fitlab.core.Target` whose training and validation sets are these rows, whose
        error is theirs: what :func:`fitlab.fit.refit.refit` and :func:`fitlab.discover.discover` fit."""
        from fitlab.core import Input, Target

        t = self.table
        source = {"csv": f"column {self.target} of the table {safe_text(Path(t.name).name)}",
                  "arrays": f"{self.target}, given to fitlab.fit_table as arrays",
                  "function": f"{self.target}, {safe_text(t.function)}"}[t.source]  # fmt: skip

        def scale(ds, floor=self.floor, error=self.error):
            return error_scale(ds.y, error, floor)

        return Target(
            name=self.target,
            description=f"{source}: a table of the user's ({t.rows} rows, sha256 {t.sha256[:16]}...)",
            variables=tuple(Input(n, self.domain[n]) for n in self.inputs),
            default_form=form_name,
            published=(),
            training=lambda: self.train,
            validation=lambda: self.valid,
            claimed="none stated: the validation is the held-out rows of the user's table",
            error_measure=measure_text(self.error, self.floor, self.target),
            scale=scale,
            minimax=True,
            note=(f"the domain is the bounding box of the {self.used} rows used; "
                  f"{split_text(self.every, self.offset, self.inputs)}"),
        )  # fmt: skip


def prepare_rows(table: UserTable, target: str, inputs, *, domain=None, error: str = "relative",
                 holdout_every: int = HOLDOUT_EVERY) -> Rows:  # fmt: skip
    """The checks of a table (module docstring) and its split: column ``target`` against the columns ``inputs``
    (every other column when None), the rows inside ``domain``; :class:`UserDataError` (one line) on the first
    refusal."""
    check_name(target, "the fitted column")
    not_registered(target)
    if target not in table.cells:
        raise UserDataError(f"{table.name}: no column {target!r} to fit; the header has {', '.join(table.header)}")
    inputs = [c for c in table.header if c != target] if inputs is None else list(inputs)
    for n in inputs:
        if n not in table.cells:
            raise UserDataError(f"{table.name}: no column {n!r}; the header has {', '.join(table.header)}")
        check_name(n, "input")
    if target in inputs:
        raise UserDataError(f"the fitted column {target} is also an input")
    if len(set(inputs)) != len(inputs):
        raise UserDataError(f"an input is named twice: {', '.join(inputs)}")
    if not inputs:
        raise UserDataError("no input column: name the inputs (--inputs) or use them in the form")
    from fitlab.store import fit_limits

    if len(inputs) > fit_limits().inputs:
        raise UserDataError(f"{len(inputs)} inputs; a fit file holds at most {fit_limits().inputs}")
    if error not in ("relative", "absolute"):
        raise UserDataError(f"error: relative or absolute, not {error!r}")
    if not (isinstance(holdout_every, (int, np.integer)) and 2 <= holdout_every <= 1000):
        raise UserDataError(f"holdout every {holdout_every!r}: an integer from 2 to 1000")
    box = check_domain(domain, inputs)

    xs_all = {n: table.column(n) for n in inputs}
    y_all = table.column(target)
    keep = _selected(xs_all, box)
    index = np.flatnonzero(keep)
    if not index.size:
        raise UserDataError(f"{table.name}: no row lies in the domain {box_text(box)}")
    xs, y = {n: x[keep] for n, x in xs_all.items()}, y_all[keep]
    for n, values in (*xs.items(), (target, y)):
        check_scale(table, n, values)
    fitted_domain = {n: (float(np.min(x)), float(np.max(x))) for n, x in xs.items()}
    for n, (lo, hi) in fitted_domain.items():
        if not lo < hi:
            raise UserDataError(
                f"{table.name}: input {n} is {lo:g} in every row{' of the domain' if box else ''}; "
                "an input must vary (leave it out)"
            )
    order = _sorted_order(xs, inputs)
    stacked = np.column_stack([xs[n][order] for n in inputs])
    same = np.flatnonzero(np.all(stacked[1:] == stacked[:-1], axis=1))
    if same.size:
        i, j = sorted((int(index[order[same[0]]]), int(index[order[same[0] + 1]])))
        point = ", ".join(f"{n}={xs_all[n][i]:.6g}" for n in inputs)
        raise UserDataError(
            f"{table.name}: {table.where(i)} and {table.where(j)} have the same inputs ({point}); one row per point"
        )
    every = int(holdout_every)
    offset = every // 2
    held = held_out_rows(xs, inputs, every, offset)
    error_floor = SCALE_FLOOR * float(np.max(np.abs(y)))
    if error == "relative" and not error_floor > 0.0:
        raise UserDataError(
            f"{table.name}: column {target} is 0 in every row; nothing to fit relative to (use the absolute error)"
        )
    floor = error_floor if error == "relative" else 0.0

    from fitlab.core import Dataset

    split = split_text(every, offset, inputs)
    label = safe_text(Path(table.name).name if table.source == "csv" else table.name)
    train = Dataset({n: x[~held] for n, x in xs.items()}, y[~held], f"{label}: the rows not held out ({split})")
    valid = Dataset({n: x[held] for n, x in xs.items()}, y[held], f"{label}: the held-out rows ({split})")
    return Rows(target, tuple(inputs), train, valid, fitted_domain, floor, error, every, offset, table, len(y),
                index[~held])  # fmt: skip


def check_row_parameters(table: UserTable, n_train: int, p: int) -> None:
    """Refuse ``n_train`` rows to fit times ``p`` parameters beyond :data:`MAX_ROW_PARAMETERS`."""
    if n_train * p > MAX_ROW_PARAMETERS:
        raise UserDataError(
            f"{table.name}: {n_train} rows to fit x {p} parameters = {n_train * p:.3g}; fitlab fits at most "
            f"{power(MAX_ROW_PARAMETERS)} (the fit's memory grows with both): fit fewer rows (--domain, or a "
            "thinned table) or fewer parameters"
        )


def check_scale(table: UserTable, name: str, values: np.ndarray) -> None:
    """Refuse a column whose largest |value| lies outside :data:`VALUE_RANGE` (0 excepted)."""
    lo, hi = VALUE_RANGE
    big = float(np.max(np.abs(values)))
    if big > hi or 0.0 < big < lo:
        raise UserDataError(
            f"{table.name}: column {name} reaches |{name}| = {big:.3g}; fitlab fits columns whose largest magnitude "
            f"lies between {power(lo)} and {power(hi)} (squares of the values must stay normal doubles): rescale it"
        )


def box_text(box) -> str:
    return ", ".join(f"{n}={lo:g}:{hi:g}" for n, (lo, hi) in box.items())
