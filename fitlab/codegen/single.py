r"""One fit as a program of its own: a fit of a user's table (``fitlab fit``, :func:`fitlab.fit_table`,
:func:`fitlab.fit_function`) in every language :mod:`fitlab.codegen` prints (:data:`fitlab.codegen.LANGUAGES`).

The program holds one routine: the fit's expression with its parameters as numbers, named after the form,
in files named after the fitted column (``E.h``/``E.c``, ``E.glsl``, ``E.py``, ...: ``E_rational(mu, alpha)``
for the form ``rational`` of a column ``E``).  Every input is clamped into the fit's domain, the bounding box
of the rows it was fitted and validated on (:func:`fitlab.codegen.with_domain`: NaN stays NaN,
+-inf and other values outside are clamped).

The routine's documentation and the banner state that domain and the held-out error measured again at
generation: the table the fit names (a file beside the fit) is read (its sha256 must be the one the fit
states), its rows are checked and split again as the fit says, and every figure the banner prints of it (the
domain, the rows, the error's floor, the split) must be the one the table gives
(:func:`fitlab.fit.user.remeasure`); the fit is measured on the held-out rows.  The number the fit file
states is not copied: it must agree with the one measured to rounding, else the fit and its table disagree
and nothing is generated (:class:`fitlab.store.FitFileError`).  The routine must be finite on a dense probe of
its domain (:func:`fitlab.fit.user.nonfinite_point`).
"""

from __future__ import annotations

import math
from pathlib import Path

from fitlab.codegen._model import Program, Routine
from fitlab.codegen._policy import with_domain
from fitlab.codegen.languages import LANGUAGES, emit
from fitlab.store import FitFileError, FitFunction, fit_sha256, load

__all__ = [
    "user_program",
    "generate_user_fit",
    "read_user_fit",
    "generate_fit_file",
    "codegen_fit_command",
    "AGREEMENT_RTOL",
]

#: the relative difference allowed between the held-out error a fit states and the one measured again (the
#: two evaluate one expression in different orders of operations)
AGREEMENT_RTOL = 1e-6


def _agrees(stated: float, measured: float, unit: float) -> bool:
    stated, measured = float(stated), float(measured)
    if not (math.isfinite(stated) and math.isfinite(measured)):
        return stated == measured
    return abs(stated - measured) <= AGREEMENT_RTOL * max(abs(stated), abs(measured)) + 1e-12 * unit


def _measure_words(record: dict) -> str:
    user = record["user_data"]
    if user["error"] == "relative":
        return f"relative error |f - {record['target']}| / max(|{record['target']}|, {user['scale_floor']:.6g})"
    return f"absolute error |f - {record['target']}|"


def user_program(fit: FitFunction, table, source: tuple[str, str] | None = None) -> Program:
    """The one-routine :class:`Program` of the user fit ``fit`` (a :class:`FitFunction` of a record with
    ``user_data``), its held-out error measured again on ``table`` (:class:`fitlab.fit.user.UserTable`, the
    table the record names).  ``source``: (fit file name, sha256) the banner lists.  FitFileError (one line)
    when the fit is not a user fit, the table is not its table, or the error it states is not the one measured."""
    # the modules of fitlab.fit.user, not the package, which imports this module (UserFit.generate)
    from fitlab.fit.user._limits import UserDataError
    from fitlab.fit.user._measure import nonfinite_point, remeasure
    from fitlab.fit.user._split import split_text

    record = fit.record
    if "user_data" not in record:
        raise FitFileError(
            f"{fit.target}/{fit.form}: not a fit of a user's table (no user_data); `fitlab codegen "
            "--fits` prints the fits of fitlab's own targets"
        )
    try:
        measured = remeasure(record, table)
    except UserDataError as exc:
        raise FitFileError(f"{fit.path or f'{fit.target}/{fit.form}'}: {exc}") from None
    stated = record.get("validation", {})
    # an absolute error's rounding scales with the values
    unit = 1.0 if record["user_data"]["error"] == "relative" else max(abs(float(measured["worst"]["exact"])), 1.0)
    for key in ("max_rel", "rms_rel"):
        if key not in stated or not _agrees(stated[key], measured[key], unit):
            raise FitFileError(
                f"{fit.target}/{fit.form}: measured again on the held-out rows of {table.name}, the "
                f"{'max' if key == 'max_rel' else 'RMS'} error is {measured[key]:.6e}, not the "
                f"{float(stated.get(key, math.nan)):.6e} the fit states; the fit and its table disagree"
            )
    domain = {k: tuple(float(x) for x in v) for k, v in record["domain"].items()}
    where = ", ".join(f"{k} in [{lo!r}, {hi!r}]" for k, (lo, hi) in domain.items())
    bad = nonfinite_point(fit, domain)
    if bad is not None:
        at = ", ".join(f"{k} = {v!r}" for k, v in bad.items())
        raise FitFileError(f"{fit.target}/{fit.form}: not finite at {at}, inside its domain {where}; nothing generated")
    args = ", ".join(fit.inputs)
    user = record["user_data"]
    origin = {
        "csv": f"column {fit.target} of {Path(table.name).name}",
        "arrays": f"{fit.target} (arrays given to fitlab.fit_table)",
        "function": f"{fit.target} ({user.get('function', 'a sampled function')})",
    }[user["source"]]
    split = split_text(user["holdout_every"], user["holdout_offset"], fit.inputs)
    error = (
        f"held-out error measured again at generation on the {measured['points']} held-out rows ({split}), "
        f"{_measure_words(record)}: max "
        f"{measured['max_rel']:.3e}, RMS {measured['rms_rel']:.3e}; max absolute {measured['max_abs']:.3e}."
    )
    doc = (
        f"{fit.target}({args}) by the form {fit.form}, {record['expression'][:300]}"
        f"{'...' if len(record['expression']) > 300 else ''}, fitted to {origin} (sha256 {user['sha256'][:16]}..., "
        f"{user['rows']} rows). Valid on {where}: inputs outside are clamped into it (NaN stays NaN). The {error}"
    )
    routine = Routine(fit.form, fit.inputs, fit.expression, doc, domain=domain)
    about = (
        f"A fit of {origin} by the form {fit.form}: one function, {fit.target}_{fit.form}({args}) in C and the "
        f"shaders, {fit.form}({args}) in the Python and Dr.Jit modules.",
        f"Domain: {where} (inputs clamped into it).",
        f"The {error}",
        f"Table: {Path(table.name).name if user['source'] == 'csv' else user.get('file', table.name)} "
        f"(sha256 {user['sha256']}).",
    )
    python_doc = (
        f"{fit.target}, fitted by fitlab to a table of the user's: numpy only.\n\n"
        f"{fit.form}({args}) takes numpy arrays (any broadcastable shapes) and returns an array of "
        "float64.\n"
    )
    return Program((with_domain(routine),), (tuple(source),) if source else (), (), fit.target, about, python_doc)


def codegen_fit_command(lang: str, fit_name: str | None = None, single_header: bool = False) -> str:
    """The command the banner names: ``fitlab codegen --fit FILE --lang LANG``."""
    words = ["fitlab codegen", f"--fit {fit_name}" if fit_name else "--fit FIT.json", f"--lang {lang}"]
    return " ".join(words + (["--single-header"] if single_header else []))


def generate_user_fit(fit: FitFunction, table, lang: str, single_header: bool = False,
                      source: tuple[str, str] | None = None) -> dict[str, str]:  # fmt: skip
    """Source files ({name: text}) in ``lang`` of a user fit (:func:`user_program`)."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    program = user_program(fit, table, source)
    return emit(program, lang, codegen_fit_command(lang, source[0] if source else None, single_header), single_header)


def read_user_fit(path) -> tuple[FitFunction, object]:
    """The user fit in the file ``path`` and the table it names (``user_data.file``, relative to the fit's
    folder), read and checked; FitFileError (one line) when either is missing or refused."""
    from fitlab.fit.user._limits import UserDataError
    from fitlab.fit.user._table import read_csv_table

    path = Path(path)
    fit = load(path)
    user = fit.record.get("user_data")
    if user is None:
        raise FitFileError(
            f"{path}: a fit of fitlab's target {fit.target}, not of a user's table; print it with "
            "`fitlab codegen --fits FOLDER` (and --form)"
        )
    if "file" not in user:
        raise FitFileError(
            f"{path}: names no table file; codegen measures the held-out error again on the table, "
            "so save the fit with UserFit.save, which writes its table beside it"
        )
    table_path = path.parent / user["file"]  # a file name alone (fitlab.store checks it): the fit's folder
    if table_path.is_symlink():
        raise FitFileError(
            f"{path}: its table {user['file']} is a symbolic link; a fit's table is a file beside it, read only there"
        )
    try:
        table = read_csv_table(table_path)
    except UserDataError as exc:
        raise FitFileError(f"{path}: its table: {exc}") from None
    return fit, table


def generate_fit_file(path, lang: str, single_header: bool = False) -> dict[str, str]:
    """Source files ({name: text}) in ``lang`` of the user fit in the file ``path`` (:func:`read_user_fit`,
    :func:`generate_user_fit`); the banner names the fit file by name and sha256."""
    path = Path(path)
    fit, table = read_user_fit(path)
    return generate_user_fit(fit, table, lang, single_header, (path.name, fit_sha256(path)))
