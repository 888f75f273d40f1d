"""The fit of one's own table: every check before it starts (:func:`prepare`), the fit (:func:`run_fit`, the
refit of fitlab's own targets), how well the data determine its parameters, and the API's
:func:`fit_table` and :func:`fit_function`."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fitlab.fit.user._form import check_start, initial_values, jacobian, names_in, user_form
from fitlab.fit.user._limits import HOLDOUT_EVERY, MAX_TABLE_ROWS, MINIMAX_ROUNDS, UserDataError
from fitlab.fit.user._measure import remeasure
from fitlab.fit.user._names import check_name
from fitlab.fit.user._split import Rows, check_domain, check_row_parameters, error_scale, prepare_rows, safe_text
from fitlab.fit.user._table import UserTable, table_beside, table_file_name, table_from_arrays

if TYPE_CHECKING:  # imported where used: importing fitlab.fit.user stays light
    from fitlab.forms import Form
    from fitlab.store import FitFunction

__all__ = [
    "UserFit",
    "prepare",
    "run_fit",
    "stages",
    "user_record",
    "conditioning",
    "conditioning_warning",
    "ILL_PARAMETER",
    "ILL_CONDITION",
    "fit_table",
    "fit_function",
]


@dataclass(eq=False)
class UserFit:
    """A fit of a user's table: ``record`` (a fit-file record, format fitlab-fit/1 with ``user_data``),
    ``table`` (the rows as given), ``result`` (the optimiser's :class:`fitlab.fit.solver.FitResult`).

    Callable like the saved fit (:class:`fitlab.store.FitFunction`): ``fit(mu=..., alpha=...)``, inputs
    inside the domain it was validated on."""

    record: dict
    table: UserTable
    result: object = None
    _function: FitFunction | None = field(default=None, repr=False)
    #: how well the data determine the fitted parameters (:func:`conditioning`), or None when not measured
    conditioning: dict | None = None

    @property
    def warning(self) -> str | None:
        """One line when the fit is ill-conditioned (:func:`conditioning_warning`), else None."""
        return None if self.conditioning is None else conditioning_warning(self.conditioning)

    @property
    def function(self):
        """The fit as a :class:`fitlab.store.FitFunction`."""
        if self._function is None:
            from fitlab.store import FitFunction

            self._function = FitFunction(self.record)
        return self._function

    def __call__(self, *args, **kwargs):
        return self.function(*args, **kwargs)

    def __repr__(self) -> str:
        v = self.record["validation"]
        return (
            f"UserFit({self.record['target']}/{self.record['form']}, inputs={tuple(self.record['inputs'])}, "
            f"held-out max {v['max_rel']:.3e}, RMS {v['rms_rel']:.3e})"
        )

    @property
    def params(self) -> dict:
        return dict(self.record["params"])

    @property
    def domain(self) -> dict:
        return {k: tuple(v) for k, v in self.record["domain"].items()}

    @property
    def validation(self) -> dict:
        """The held-out error the record states (max_rel, rms_rel, max_abs, points, worst)."""
        return dict(self.record["validation"])

    def remeasure(self) -> dict:
        """The held-out error measured again from the table (:func:`remeasure`)."""
        return remeasure(self.record, self.table)

    def files(self, path) -> dict[Path, bytes]:
        """What :meth:`save` writes: {path: bytes}."""
        from fitlab.store import check_fit, strict_json

        path = Path(path)
        table_path = table_beside(path)
        record = {**self.record, "user_data": {**self.record["user_data"], "file": table_path.name}}
        return {table_path: self.table.data, path: strict_json(check_fit(record, str(path))).encode()}

    def save(self, path) -> list[Path]:
        """Write the fit to ``path`` (JSON) and the table beside it (:func:`table_beside`: the file's bytes, or
        the canonical CSV of arrays or a sampled function), as one unit (all or nothing); the record names the
        table by its file name, where ``fitlab codegen --fit`` reads it to re-measure the held-out error."""
        from fitlab._io import atomic_write_many

        files = self.files(path)
        atomic_write_many(files)
        return list(files)

    def generate(self, lang: str, single_header: bool = False) -> dict[str, str]:
        """Source files ({name: text}) of the fit in ``lang`` (one of fitlab.codegen.LANGUAGES), its
        banner and documentation stating the domain and the held-out error re-measured from the table
        (:func:`fitlab.codegen.single.user_program`)."""
        from fitlab.codegen.single import generate_user_fit

        return generate_user_fit(self.function, self.table, lang, single_header=single_header)


@dataclass(frozen=True, eq=False)
class _Prepared:
    """Everything a fit needs, checked: the rows, the form and its start values."""

    rows: Rows
    form: Form
    start: dict


def prepare(table: UserTable, target: str, form: str, *, inputs=None, domain=None, name=None, start=None,
            error: str = "relative", holdout_every: int = HOLDOUT_EVERY) -> _Prepared:  # fmt: skip
    """Every check of a fit of column ``target`` of ``table`` by the form text ``form`` (see the module
    docstring), before any work; :class:`UserDataError` (one line) on the first refusal.  ``inputs``: the
    input columns (default: the columns the form names, in the table's order)."""
    from fitlab.forms import Form

    check_name(target, "the fitted column")
    if inputs is None:  # the columns the form names, in the table's order
        named = set(names_in(form))
        inputs = [c for c in table.header if c in named and c != target]
        if not inputs:
            raise UserDataError(
                f"the form names no column of {table.name} ({', '.join(table.header)[:120]}); "
                "name the inputs (--inputs) or use them in the form"
            )
    columns = [c for c in table.header if c != target]
    expr, params, _ = user_form(form, list(inputs), columns)
    form_name = (
        check_name(name, "the form's name")
        if name is not None
        else "form_" + hashlib.sha256(str(expr).encode()).hexdigest()[:6]
    )
    start_values = initial_values(params, start)
    if not domain and isinstance(holdout_every, (int, np.integer)) and holdout_every >= 2:
        # every row is fitted or held out: the rows to fit follow from the count alone, before a number is read
        every = int(holdout_every)
        check_row_parameters(table, table.rows - len(range(every // 2, table.rows, every)), len(params))
    rows = prepare_rows(table, target, inputs, domain=domain, error=error, holdout_every=holdout_every)
    rows.check_size(len(params), bool(domain))
    description = f"a fit of {safe_text(form.strip())[:200]}"
    fitted = Form(target=target, name=form_name, inputs=rows.inputs, params=params, expr=expr,
                  start=start_values, description=description, refit_by_default=False)  # fmt: skip
    _check_savable(rows, fitted, start_values)
    check_start(fitted, start_values, rows.train, error_scale(rows.train.y, rows.error, rows.floor), table,
                 rows.train_rows)  # fmt: skip
    return _Prepared(rows, fitted, start_values)


def _check_savable(rows: Rows, form, start: dict) -> None:
    """Refuse a fit its fit file could not hold: the record the fit will write, made now with the start values
    for the fitted ones, checked as the store checks every record it writes (the schema's sizes, names and
    text; the parameters' magnitude), so that no limit of the format is met only after the fit."""
    from fitlab.fit.refit import fit_record
    from fitlab.fit.solver import FitResult
    from fitlab.store import FitFileError, check_fit, fit_limits

    limits = fit_limits()
    if len(form.expression) > limits.expression:
        raise UserDataError(
            f"the form's expression is {len(form.expression)} characters long as fitlab writes it; a fit file "
            f"holds at most {limits.expression}"
        )
    theta = form.vector(start)
    not_run = FitResult(theta, 0, 0, 0, "not run", 0.0, 0.0, 0.0, 0.0)
    with np.errstate(all="ignore"):  # the errors at the start values: a form not finite there is said below
        record = fit_record(rows.target_object(form.name), form, not_run, rows.train, rows.valid, rows.domain,
                            MINIMAX_ROUNDS)  # fmt: skip
    record = user_record(record, rows, MINIMAX_ROUNDS)
    record["user_data"]["file"] = table_file_name(form.target, form.name)
    try:
        check_fit(record, f"{form.target}/{form.name}")
    except FitFileError as exc:
        raise UserDataError(f"the fit could not be saved: {exc}") from None


def run_fit(prep: _Prepared, minimax_rounds: int = MINIMAX_ROUNDS, on_step=None) -> UserFit:
    """The fit of a prepared table (:func:`prepare`): :func:`fitlab.fit.refit.refit` with the table as the
    target's data, and the record's ``user_data``."""
    from fitlab.fit.refit import refit

    rows = prep.rows
    res = refit(rows.target_object(prep.form.name), prep.form, start=prep.start, minimax=minimax_rounds > 0,
                minimax_rounds=minimax_rounds, on_step=on_step)  # fmt: skip
    record = user_record(res.record, rows, minimax_rounds)
    return UserFit(record, rows.table, res.fit, conditioning=conditioning(prep, prep.form.vector(record["params"])))


#: a fitted parameter beyond this magnitude, or a condition number beyond :data:`ILL_CONDITION`, makes a fit
#: ill-conditioned (:func:`conditioning_warning`)
ILL_PARAMETER = 1e6
ILL_CONDITION = 1e12


def conditioning(prep: _Prepared, theta) -> dict:
    """How well the fitted rows determine the parameters ``theta`` of the prepared fit ``prep``: {"condition":
    the condition number of the Jacobian of the scaled residuals at ``theta`` (on at most :data:`RANK_ROWS`
    fitted rows) with its columns scaled to unit norm, so that a parameter's units do not count, only how
    nearly the columns depend on one another; "weak": the parameters of the direction it is weakest in
    (components of at least a tenth of the largest, in those scaled units); "large": [(name, value)] of the
    parameters beyond :data:`ILL_PARAMETER` in magnitude}."""
    form, train = prep.form, prep.rows.train
    theta = np.asarray(theta, dtype=float)
    xs = [train.inputs[n] for n in form.inputs]
    jac, _ = jacobian(form, theta, xs, error_scale(train.y, prep.rows.error, prep.rows.floor))
    large = [(p, float(v)) for p, v in zip(form.params, theta) if abs(v) > ILL_PARAMETER]
    norms = np.sqrt(np.sum(jac**2, axis=0))
    if not (np.all(np.isfinite(jac)) and np.all(norms > 0.0)):
        weak = [p for p, n in zip(form.params, norms) if not (math.isfinite(n) and n > 0.0)]
        return {"condition": math.inf, "weak": weak or list(form.params), "large": large}
    _, sv, vt = np.linalg.svd(jac / norms, full_matrices=False)
    condition = float(sv[0] / sv[-1]) if sv[-1] > 0.0 else math.inf
    direction = np.abs(vt[-1])
    weak = [p for p, c in zip(form.params, direction) if c >= 0.1 * np.max(direction)]
    return {"condition": condition, "weak": weak, "large": large}


def conditioning_warning(measured: Mapping) -> str | None:
    """One line naming the parameters when :func:`conditioning` finds the fit ill-conditioned (a parameter
    beyond :data:`ILL_PARAMETER`, or a condition number beyond :data:`ILL_CONDITION`), else None."""
    words = []
    if measured["large"]:
        listed = ", ".join(f"{p} = {v:.3g}" for p, v in measured["large"])
        words.append(f"{listed} beyond {ILL_PARAMETER:g} in magnitude")
    if measured["condition"] > ILL_CONDITION:
        words.append(
            f"the Jacobian's condition number at the solution is {measured['condition']:.2g} (beyond "
            f"{ILL_CONDITION:g}), weakest along {', '.join(measured['weak'])}"
        )
    if not words:
        return None
    return (
        f"ill-conditioned: {'; '.join(words)}: other parameters fit the rows about as well, and the "
        "digits printed are not all determined by the data (simplify the form, or rescale its inputs)"
    )


def user_record(record: dict, rows: Rows, minimax_rounds: int) -> dict:
    """A refit's record as the record of a fit of a user's table: ``user_data`` added, the objective in the
    user's error, no published presets."""
    record.pop("published", None)
    record["optimizer"]["objective"] = (
        f"least squares of the {rows.error} error (error_measure), then Lawson minimax refinement "
        f"({minimax_rounds} rounds, best max error kept)"
        if minimax_rounds > 0
        else f"least squares of the {rows.error} error (error_measure)"
    )
    record["user_data"] = rows.user_data()
    return record


def stages(minimax_rounds: int = MINIMAX_ROUNDS) -> int:
    """How many times :func:`run_fit` calls its ``on_step`` (at most)."""
    return 3 + max(0, minimax_rounds)


def _progress(enabled: bool, rounds: int, label: str):
    from tqdm import tqdm

    bar = tqdm(total=stages(rounds), desc=label, unit="stage", leave=False, disable=not enabled)

    def on_step(stage):
        bar.set_postfix_str(stage, refresh=False)
        bar.update()

    return bar, on_step


def fit_table(inputs: Mapping[str, object], values, form: str, *, target: str = "y", name: str | None = None,
              domain: Mapping[str, tuple[float, float]] | None = None, start: Mapping[str, float] | None = None,
              error: str = "relative", holdout_every: int = HOLDOUT_EVERY, minimax_rounds: int = MINIMAX_ROUNDS,
              progress: bool = True) -> UserFit:  # fmt: skip
    """Fit the form ``form`` (text in the inputs and parameters a0, a1, ...) to the rows
    (``inputs[name][i]``, ``values[i]``), numpy arrays of one length: the fit ``fitlab fit`` makes of a CSV
    file (module docstring: rows, split, error, fit).

    target: the fitted quantity's name (the record's target; generated code's files and function prefix).
    name: the form's name (default form_ and 6 hex digits of the expression).
    domain: {input: (lo, hi)}: fit only the rows inside (edges included).
    start: start values of some parameters (the others start at a<k> = 1/(k + 1)).
    error: "relative" (with a floor: 1e-3 of the largest |value|) or "absolute".
    holdout_every: one row in this many is held out.
    minimax_rounds: Lawson rounds after least squares (0: least squares only).

    Every check is made before the fit (:class:`UserDataError`, one line).  Returns a :class:`UserFit`;
    nothing is written (``fit.save(path)`` writes it).
    """
    table = table_from_arrays(inputs, values, target)
    prep = prepare(table, target, form, inputs=list(inputs), domain=domain, name=name, start=start, error=error,
                   holdout_every=holdout_every)  # fmt: skip
    bar, on_step = _progress(progress, minimax_rounds, f"fit {target}/{prep.form.name}")
    try:
        return run_fit(prep, minimax_rounds, on_step)
    finally:
        bar.close()


def fit_function(function: Callable, domain: Mapping[str, tuple[float, float]], form: str, *,
                 n: int | Mapping[str, int] | None = None, target: str = "f", **options) -> UserFit:  # fmt: skip
    """Sample ``function`` on a tensor grid over ``domain`` ({input: (lo, hi)}, in argument order) and fit the
    form to it (:func:`fit_table`, whose ``options`` it takes).

    The grid: ``n`` points per input (an int, or one per input; default round(4096^(1/d)) for d inputs:
    4096, 64, 16, 8, ...), numpy.linspace(lo, hi, n), so the domain's edges are sample points.  The function
    is called once, with keyword arrays of every grid point (``function(mu=..., alpha=...)``), and must
    return an array of their length (numpy broadcasting).
    """
    names = list(domain)
    if not names:
        raise UserDataError("domain: give at least one input, {name: (lo, hi)}")
    box = check_domain(domain, names)
    counts = {k: n if isinstance(n, int) or n is None else n.get(k) for k in names}
    default = max(2, round(4096 ** (1.0 / len(names))))
    axes = []
    for k in names:
        count = default if counts[k] is None else counts[k]
        if not isinstance(count, (int, np.integer)) or count < 2:
            raise UserDataError(f"n for {k}: an integer >= 2, not {count!r}")
        axes.append(np.linspace(*box[k], int(count)))
    if math.prod(len(a) for a in axes) > MAX_TABLE_ROWS:
        raise UserDataError(f"the grid has more than {MAX_TABLE_ROWS} points; give a smaller n")
    grid = [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]
    points = dict(zip(names, grid))
    label = getattr(function, "__qualname__", None) or type(function).__name__
    try:
        with np.errstate(all="ignore"):
            values = np.asarray(function(**points), dtype=float)
    except Exception as exc:  # noqa: BLE001 - the user's function: its failure, in one line
        raise UserDataError(f"calling {label} on the grid failed: {type(exc).__name__}: {str(exc)[:120]}") from None
    if values.shape != grid[0].shape:
        try:
            values = np.broadcast_to(values, grid[0].shape).copy()
        except ValueError:
            raise UserDataError(
                f"{label} returned shape {values.shape}, not ({grid[0].size},): it must take and return arrays"
            ) from None
    sizes = " x ".join(str(len(a)) for a in axes)
    what = (
        f"the function {label} sampled on a {sizes} grid (numpy.linspace over "
        f"{', '.join(f'{k} [{lo:g}, {hi:g}]' for k, (lo, hi) in box.items())})"
    )
    options = dict(options)
    table = table_from_arrays(points, values, check_name(target, "the fitted quantity"), "function", what)
    prep = prepare(table, target, form, inputs=names, domain=None, name=options.pop("name", None),
                   start=options.pop("start", None), error=options.pop("error", "relative"),
                   holdout_every=options.pop("holdout_every", HOLDOUT_EVERY))  # fmt: skip
    rounds = options.pop("minimax_rounds", MINIMAX_ROUNDS)
    progress = options.pop("progress", True)
    if options:
        raise TypeError(f"fit_function() got unexpected options {sorted(options)}")
    bar, on_step = _progress(progress, rounds, f"fit {target}/{prep.form.name}")
    try:
        return run_fit(prep, rounds, on_step)
    finally:
        bar.close()
