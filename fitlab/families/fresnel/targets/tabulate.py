r"""The Fresnel family's table (its tables for ``fitlab tabulate``): the colour-matching weights of
:mod:`fitlab.families.fresnel.exact.colour`, computed with colour-science, written through
:mod:`fitlab.store`; the committed copy is fitlab/data/fresnel/colour_weights.csv.  The optical constants
beside it are measured data with their sources, not computed, so they are not rewritten here.

The check recomputes every weight with colour-science and compares within 1e-12 (the weights are written
as Python's repr of the doubles, which reads back exactly; the tolerance allows another colour-science
release to round its interpolation differently).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fitlab.families.fresnel.exact import (
    SPACES,
    WAVELENGTHS,
    WEIGHTS_COLUMNS,
    WEIGHTS_FILE,
    WEIGHTS_GRID,
    compute_channel_weights,
    read_weights,
)
from fitlab.store import Table, TableError
from fitlab.store import write_tables as store_write_tables

__all__ = ["FAMILY_NAME", "TABLE_FILES", "TOLERANCE", "build_tables", "write_tables", "check_tables"]

FAMILY_NAME = "fresnel"
TABLE_FILES = {WEIGHTS_FILE: WEIGHTS_COLUMNS}
TOLERANCE = 1e-12


def build_tables(show_progress: bool = True) -> dict[str, Table]:
    weights = compute_channel_weights()
    columns = [WAVELENGTHS] + [weights[s][c] for s in SPACES for c in range(3)]
    return {
        WEIGHTS_FILE: Table(
            WEIGHTS_FILE.removesuffix(".csv"),
            "W_c(lambda) = [M (xbar, ybar, zbar)(lambda) D65(lambda)]_c / sum over lambda of the same: the CIE 1931 "
            "2-degree observer and D65 from colour-science, M its XYZ-to-linear-RGB matrix of sRGB and of ACEScg "
            "(CAT02 from D65); each channel sums to 1",
            f"absolute {TOLERANCE:g}",
            WEIGHTS_COLUMNS,
            np.column_stack(columns).tolist(),
            WEIGHTS_GRID,
        )
    }


def write_tables(out: Path, show_progress: bool = True) -> dict[str, str]:
    """Compute the table, then write it into ``out`` (nothing is written on failure)."""
    return store_write_tables(Path(out), build_tables(show_progress))


def check_tables(folder: Path, show_progress: bool = True) -> list[str]:
    """Read the table in ``folder`` and recompute it; one line per failure."""
    try:
        table = read_weights(folder)
    except TableError as exc:
        return [str(exc)]
    try:
        weights = compute_channel_weights()
    except ImportError as exc:
        return [f"{WEIGHTS_FILE}: cannot be checked: {exc}"]
    for space in SPACES:
        err = np.abs(table[space] - weights[space])
        if not np.all(err <= TOLERANCE):
            c, i = np.unravel_index(int(np.argmax(err)), err.shape)
            return [
                f"{WEIGHTS_FILE}: {space}_{'rgb'[c]} at {WAVELENGTHS[i]:g} nm differs from colour-science's "
                f"by {err[c, i]:.2e}"
            ]
    return []
