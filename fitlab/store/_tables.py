"""Exact tables (data/FAMILY/*.csv): written with a commented header (version, method, tolerance, grid), read
back with every check."""

from __future__ import annotations

import csv
import hashlib
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fitlab import __version__
from fitlab._io import (
    InputFileError,
    TableError,
    atomic_write_many,
    decimal,
    read_regular_file,
    text_lines,
    unusual_character,
)

__all__ = ["Table", "TableError", "MAX_TABLE_BYTES", "format_table", "read_table", "write_tables"]


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
