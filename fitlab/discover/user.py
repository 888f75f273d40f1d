r"""Symbolic regression on a table of one's own (``fitlab discover TABLE.csv --target COLUMN``).

The rows are checked and split as ``fitlab fit`` does (:func:`fitlab.fit.user.prepare_rows`: the same
held-out rows, the same error measure), and searched with the library of :func:`user_library`, a rational
in the inputs each mapped to [0, 1] over the fit's domain, u_k = (x_k - lo_k)/(hi_k - lo_k):

    y = (sum_k a_k f_k(u)) / (1 + sum_j b_j g_j(u)),

f_k every monomial of degree <= :data:`NUMERATOR_DEGREE` (the constant included), g_j every monomial of
degree 1 to :data:`DENOMINATOR_DEGREE`.  The search, refits and front are those of
:func:`fitlab.discover.discover`; every refitted candidate's record is a fit of the user's table
(``user_data``), which ``fitlab codegen --fit`` prints once saved beside the table's path.
"""

from __future__ import annotations

import itertools
import math

import sympy as sp

from fitlab.discover.library import Library
from fitlab.discover.search import Discovery, discover
from fitlab.fit.user import HOLDOUT_EVERY, MAX_ROW_PARAMETERS, Rows, UserDataError, UserTable, prepare_rows, user_record
from fitlab.forms.symbolic import symbols

__all__ = [
    "user_library",
    "library_size",
    "prepare_table",
    "search_rows",
    "discover_table",
    "NUMERATOR_DEGREE",
    "DENOMINATOR_DEGREE",
]

NUMERATOR_DEGREE = 3
DENOMINATOR_DEGREE = 2


def _monomials(variables: dict, lo: int, hi: int) -> dict:
    """{label: monomial} of every monomial of the ``variables`` ({label: expression}) of degree lo..hi."""
    names = list(variables)
    out = {}
    for degree in range(lo, hi + 1):
        for combo in itertools.combinations_with_replacement(names, degree):
            label = " ".join(f"{n}^{combo.count(n)}" if combo.count(n) > 1 else n for n in names if n in combo)
            out[label or "1"] = sp.Mul(*(variables[n] for n in combo))
    return out


def user_library(target: str, domain: dict) -> Library:
    """The rational library of a user's table: column ``target`` of the inputs ``domain`` ({input: (lo, hi)},
    in argument order); see the module docstring."""
    xs = dict(zip(domain, symbols(tuple(domain))))
    scaled = {f"u_{n}": (xs[n] - sp.Float(lo, 17)) / sp.Float(hi - lo, 17) for n, (lo, hi) in domain.items()}
    return Library(
        name="rational",
        target=target,
        inputs=tuple(domain),
        numerator=_monomials(scaled, 0, NUMERATOR_DEGREE),
        denominator=_monomials(scaled, 1, DENOMINATOR_DEGREE),
        n0=sp.S.Zero,
        description=(
            f"a rational in u = (x - lo)/(hi - lo) of each input over the fit's domain: monomials of degree "
            f"<= {NUMERATOR_DEGREE} over 1 + monomials of degree 1..{DENOMINATOR_DEGREE}"
        ),
    )


def prepare_table(table: UserTable, target: str, *, inputs=None, domain=None, error: str = "relative",
                  holdout_every: int = HOLDOUT_EVERY, max_terms: int = 12) -> Rows:  # fmt: skip
    """Every check of a search of column ``target`` of ``table`` against ``inputs`` (default: every other
    column) on the rows inside ``domain``, before any work (:class:`fitlab.fit.user.UserDataError`, one line):
    the table's (:func:`fitlab.fit.user.prepare_rows`), and the sizes: ``max_terms`` parameters a fit file
    holds, rows to fit times ``max_terms`` and times the library's terms (the regression's matrix) within
    :data:`fitlab.fit.user.MAX_ROW_PARAMETERS`."""
    from fitlab.store import fit_limits

    rows = prepare_rows(table, target, inputs, domain=domain, error=error, holdout_every=holdout_every)
    rows.check_size(2, bool(domain))
    if max_terms > fit_limits().params:
        raise UserDataError(f"max_terms {max_terms}: a fit file holds at most {fit_limits().params} parameters")
    terms = library_size(len(rows.inputs))
    n = len(rows.train)
    for count, what in ((max_terms, "terms of a form (max_terms)"), (terms, "candidate terms of the library")):
        if n * count > MAX_ROW_PARAMETERS:
            raise UserDataError(
                f"{table.name}: {n} rows to fit x {count} {what} = {n * count:.3g}; fitlab searches at most "
                f"{MAX_ROW_PARAMETERS:.3g} (the search's memory grows with both): fit fewer rows (a domain, or a "
                "thinned table), or fewer inputs or terms"
            )
    return rows


def library_size(inputs: int) -> int:
    """Terms of :func:`user_library` for ``inputs`` inputs: the monomials of degree <= NUMERATOR_DEGREE, and
    of degree 1 to DENOMINATOR_DEGREE."""
    return (
        math.comb(inputs + NUMERATOR_DEGREE, NUMERATOR_DEGREE)
        + math.comb(inputs + DENOMINATOR_DEGREE, DENOMINATOR_DEGREE)
        - 1
    )


def search_rows(rows: Rows, *, max_terms: int = 12, minimax_rounds: int = 20, progress: bool = True) -> Discovery:
    """:func:`fitlab.discover.discover` of checked rows (:func:`prepare_table`) with :func:`user_library`; each
    refitted record carries ``user_data``."""
    library = user_library(rows.target, rows.domain)
    disc = discover(rows.target_object("discovered"), libraries=(library,), max_terms=max_terms,
                    minimax_rounds=minimax_rounds, progress=progress)  # fmt: skip
    for d in disc.refined:
        d.record = user_record(d.record, rows, minimax_rounds)
    return disc


def discover_table(table: UserTable, target: str, *, inputs=None, domain=None, error: str = "relative",
                   holdout_every: int = HOLDOUT_EVERY, max_terms: int = 12, minimax_rounds: int = 20,
                   progress: bool = True) -> Discovery:  # fmt: skip
    """Symbolic regression of column ``target`` of ``table`` against ``inputs`` (default: every other column),
    on the rows inside ``domain``: every check first (:func:`prepare_table`), then :func:`search_rows`."""
    rows = prepare_table(table, target, inputs=inputs, domain=domain, error=error, holdout_every=holdout_every,
                         max_terms=max_terms)  # fmt: skip
    return search_rows(rows, max_terms=max_terms, minimax_rounds=minimax_rounds, progress=progress)
