"""A user's table as read: a CSV file (every refusal one line, before any number is read) or numpy arrays, and
where a fit's table is written beside it."""

from __future__ import annotations

import csv
import gc
import hashlib
import io
from collections.abc import Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from fitlab._io import InputFileError, read_regular_file
from fitlab.fit.user._limits import MAX_TABLE_BYTES, MAX_TABLE_ROWS, UserDataError
from fitlab.fit.user._names import check_name

__all__ = ["UserTable", "read_csv_table", "table_from_arrays", "table_beside", "table_file_name"]


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


def table_beside(path) -> Path:
    """Where the table of the fit file ``path`` is written: beside it, ``PATH`` less .json plus .csv
    (fits/E.rational.json: fits/E.rational.csv); the fit names it by that file name alone."""
    path = Path(path)
    return path.with_name((path.name[:-5] if path.name.endswith(".json") else path.name) + ".csv")


def table_file_name(target: str, form: str) -> str:
    """The file name of the table beside the fit file COLUMN.NAME.json (:func:`table_beside`)."""
    return f"{target}.{form}.csv"
