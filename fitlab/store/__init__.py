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

The store reads and checks; it measures nothing: :func:`fitlab.fit.verify.verify_fit` measures a loaded fit
again on its target's validation set.  Its modules, by job: the JSON of a record (``_json``), the checks of a
record (``_check``: the schema, its limits, the registry), fit files and where they live (``_files``), a fit as
a function (``_function``) and the exact tables (``_tables``).
"""

from __future__ import annotations

from fitlab.store._check import (
    FORMAT,
    PARAM_LIMIT,
    FitFileError,
    FitLimits,
    check_fit,
    checked_fit,
    fit_limits,
    fit_schema,
)
from fitlab.store._files import (
    MAX_FIT_BYTES,
    fit_files,
    fit_origin,
    fit_path,
    fit_sha256,
    fit_source,
    fits_folder,
    read_checked_fit,
    read_fit,
    write_fit,
    write_fits,
)
from fitlab.store._function import FitFunction, form_from_fit, load, resolve_form
from fitlab.store._json import decode_nonfinite, strict_json
from fitlab.store._tables import MAX_TABLE_BYTES, Table, TableError, format_table, read_table, write_tables

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
    "MAX_FIT_BYTES",
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
    "MAX_TABLE_BYTES",
    "format_table",
    "read_table",
    "write_tables",
]
