"""The limits of a fit of one's own table, each checked before any work, and the one error of every refusal."""

from __future__ import annotations

__all__ = [
    "UserDataError",
    "HOLDOUT_EVERY",
    "SCALE_FLOOR",
    "RANK_RTOL",
    "MAX_TABLE_BYTES",
    "MAX_TABLE_ROWS",
    "MAX_ROW_PARAMETERS",
    "VALUE_RANGE",
    "RANK_ROWS",
    "MINIMAX_ROUNDS",
    "limits_text",
    "power",
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


def limits_text() -> str:
    """The limits of a fit of one's own table, as docs/reliability.md states them (a Markdown list), from the
    constants the checks use: :func:`fitlab.store.fit_limits` (the fit-file schema's), :data:`MAX_TABLE_BYTES`,
    :data:`MAX_TABLE_ROWS`, :data:`MAX_ROW_PARAMETERS`, :data:`VALUE_RANGE` and
    :data:`fitlab.store.PARAM_LIMIT`.  Each is checked before any work (one line, exit status 2)."""
    from fitlab.store import PARAM_LIMIT, fit_limits

    lim = fit_limits()
    lo, hi = (power(x) for x in VALUE_RANGE)
    return "\n".join([
        f"* inputs: at most {lim.inputs} (a fit file's `inputs`, `domain` and `user_data.columns`, and its worst "
        f"point, which names the inputs beside `exact` and `approx`);",
        f"* parameters: at most {lim.params} (`params`), each fitted value of magnitude at most {power(PARAM_LIMIT)} "
        "(the start values are checked before the fit);",
        f"* rows x parameters: the rows fitted times the parameters at most {power(MAX_ROW_PARAMETERS)}, and for "
        "`fitlab discover TABLE.csv` the rows times the library's terms and times `--max-terms` too (memory grows "
        "with both);",
        f"* names: at most {lim.name} characters each (the fitted column, `--name`, the inputs, the parameters "
        "a0, a1, ...: a letter, then letters, digits or _);",
        f"* the expression: at most {lim.expression:,} characters as fitlab writes it, the text fields of the "
        f"record at most {lim.text:,};",
        f"* the table: at most {MAX_TABLE_BYTES:,} bytes and {MAX_TABLE_ROWS:,} rows; each column fitted of "
        f"largest magnitude between {lo} and {hi} (0 aside), so that the fit's squares stay normal doubles.",
    ]) + "\n"  # fmt: skip


def power(x: float) -> str:
    """A number as docs write it: a power of ten as 1e12, 1e-150; another as %g writes it."""
    mantissa, exponent = f"{x:.0e}".split("e")
    return f"{mantissa}e{int(exponent)}" if mantissa == "1" and float(f"1e{int(exponent)}") == x else f"{x:g}"


class UserDataError(ValueError):
    """A table, form or option that fitlab refuses before any fit starts (one line)."""
