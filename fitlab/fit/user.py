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

import ast
import csv
import gc
import hashlib
import io
import keyword
import math
import re
from collections.abc import Callable, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from fitlab._io import InputFileError, read_regular_file

if TYPE_CHECKING:  # imported where used: importing fitlab.fit.user stays light
    import sympy as sp

    from fitlab.core import Dataset
    from fitlab.forms import Form
    from fitlab.store import FitFunction

__all__ = [
    "UserDataError",
    "UserTable",
    "UserFit",
    "fit_table",
    "fit_function",
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
    "limits_text",
]

#: one row in HOLDOUT_EVERY is held out, from sorted position HOLDOUT_EVERY // 2
HOLDOUT_EVERY = 4
#: the relative error's floor, as a fraction of the largest |value| of the rows used
SCALE_FLOOR = 1e-3
#: a singular value of the column-normalised Jacobian below RANK_RTOL times the largest counts as zero
RANK_RTOL = 1e-10
#: the largest table file read, in bytes, and the most rows
MAX_TABLE_BYTES = 50_000_000
MAX_TABLE_ROWS = 1_000_000
#: the most rows to fit times parameters (a fit's Jacobian and the solver's work arrays take about 90 bytes
#: of each, 0.9 GB at the limit), and rows times candidate terms of a search (its regression's matrix)
MAX_ROW_PARAMETERS = 10_000_000
#: the largest |value| of a column fitted must lie in [lo, hi]: the fit squares and multiplies values, and the
#: square of a number outside overflows or falls below the smallest normal double (2.2e-308)
VALUE_RANGE = (1e-150, 1e150)
#: rows of the table the Jacobian's rank is measured on (evenly spaced among the fitted rows)
RANK_ROWS = 50_000
#: Lawson rounds by default: those of ``fitlab refit``
MINIMAX_ROUNDS = 40

_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")  # of at most fit_limits().name characters
_PARAMETER = re.compile(r"^a[0-9]+$")
_TEMPORARY = re.compile(r"^t[0-9]+$")  # generated code names its common subexpressions t0, t1, ...

#: names an input, a fitted column or a form may not have: keywords and types of the languages codegen prints
#: (C, C++ for Metal, GLSL, HLSL, Python), and the modules generated Python imports
RESERVED = frozenset(
    """
auto break case char const continue default do double else enum extern float for goto if inline int long register
restrict return short signed sizeof static struct switch typedef union unsigned void volatile while bool true false
class namespace new delete this template typename using public private protected virtual operator friend try catch
throw explicit mutable constexpr decltype nullptr alignas alignof noexcept static_assert thread_local char16_t
char32_t wchar_t export asm and or not xor bitand bitor compl
attribute uniform varying layout centroid flat smooth noperspective patch sample subroutine in out inout invariant
precise discard lowp mediump highp precision vec2 vec3 vec4 ivec2 ivec3 ivec4 bvec2 bvec3 bvec4 uvec2 uvec3 uvec4
dvec2 dvec3 dvec4 mat2 mat3 mat4 uint half float2 float3 float4 float3x3 float4x4 half2 half3 half4 min16float
texture sampler2D sampler3D samplerCube cbuffer tbuffer groupshared technique pass string vector matrix
kernel device constant thread threadgroup metal main numpy dr drjit math safe_pow log1p expm1
""".split()
) | frozenset(keyword.kwlist)
#: names an input may not have besides: the functions generated code calls (an argument of that name would
#: hide the function) and the parser's constants
RESERVED_INPUTS = frozenset(
    """
abs acos asin atan atan2 ceil clamp cos cosh cross degrees distance dot exp exp2 floor fma fmod fract inversesqrt
length log log2 max min mix mod normalize pow radians round sign sin sinh smoothstep sqrt step tan tanh trunc
saturate lerp rsqrt frac Abs Max Min pi E
""".split()
)


def limits_text() -> str:
    """The limits of a fit of one's own table, as docs/reliability.md states them (a Markdown list), from the
    constants the checks use: :func:`fitlab.store.fit_limits` (the fit-file schema's), :data:`MAX_TABLE_BYTES`,
    :data:`MAX_TABLE_ROWS`, :data:`MAX_ROW_PARAMETERS`, :data:`VALUE_RANGE` and
    :data:`fitlab.store.PARAM_LIMIT`.  Each is checked before any work (one line, exit status 2)."""
    from fitlab.store import PARAM_LIMIT, fit_limits

    lim = fit_limits()
    lo, hi = (_power(x) for x in VALUE_RANGE)
    return "\n".join([
        f"* inputs: at most {lim.inputs} (a fit file's `inputs`, `domain` and `user_data.columns`, and its worst "
        f"point, which names the inputs beside `exact` and `approx`);",
        f"* parameters: at most {lim.params} (`params`), each fitted value of magnitude at most {_power(PARAM_LIMIT)} "
        "(the start values are checked before the fit);",
        f"* rows x parameters: the rows fitted times the parameters at most {_power(MAX_ROW_PARAMETERS)}, and for "
        "`fitlab discover TABLE.csv` the rows times the library's terms and times `--max-terms` too (memory grows "
        "with both);",
        f"* names: at most {lim.name} characters each (the fitted column, `--name`, the inputs, the parameters "
        "a0, a1, ...: a letter, then letters, digits or _);",
        f"* the expression: at most {lim.expression:,} characters as fitlab writes it, the text fields of the "
        f"record at most {lim.text:,};",
        f"* the table: at most {MAX_TABLE_BYTES:,} bytes and {MAX_TABLE_ROWS:,} rows; each column fitted of "
        f"largest magnitude between {lo} and {hi} (0 aside), so that the fit's squares stay normal doubles.",
    ]) + "\n"  # fmt: skip


def _power(x: float) -> str:
    """A number as docs write it: a power of ten as 1e12, 1e-150; another as %g writes it."""
    mantissa, exponent = f"{x:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}" if mantissa == "1" and float(f"1e{int(exponent)}") == x else f"{x:g}"


class UserDataError(ValueError):
    """A table, form or option that fitlab refuses before any fit starts (one line)."""


# -- names -----------------------------------------------------------------------
def check_name(name, what: str) -> str:
    """``name`` if it can name an input, a fitted column or a form (an identifier of at most 64 characters
    that generated code can use: not a reserved word (:data:`RESERVED`; for an input :data:`RESERVED_INPUTS`
    too), not a parameter name a<digits>, not a generated temporary t<digits>); else :class:`UserDataError`."""
    from fitlab.store import fit_limits

    longest = fit_limits().name
    if not isinstance(name, str) or not _IDENTIFIER.match(name) or len(name) > longest:
        raise UserDataError(
            f"{what} {str(name)[:70]!r}{'...' if len(str(name)) > 70 else ''} is not a name fitlab can use: a "
            f"letter, then letters, digits or _ (at most {longest}); rename it"
        )
    if _PARAMETER.match(name):
        raise UserDataError(
            f"{what} {name!r} is named like a parameter (a0, a1, ... are the form's parameters); rename it"
        )
    if _TEMPORARY.match(name) or name in RESERVED or (what == "input" and name in RESERVED_INPUTS):
        raise UserDataError(f"{what} {name!r} is a reserved word of a language fitlab generates; rename it")
    return name


def _not_registered(target: str) -> None:
    from fitlab.core import targets

    registered = targets().get(target)
    if registered is not None:
        raise UserDataError(
            f"the fitted column is called {target}, like fitlab's built-in target {target} "
            f"({registered.family}); rename it so that its fit is never taken for that target's"
        )


# -- tables ----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class UserTable:
    """The rows of a user's table as read: every column by name (strings as in the file, or floats), where
    each row came from, and the bytes its sha256 is of.

    source: "csv" (a file), "arrays" (:func:`fitlab.fit_table`) or "function" (:func:`fitlab.fit_function`).
    name: the file's path as given, or a description.
    data: the file's bytes, or the canonical CSV text of the arrays (what :meth:`UserFit.save` writes).
    lines: the file line of each row (for messages), or None (rows numbered from 1).
    function: what was sampled (source "function").
    """

    source: str
    name: str
    header: tuple[str, ...]
    cells: Mapping[str, np.ndarray | Sequence]  # a column: an array, or the cells' texts
    data: bytes
    lines: np.ndarray | None = None
    function: str = ""

    @property
    def rows(self) -> int:
        return len(next(iter(self.cells.values())))

    def _numbers(self, name: str, cells: Sequence[str]) -> np.ndarray:
        parsed = _decimal_cells(cells)
        if isinstance(parsed, int):
            text = cells[parsed].strip()
            raise UserDataError(
                f"{self.name} {self.where(parsed)}: column {name} holds {text[:40]!r}, not a number (a number is "
                "written in ASCII digits, with an optional sign, point and exponent)"
            )
        return parsed

    @cached_property
    def sha256(self) -> str:
        return hashlib.sha256(self.data).hexdigest()

    def where(self, i: int) -> str:
        """Where row ``i`` is: ``line 12`` of a file, ``row 12`` of arrays."""
        return f"line {int(self.lines[i])}" if self.lines is not None else f"row {i + 1}"

    def column(self, name: str) -> np.ndarray:
        """Column ``name`` as finite floats; :class:`UserDataError` naming the table, the column and the row
        of a missing column, a cell that is not a number, NaN or inf."""
        if name not in self.cells:
            raise UserDataError(f"{self.name}: no column {name!r}; the header has {', '.join(self.header)}")
        raw = self.cells[name]
        values = raw if isinstance(raw, np.ndarray) else self._numbers(name, raw)
        bad = ~np.isfinite(values)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise UserDataError(
                f"{self.name} {self.where(i)}: column {name} is {float(values[i])!r}; every value "
                "must be a finite number"
            )
        return values


def _decimal_cells(cells: Sequence[str]) -> np.ndarray | int:
    """The cells as float64 when each is a plain decimal number (:data:`fitlab._io.DECIMAL`; spaces around it
    aside), else the index of the first that is not.  Python's float() takes a decimal as it is, and takes more
    only with a character outside ASCII or an underscore (995_099), which send the cells to the check one by
    one."""
    from fitlab._io import DECIMAL

    joined = "\n".join(cells)
    if joined.isascii() and "_" not in joined:  # float() reads these cells as the grammar does, spaces aside
        try:
            return np.array(cells, dtype=float)
        except ValueError:
            pass
    return next((i for i, text in enumerate(cells) if not DECIMAL.fullmatch(text.strip())), -1)


def read_csv_table(path) -> UserTable:
    """Read a CSV table: a header row naming the columns, then one row per point; lines starting with # and
    blank lines are skipped.  Refused with one :class:`UserDataError` line: a path that is not a regular file
    (checked with os.stat before it is opened, so that a FIFO or a device cannot hang the read), a file over
    :data:`MAX_TABLE_BYTES` or of more than :data:`MAX_TABLE_ROWS` rows, text that is not UTF-8 or not CSV, a
    missing header (a first row of numbers), empty or repeated column names, rows of another length than the
    header, no rows.  Cells stay text until :meth:`UserTable.column` reads them."""
    path = Path(path)
    try:  # fitlab._io.read_regular_file: type and size checked before the file is opened
        data = read_regular_file(path, MAX_TABLE_BYTES)
    except InputFileError as exc:
        raise UserDataError(f"{path}: {'no such file' if exc.kind == 'missing' else exc.refusal('table')}") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise UserDataError(f"{path}: not UTF-8 text; a table is a CSV file") from None
    with _collector_paused():  # a million rows are a million lists: the cyclic collector would walk them often
        numbers, records = _csv_rows(text, path)
        columns = list(zip(*records[1:]))  # the columns as read, a transpose in C
    if not records:
        raise UserDataError(f"{path}: empty; a table is a header row naming the columns, then one row per point")
    header = tuple(f.strip() for f in records[0])
    rows, lines = records[1:], numbers[1:]
    if len(rows) > MAX_TABLE_ROWS:
        raise UserDataError(f"{path}: {len(rows)} rows, more than {MAX_TABLE_ROWS}; fitlab fits tables of at most that")
    ragged = next((i for i, r in enumerate(rows) if len(r) != len(header)), None)
    if ragged is not None:
        raise UserDataError(f"{path} line {lines[ragged]}: {len(rows[ragged])} fields, the header has {len(header)}")
    if all(_is_number(f) for f in header):
        raise UserDataError(f"{path}: the first row is numbers; the first row must be a header naming the columns")
    if any(not f for f in header) or len(set(header)) != len(header):
        raise UserDataError(f"{path}: the header {', '.join(header)[:120]} has an empty or repeated column name")
    if not rows:
        raise UserDataError(f"{path}: a header and no rows")
    cells = dict(zip(header, columns))  # :meth:`UserTable.column` reads the numbers, spaces around them aside
    return UserTable("csv", str(path), header, cells, data, np.asarray(lines))


@contextmanager
def _collector_paused():
    """Python's cyclic garbage collector off while the block runs (and on again after, if it was on): reading a
    table builds millions of lists and strings, none in a cycle, and the collector's passes over them took most
    of the time."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _csv_rows(text: str, path) -> tuple[list[int], list[list[str]]]:
    """(line numbers, fields) of every CSV row, without comment (#) and blank lines; lines numbered as text
    editors number them (:func:`fitlab._io.text_lines`).  :class:`UserDataError` on a character a table may not
    hold (:func:`fitlab._io.unusual_character`: U+2028 splits a row for some readers), on a quoted cell that
    runs over the end of its line (a cell holding a line break), and on text the csv module refuses."""
    from fitlab._io import text_lines, unusual_character

    unusual = unusual_character(text)
    if unusual is not None:
        line, what = unusual
        raise UserDataError(f"{path} line {line}: holds {what}; a table is plain text, one row per line")
    lines = text_lines(text)
    numbers = [n for n, line in enumerate(lines, start=1) if line.strip() and not line.lstrip().startswith("#")]
    try:
        reader = csv.reader([lines[n - 1] for n in numbers])
        records = list(reader)
        if len(records) == len(numbers):  # each record one line
            return numbers, records
        reader = csv.reader(lines[n - 1] for n in numbers)  # again, to find the record that took two lines
        for k, _ in enumerate(reader):
            if reader.line_num != k + 1:
                raise UserDataError(
                    f"{path} line {numbers[k]}: a quoted cell runs over the end of the line (a cell holding a line "
                    "break); a cell is one line"
                )
    except csv.Error as exc:
        raise UserDataError(f"{path}: not CSV ({exc})") from None
    raise AssertionError("a record of two lines was not found")  # pragma: no cover - the counts differed


def _is_number(text: str) -> bool:
    from fitlab._io import DECIMAL

    return DECIMAL.fullmatch(text.strip()) is not None


def _format_csv(header, columns, comment: str) -> bytes:
    buf = io.StringIO()
    buf.write(f"# {comment}\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in zip(*columns):
        w.writerow([repr(float(x)) for x in row])
    return buf.getvalue().encode()


def table_from_arrays(inputs: Mapping[str, object], values, target: str, source: str = "arrays",
                      function: str = "") -> UserTable:  # fmt: skip
    """A :class:`UserTable` of numpy arrays (``inputs`` by name, ``values`` the fitted column, 1-D, one length):
    its bytes are the canonical CSV text of the rows (what :meth:`UserFit.save` writes beside the fit)."""
    names = [check_name(n, "input") for n in inputs]
    check_name(target, "the fitted column")
    if target in names:
        raise UserDataError(f"the fitted column {target} is also an input")
    if not names:
        raise UserDataError("no inputs: give at least one input array")
    arrays = {}
    for name, a in [*inputs.items(), (target, values)]:
        try:
            arr = np.asarray(a, dtype=float)
        except (TypeError, ValueError):
            raise UserDataError(f"{name}: not an array of numbers") from None
        if arr.ndim != 1:
            arr = arr.ravel() if arr.ndim > 1 else arr.reshape(1)
        arrays[name] = arr.copy()
    sizes = {len(a) for a in arrays.values()}
    if len(sizes) != 1:
        lengths = ", ".join(f"{k} {len(v)}" for k, v in arrays.items())
        raise UserDataError(f"the arrays have different lengths: {lengths}")
    if sizes == {0}:
        raise UserDataError("the arrays are empty")
    if len(arrays[target]) > MAX_TABLE_ROWS:
        raise UserDataError(f"{len(arrays[target])} rows; fitlab fits tables of at most {MAX_TABLE_ROWS} rows")
    header = (*names, target)
    what = function or "arrays given to fitlab.fit_table"
    data = _format_csv(header, [arrays[n] for n in header], f"fitlab: the table fitted ({what}): inputs, then {target}")
    return UserTable(source, function or "arrays", header, arrays, data, None, function)


# -- forms -----------------------------------------------------------------------
def _names_in(text: str) -> list[str]:
    """The names an expression text uses as values (not the functions it calls), in order of first use."""
    from fitlab.forms.symbolic import MAX_TEXT

    if not isinstance(text, str) or not text.strip():
        raise UserDataError("the form is empty; write an expression such as (a0 + a1*x)/(1 + a2*x)")
    if len(text) > MAX_TEXT:
        raise UserDataError(f"the form is {len(text)} characters long; at most {MAX_TEXT} are read")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise UserDataError(f"cannot read the form {text.strip()[:60]!r}: {type(exc).__name__}") from None
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and id(node) not in called and node.id not in out:
            out.append(node.id)
    return out


def user_form(text: str, inputs, columns=None):
    """(expression, parameters, inputs used) of the form ``text``: parameters are the names a<digits>, in
    numeric order; every other name must be one of ``inputs`` (or a constant pi, E).  ``columns``: the table's
    other columns, named in the message when the form uses one that is not an input.  Parsed by the restricted
    parser; :class:`UserDataError` on any refusal, on no parameters, and on a parameter that cancels."""
    from fitlab.forms.symbolic import CONSTANTS, parse_expression
    from fitlab.store import fit_limits

    limits = fit_limits()
    names = _names_in(text)
    long = next((n for n in names if len(n) > limits.name), None)
    if long is not None:  # a parameter a<400 digits> is refused here, before its number is read
        raise UserDataError(
            f"the form names {long[:20]}... ({len(long)} characters); a fit file holds names of at most "
            f"{limits.name} characters"
        )
    params = sorted((n for n in names if _PARAMETER.match(n)), key=lambda n: int(n[1:]))
    if len(params) > limits.params:
        raise UserDataError(f"the form has {len(params)} parameters; a fit file holds at most {limits.params}")
    unknown = [n for n in names if n not in params and n not in inputs and n not in CONSTANTS]
    if unknown:
        where = f" (the inputs are {', '.join(inputs)})" if inputs else ""
        hint = (
            ""
            if columns is None
            else "; it is a column: add it to the inputs"
            if unknown[0] in columns
            else f"; the table's columns are {', '.join(columns)[:200]}"
        )
        raise UserDataError(
            f"the form names {unknown[0]!r}, which is neither an input{where} nor a parameter a0, a1, ...{hint}"
        )
    if not params:
        raise UserDataError("the form has no parameters (a0, a1, ...): nothing to fit")
    try:
        expr = parse_expression(text, (*inputs, *params))
    except ValueError as exc:
        raise UserDataError(f"the form: {exc}") from None
    present = {s.name for s in cast("set[sp.Symbol]", expr.free_symbols)}  # sympy annotates them as Basic
    gone = [p for p in params if p not in present]
    if gone:
        raise UserDataError(f"{gone[0]} cancels out of the form as written ({text.strip()[:60]}); remove it")
    return expr, tuple(params), tuple(n for n in inputs if n in present)


# -- the split -------------------------------------------------------------------
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


def _scale(y: np.ndarray, error: str, floor: float) -> np.ndarray:
    return np.maximum(np.abs(y), floor) if error == "relative" else np.ones_like(y)


def _measure_text(error: str, floor: float, target: str) -> str:
    if error == "relative":
        return (
            f"relative with a floor: |approx - {target}| / max(|{target}|, {floor:.6g}), the floor being "
            f"{SCALE_FLOOR:g} x the largest |{target}| of the rows used"
        )
    return f"absolute: |approx - {target}|"


def remeasure(record: Mapping, table: UserTable) -> dict:
    """The held-out error of the fit ``record`` measured again on ``table`` (the table its ``user_data``
    names): the rows in the record's domain, checked and split again as a fit does (:func:`prepare_rows`), the
    fit evaluated there and measured with the record's error (:func:`fitlab.fit.metrics.summary`).

    Every figure the record states of its table is derived again from the table and must be the one derived
    (:class:`UserDataError` otherwise, naming the first that differs): the sha256, the rows, the domain (the
    bounding box of the rows inside the stated domain: a domain edited wider than the rows is refused), the
    error's floor, the split, and the numbers of rows fitted and held out."""
    from fitlab.fit.metrics import summary
    from fitlab.store import FitFunction

    user = record["user_data"]
    if table.sha256 != user["sha256"]:
        raise UserDataError(
            f"{table.name}: sha256 {table.sha256[:16]}..., the fit was made on a table with "
            f"{user['sha256'][:16]}...; the table changed since the fit"
        )
    inputs, target = list(record["inputs"]), record["target"]
    stated = {k: (float(lo), float(hi)) for k, (lo, hi) in record["domain"].items()}
    rows = prepare_rows(table, target, inputs, domain=stated, error=user["error"], holdout_every=user["holdout_every"])
    derived = rows.user_data()
    differ = [
        (what, says, gives)
        for what, says, gives in (
            ("user_data.rows", user["rows"], derived["rows"]),
            *(
                (f"the domain of {k}", f"[{stated[k][0]!r}, {stated[k][1]!r}]", f"[{lo!r}, {hi!r}]")
                for k, (lo, hi) in rows.domain.items()
            ),
            ("user_data.scale_floor", repr(float(user["scale_floor"])), repr(float(derived["scale_floor"]))),
            ("user_data.holdout_offset", user["holdout_offset"], derived["holdout_offset"]),
            ("training.points", record.get("training", {}).get("points", len(rows.train)), len(rows.train)),
            ("validation.points", record.get("validation", {}).get("points", len(rows.valid)), len(rows.valid)),
        )
        if says != gives
    ]
    if differ:
        what, says, gives = differ[0]
        raise UserDataError(
            f"the fit states {what} {says}, its table {Path(table.name).name} gives {gives}; the fit file was "
            "edited or is not this table's"
        )
    valid = rows.valid
    fit = FitFunction(dict(record))
    approx = fit.evaluate(*(valid.inputs[n] for n in inputs))
    return summary(approx, valid.y, _scale(valid.y, user["error"], user["scale_floor"]), valid.inputs)


#: points of the probe of a fit's domain (:func:`nonfinite_point`): a tensor grid of at most this many, and as
#: many uniformly random points (a fixed seed)
PROBE_POINTS = 65_536


def nonfinite_point(fit, domain: Mapping[str, Sequence[float]] | None = None) -> dict | None:
    """A point of the box ``domain`` (default the fit's) where the fit ``fit`` (a
    :class:`fitlab.store.FitFunction`) is not finite, or None: probed on a tensor grid of n points per input
    (n^d <= :data:`PROBE_POINTS`, at least the two ends; crowded towards both ends, where forms with log and
    sqrt terms turn) and on :data:`PROBE_POINTS` uniformly random points (a fixed seed), which fall between
    the grid's lines."""
    box = {k: (float(lo), float(hi)) for k, (lo, hi) in (domain or fit.domain).items()}
    names = list(fit.inputs)
    d = len(names)
    n = max(2, int(math.floor(PROBE_POINTS ** (1.0 / d) + 1e-9)))
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, n))  # Chebyshev-Lobatto: both ends, crowded there
    axes = [box[k][0] + (box[k][1] - box[k][0]) * t for k in names]
    grid = [g.ravel() for g in np.meshgrid(*axes, indexing="ij")]
    lo, hi = np.array([box[k][0] for k in names]), np.array([box[k][1] for k in names])
    cloud = lo + (hi - lo) * np.random.default_rng(20240).random((PROBE_POINTS, d))
    for points in (grid, list(cloud.T)):
        points = [np.clip(x, box[k][0], box[k][1]) for x, k in zip(points, names)]
        values = fit.evaluate(*points)
        bad = ~np.isfinite(values)
        if np.any(bad):
            i = int(np.argmax(bad))
            return {k: float(x[i]) for k, x in zip(names, points)}
    return None


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
        return f"a fit over {_box_text(theirs)}, this one over {_box_text(rows.domain)}"
    if (user["holdout_every"], user["holdout_offset"]) != (mine["holdout_every"], mine["holdout_offset"]):
        return f"a fit validated on other held-out rows (every {user['holdout_every']} from {user['holdout_offset']})"
    if (user["error"], float(user["scale_floor"])) != (mine["error"], float(mine["scale_floor"])):
        return f"a fit measured by another error ({user['error']}, floor {float(user['scale_floor']):g})"
    return None


# -- the fit ---------------------------------------------------------------------
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


def table_beside(path) -> Path:
    """Where the table of the fit file ``path`` is written: beside it, ``PATH`` less .json plus .csv
    (fits/E.rational.json: fits/E.rational.csv); the fit names it by that file name alone."""
    path = Path(path)
    return path.with_name((path.name[:-5] if path.name.endswith(".json") else path.name) + ".csv")


def table_file_name(target: str, form: str) -> str:
    """The file name of the table beside the fit file COLUMN.NAME.json (:func:`table_beside`)."""
    return f"{target}.{form}.csv"


def _safe_text(text: str) -> str:
    """``text`` with every character a fit file's text fields refuse replaced by ?."""
    text = re.sub(r"[\x00-\x1f\x7f\"\\`]", "?", text)
    return text.replace("*/", "*?")


def _check_domain(domain, inputs) -> dict[str, tuple[float, float]]:
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


def _start(params, start) -> dict:
    """The start values: ``start``'s, else a<k> = 1/(k + 1) (distinct values, so that terms of one shape, as a
    rational's numerator and denominator have, do not start equal and leave the fit undetermined)."""
    values = {p: 1.0 / (int(p[1:]) + 1) for p in params}
    for name, value in (start or {}).items():
        if name not in values:
            raise UserDataError(
                f"start: {name!r} is not a parameter of the form; its parameters are {', '.join(params)}"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise UserDataError(f"start: {name}={value!r} is not a number") from None
        if not math.isfinite(v):
            raise UserDataError(f"start: {name}={v!r} is not finite")
        values[name] = v
    return values


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
        _check_row_parameters(self.table, n_train, p)
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
            **({"function": _safe_text(t.function)[:2000]} if t.function else {}),
        }

    def target_object(self, form_name: str):
        """An unregistered :class:`fitlab.core.Target` whose training and validation sets are these rows, whose
        error is theirs: what :func:`fitlab.fit.refit.refit` and :func:`fitlab.discover.discover` fit."""
        from fitlab.core import Input, Target

        t = self.table
        source = {"csv": f"column {self.target} of the table {_safe_text(Path(t.name).name)}",
                  "arrays": f"{self.target}, given to fitlab.fit_table as arrays",
                  "function": f"{self.target}, {_safe_text(t.function)}"}[t.source]  # fmt: skip

        def scale(ds, floor=self.floor, error=self.error):
            return _scale(ds.y, error, floor)

        return Target(
            name=self.target,
            description=f"{source}: a table of the user's ({t.rows} rows, sha256 {t.sha256[:16]}...)",
            variables=tuple(Input(n, self.domain[n]) for n in self.inputs),
            default_form=form_name,
            published=(),
            training=lambda: self.train,
            validation=lambda: self.valid,
            claimed="none stated: the validation is the held-out rows of the user's table",
            error_measure=_measure_text(self.error, self.floor, self.target),
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
    _not_registered(target)
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
    box = _check_domain(domain, inputs)

    xs_all = {n: table.column(n) for n in inputs}
    y_all = table.column(target)
    keep = _selected(xs_all, box)
    index = np.flatnonzero(keep)
    if not index.size:
        raise UserDataError(f"{table.name}: no row lies in the domain {_box_text(box)}")
    xs, y = {n: x[keep] for n, x in xs_all.items()}, y_all[keep]
    for n, values in (*xs.items(), (target, y)):
        _check_scale(table, n, values)
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
    label = _safe_text(Path(table.name).name if table.source == "csv" else table.name)
    train = Dataset({n: x[~held] for n, x in xs.items()}, y[~held], f"{label}: the rows not held out ({split})")
    valid = Dataset({n: x[held] for n, x in xs.items()}, y[held], f"{label}: the held-out rows ({split})")
    return Rows(target, tuple(inputs), train, valid, fitted_domain, floor, error, every, offset, table, len(y),
                index[~held])  # fmt: skip


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
        named = set(_names_in(form))
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
    start_values = _start(params, start)
    if not domain and isinstance(holdout_every, (int, np.integer)) and holdout_every >= 2:
        # every row is fitted or held out: the rows to fit follow from the count alone, before a number is read
        every = int(holdout_every)
        _check_row_parameters(table, table.rows - len(range(every // 2, table.rows, every)), len(params))
    rows = prepare_rows(table, target, inputs, domain=domain, error=error, holdout_every=holdout_every)
    rows.check_size(len(params), bool(domain))
    description = f"a fit of {_safe_text(form.strip())[:200]}"
    fitted = Form(target=target, name=form_name, inputs=rows.inputs, params=params, expr=expr,
                  start=start_values, description=description, refit_by_default=False)  # fmt: skip
    _check_savable(rows, fitted, start_values)
    _check_start(fitted, start_values, rows.train, _scale(rows.train.y, rows.error, rows.floor), table,
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


def _check_row_parameters(table: UserTable, n_train: int, p: int) -> None:
    """Refuse ``n_train`` rows to fit times ``p`` parameters beyond :data:`MAX_ROW_PARAMETERS`."""
    if n_train * p > MAX_ROW_PARAMETERS:
        raise UserDataError(
            f"{table.name}: {n_train} rows to fit x {p} parameters = {n_train * p:.3g}; fitlab fits at most "
            f"{_power(MAX_ROW_PARAMETERS)} (the fit's memory grows with both): fit fewer rows (--domain, or a "
            "thinned table) or fewer parameters"
        )


def _check_scale(table: UserTable, name: str, values: np.ndarray) -> None:
    """Refuse a column whose largest |value| lies outside :data:`VALUE_RANGE` (0 excepted)."""
    lo, hi = VALUE_RANGE
    big = float(np.max(np.abs(values)))
    if big > hi or 0.0 < big < lo:
        raise UserDataError(
            f"{table.name}: column {name} reaches |{name}| = {big:.3g}; fitlab fits columns whose largest magnitude "
            f"lies between {_power(lo)} and {_power(hi)} (squares of the values must stay normal doubles): rescale it"
        )


def _box_text(box) -> str:
    return ", ".join(f"{n}={lo:g}:{hi:g}" for n, (lo, hi) in box.items())


def _check_start(form, start: dict, train, scale, table: UserTable, rows: np.ndarray) -> None:
    """The form at the start values: finite on every fitted row, and its Jacobian of full numerical rank."""
    theta = form.vector(start)
    xs = [train.inputs[n] for n in form.inputs]
    value = form.numpy_fit_function(theta, *xs)
    bad = ~np.isfinite(value)
    if np.any(bad):
        i = int(np.argmax(bad))
        point = ", ".join(f"{n}={x[i]:.6g}" for n, x in zip(form.inputs, xs))
        raise UserDataError(
            f"{table.name} {table.where(int(rows[i]))}: the form is not finite at {point} with the "
            f"start values ({_start_text(start)}); give other start values"
        )
    jac, used = _jacobian(form, theta, xs, scale)
    if not np.all(np.isfinite(jac)):
        i, k = (int(v) for v in np.argwhere(~np.isfinite(jac))[0])
        i = int(used[i])
        point = ", ".join(f"{n}={x[i]:.6g}" for n, x in zip(form.inputs, xs))
        raise UserDataError(
            f"{table.name} {table.where(int(rows[i]))}: the form's derivative in {form.params[k]} is "
            f"not finite at {point} with the start values ({_start_text(start)}); the fit cannot "
            "start there: give other start values"
        )
    norms = np.sqrt(np.sum(jac**2, axis=0))
    dead = [p for p, nrm in zip(form.params, norms) if not nrm > 0.0]
    if dead:
        raise UserDataError(
            f"{dead[0]} has no effect on the fitted rows at the start values ({_start_text(start)}): "
            "the data cannot determine it; change the form or the start values"
        )
    _, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
    if rank < len(form.params):
        direction = vt[-1] / norms  # in the parameters themselves, the largest component 1
        direction = direction / direction[np.argmax(np.abs(direction))]
        terms = [(c, p) for c, p in zip(direction, form.params) if abs(c) > 0.05]
        combo = (
            " ".join(
                f"{'-' if c < 0 else '+'} {'' if abs(abs(c) - 1) < 5e-3 else f'{abs(c):.2g} '}{p}" for c, p in terms
            )
            .removeprefix("+ ")
            .replace("- ", "-", 1 if terms[0][0] < 0 else 0)
        )
        raise UserDataError(
            f"the data cannot determine the form's {len(form.params)} parameters: at the start values "
            f"its Jacobian on the fitted rows has rank {rank} (moving the parameters along {combo} "
            "leaves the fit unchanged), as in a0*a1*x; change the form, or the start values if terms "
            "were started equal"
        )


def _start_text(start: dict) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in start.items())


def _jacobian(form, theta, xs, scale) -> tuple[np.ndarray, np.ndarray]:
    """(J, rows): J_ik = d r_i / d theta_k of r = f(theta; x)/scale at ``theta`` (JAX, float64), on ``rows``, at
    most :data:`RANK_ROWS` evenly spaced rows."""
    from fitlab.core import float64

    n = len(scale)
    rows = np.unique(np.linspace(0, n - 1, min(n, RANK_ROWS)).astype(int))

    @float64
    def jac():
        import jax
        import jax.numpy as jnp

        data = tuple(jnp.asarray(x[rows]) for x in xs)
        inv = jnp.asarray(1.0 / scale[rows])
        f = form.jax_function
        return np.asarray(jax.jacfwd(lambda t: f(t, *data) * inv)(jnp.asarray(theta, dtype=jnp.float64)))

    return jac(), rows


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
    jac, _ = _jacobian(form, theta, xs, _scale(train.y, prep.rows.error, prep.rows.floor))
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
    box = _check_domain(domain, names)
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
