r"""Fitting a table of one's own: a column of a CSV file, numpy arrays, or a Python function sampled on a grid.

The table has rows (x_i, y_i): x_i in R^d the inputs (columns named by identifiers), y_i the fitted column.
The form is text, f(theta; x), an expression in the inputs and the parameters a0, a1, ... (every name
a<digits> is a parameter, in numeric order), read by the restricted parser
(:func:`fitlab.forms.symbolic.parse_expression`): numbers, names, + - * / **, a fixed set of functions;
nothing is evaluated as code.

Details: docs/your_own_data.md, section ``fitlab.fit.user``."""

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
