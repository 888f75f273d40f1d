r"""Fitting a table of one's own: a column of a CSV file, numpy arrays, or a Python function sampled on a grid.

The table has rows (x_i, y_i): x_i in R^d the inputs (columns named by identifiers), y_i the fitted column.
The form is text, f(theta; x), an expression in the inputs and the parameters a0, a1, ... (every name
a<digits> is a parameter, in numeric order), read by the restricted parser
(:func:`fitlab.forms.symbolic.parse_expression`): numbers, names, + - * / **, a fixed set of functions;
nothing is evaluated as code.

* Rows: those inside ``domain`` (a box {input: (lo, hi)}, edges included; default every row).  The
  domain the fit states, validates on and generated code clamps its inputs into is the bounding box of
  those rows, so it never claims more than the data covers.
* Split: the rows sorted by their inputs (lexicographically, in input order); the rows at sorted
  positions k = offset, offset + every, offset + 2 every, ... (every = 4, offset = 2 by default: one row
  in four, the first kept for the fit) are held out.  The held-out rows interleave the fitted ones along
  the last input and the fit never sees them.
* Error: relative with a floor, e_i = |f(x_i) - y_i| / max(|y_i|, s0), s0 = 1e-3 max_j |y_j| over the
  rows used (finite where the column is 0, and the plain relative error wherever |y| >= s0); or absolute,
  e_i = |f(x_i) - y_i|.  The record's ``validation`` (max_rel, rms_rel, max_abs, points, worst) is
  this e on the held-out rows; max_abs is always |f - y|.
* Fit: :func:`fitlab.fit.refit.refit`, the one the built-in targets use, with the table as the
  target's training and validation sets: least squares on e with optimistix Levenberg-Marquardt from
  the start values (a<k> = 1/(k + 1) unless given), then ``minimax_rounds`` rounds of Lawson's
  minimax refinement (the best max training error kept).

Every check is made before any fit starts, each refusal one :class:`UserDataError` line: a missing or
non-numeric column, NaN or inf, an input that does not vary, duplicate input points, fewer rows than
2 x parameters to fit or than the parameters held out, an expression the parser refuses or that names
a name which is no input, no parameters, a form not finite at the start values, and a form the data
cannot determine: the Jacobian of the scaled residuals in the parameters at the start values, each
column normalised, of numerical rank below the number of parameters (singular values below
:data:`RANK_RTOL` times the largest), as a0*a1*x has.  And every limit (:func:`limits_text`): those of
the fit-file format (:func:`fitlab.store.fit_limits`; the record the fit will write is made from the
start values and checked as the store checks a record it writes), a cell that is not a plain decimal
number or a line break inside a cell, a column's scale (:data:`VALUE_RANGE`), rows times parameters
(:data:`MAX_ROW_PARAMETERS`).

The result is a :class:`UserFit`: the fit record (format fitlab-fit/1 with ``user_data``, which
:mod:`fitlab.store` checks against the record's own inputs and domain), callable like
:class:`fitlab.store.FitFunction`, with how well the data determine its parameters
(:func:`conditioning`); ``save`` writes it with its table beside it, ``generate`` prints it in every
language codegen knows (:mod:`fitlab.codegen.single`).
"""

from __future__ import annotations

# The modules, by job: the limits and the error (_limits), names (_names: the keywords of every language codegen
# prints), the table (_table), the form and its start (_form), the rows and their split (_split), measuring a fit
# again (_measure) and the fit (_fit).  fitlab.codegen.single imports the modules it needs (_table, _split,
# _measure) rather than this package, whose _fit imports it (UserFit.generate).
from fitlab.fit.user._fit import (
    ILL_CONDITION,
    ILL_PARAMETER,
    UserFit,
    conditioning,
    conditioning_warning,
    fit_function,
    fit_table,
    prepare,
    run_fit,
    stages,
    user_record,
)
from fitlab.fit.user._form import user_form
from fitlab.fit.user._limits import (
    HOLDOUT_EVERY,
    MAX_ROW_PARAMETERS,
    MAX_TABLE_BYTES,
    MAX_TABLE_ROWS,
    MINIMAX_ROUNDS,
    RANK_RTOL,
    SCALE_FLOOR,
    VALUE_RANGE,
    UserDataError,
    limits_text,
)
from fitlab.fit.user._measure import nonfinite_point, remeasure
from fitlab.fit.user._names import RESERVED, RESERVED_INPUTS, check_name
from fitlab.fit.user._split import Rows, held_out_rows, not_comparable, prepare_rows, split_text
from fitlab.fit.user._table import UserTable, read_csv_table, table_beside, table_from_arrays

__all__ = [
    "UserDataError",
    "UserTable",
    "UserFit",
    "Rows",
    "fit_table",
    "fit_function",
    "prepare",
    "prepare_rows",
    "run_fit",
    "stages",
    "user_record",
    "read_csv_table",
    "table_beside",
    "table_from_arrays",
    "check_name",
    "user_form",
    "held_out_rows",
    "remeasure",
    "nonfinite_point",
    "not_comparable",
    "split_text",
    "HOLDOUT_EVERY",
    "SCALE_FLOOR",
    "RANK_RTOL",
    "MAX_TABLE_BYTES",
    "MAX_TABLE_ROWS",
    "MINIMAX_ROUNDS",
    "MAX_ROW_PARAMETERS",
    "conditioning",
    "conditioning_warning",
    "ILL_PARAMETER",
    "ILL_CONDITION",
    "VALUE_RANGE",
    "RESERVED",
    "RESERVED_INPUTS",
    "limits_text",
]
