r"""The exact tables as engines ship them: one float32 texture and the "tables, three orders" BRDF read from it.

The report's "tables, three orders" method (:mod:`.report.spline_tables`) is the exact BRDF up to the interpolation of
H0, H1, H2 and the constants; it interpolates with scipy splines and cannot be shipped.  This module stores
what that BRDF needs in one texture (:class:`fitlab.codegen.texture.Texture`) and builds the BRDF from lookups of
it, printed like any program (:func:`fitlab.codegen.texture.emit_textured`): C (the texture as a ``static const
float`` array), GLSL (an R32F texture read with ``texelFetch``) and numpy (the raw file), with a bicubic or
bilinear lookup defined once (:func:`fitlab.codegen.texture.lookup_2d`).

Details: docs/tables.md, section ``fitlab.families.lambert_sphere.program.table_export``."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from functools import cache
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab._io import read_regular_file
from fitlab.codegen import MaterialSpec, Program, Routine, call, inline_calls, material_of, with_domain
from fitlab.codegen.texture import LOOKUPS, TEXEL, Texture, combined_lookup_3d, emit_textured, lookup_1d, lookup_2d
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, RUNTIME_TERMS
from fitlab.families.lambert_sphere.forms.constants import FIRST_ORDER
from fitlab.families.lambert_sphere.forms.h_functions import first_order, log_exp, log_exp_remainder
from fitlab.families.lambert_sphere.program.report.spline_tables import kd_interpolant
from fitlab.families.lambert_sphere.program.spec import brdf_routines, local_routine
from fitlab.families.lambert_sphere.targets import TARGETS
from fitlab.families.lambert_sphere.targets.table_files import (
    CONSTANTS_FILE,
    KD_FILE,
    TRUE_FILE,
    TRUE_GRID_TEXT,
    TRUE_ORDERS,
    TRUE_S_GRID,
    check_tables,
    h_file,
    read_checked,
    read_constants,
    read_h,
    read_kd,
    read_true_orders,
    tables_dir,
)
from fitlab.forms.symbolic import symbols
from fitlab.store import MAX_TABLE_BYTES

__all__ = [
    "NAME",
    "LANGUAGES",
    "NODES",
    "DEFAULT_NODES",
    "DEFAULT_LOOKUP",
    "QUANTITIES",
    "DEFAULT_QUANTITY",
    "LIMIT_MU",
    "CONSTANT_ROWS",
    "CORRECTION_MAX_NODES",
    "CORRECTION_S_CHOICES",
    "DEFAULT_CORRECTION_S",
    "CORRECTION_LIMIT_NODES",
    "CORRECTION",
    "TableLayout",
    "layout",
    "texture",
    "program",
    "generate",
    "command",
    "check_tables",
    "tables_dir",
    "numpy_brdf",
    "numpy_part",
    "numpy_correction",
    "stored_correction",
    "memory_bytes",
    "texels_per_call",
    "GENERATE_STEPS",
    "kd_ratio_limit",
]

#: the generated files' base name and the functions' prefix
NAME = "lambert_sphere_tables"
#: the languages the exported tables are printed in (``fitlab codegen --tables --lang``)
LANGUAGES = ("c", "glsl", "python")
#: the table's resolution (nodes per axis) may be any of these: N - 1 divides 64, so that every node is a
#: node of the exact tables (s = k/64, mu = j/64), and a cubic lookup has its four nodes
NODES = (5, 9, 17, 33, 65)
#: what ``fitlab codegen --tables`` prints unless told otherwise (docs/table_export.md measures every resolution:
#: from 33 nodes up what is left is the correction's and the Fourier orders m >= 3 it leaves out)
DEFAULT_NODES = 33
DEFAULT_LOOKUP = "cubic"
#: the table node that stands in for mu -> 0 in R_m (R_m - R_m(0) = O(mu log^2 mu): about 4e-7 here)
LIMIT_MU = 1e-9
#: the true-phase correction: at most this many nodes per cosine axis (sqrt(mu) = j/(n - 1), nodes of
#: true_orders.csv: n - 1 divides 32)
CORRECTION_MAX_NODES = 33
#: how the correction may be read along s, (lookup, step): its s nodes are every step-th node of the exact table's
#: grid (:data:`..targets.table_files.TRUE_S_GRID`), read by the lookup (across sqrt(mu_i), sqrt(mu_o) by the table's
#: lookup); docs/table_export.md measures each
CORRECTION_S_CHOICES = (("linear", 2), ("cubic", 2), ("linear", 1), ("cubic", 1))
#: what is shipped: linear in s on s = k/4 (docs/table_export.md, "The correction along s": the fewest texels and
#: bytes, and a few 1e-6 of the BRDF from the tricubic lookup on every node of the exact table)
DEFAULT_CORRECTION_S = ("linear", 2)
#: the c-only rows after the three H blocks, in order, with the part each gives and what is stored
CONSTANT_ROWS = (("l", "l"), ("m", "m - 1"), ("B", "B/c - B1"), ("C", "C/c - C1"), ("D", "D/c - D1"), ("F", "F/c - F1"))
#: what the H rows may hold (docs/table_export.md measures each): ``remainder`` is what is shipped
QUANTITIES = {
    "remainder": "R_m = (log(H)/mu - Psi_m(mu) log(1 + 1/mu))/c - p_m(mu): grazing and first-order parts exact",
    "log": "log(H)/mu - Psi_m(mu) log(1 + 1/mu) = c (p_m + R_m): grazing part exact, first order interpolated",
    "h": "H_m itself",
}
DEFAULT_QUANTITY = "remainder"

mu, c, kd = symbols(("mu", "c", "kd"))
mu_i, mu_o, cos_phi = symbols(("mu_i", "mu_o", "cos_phi"))
_S = sp.sqrt(1 - c)


@dataclass(frozen=True)
class TableLayout:
    """Where each quantity sits in a texture of ``nodes`` nodes per axis: (3 nodes + 7) rows of the H functions,
    the constants and kd, then the true-phase correction, 3 orders x :attr:`correction_s_nodes` slabs x
    :attr:`correction_nodes` rows (columns beyond :attr:`correction_nodes` hold 0); its s nodes are every
    ``correction_s_step``-th of :data:`..targets.table_files.TRUE_S_GRID`."""

    nodes: int
    correction_s_step: int = DEFAULT_CORRECTION_S[1]

    def h_row(self, order: int) -> int:
        """First row of R_order: row h_row + k holds s = k/(N - 1), column j holds mu = j/(N - 1)."""
        return order * self.nodes

    def constant_row(self, part: str) -> int:
        """The row of a constant's stored quantity (column k: s = k/(N - 1))."""
        return 3 * self.nodes + [p for p, _ in CONSTANT_ROWS].index(part)

    @property
    def kd_row(self) -> int:
        """The row of kd/c(kd) (column k: kd = k/(N - 1))."""
        return 3 * self.nodes + len(CONSTANT_ROWS)

    @property
    def correction_nodes(self) -> int:
        """Nodes per cosine axis of the correction: sqrt(mu) = j/(n - 1)."""
        return min(self.nodes, CORRECTION_MAX_NODES)

    @property
    def correction_s(self) -> np.ndarray:
        """The correction's s nodes: every :attr:`correction_s_step`-th of the exact table's, s = k/(S - 1)."""
        return TRUE_S_GRID[:: self.correction_s_step]

    @property
    def correction_s_nodes(self) -> int:
        return self.correction_s.size

    def correction_row(self, order: int) -> int:
        """First row of Q_order: row correction_row + k n + i holds s = k/(S - 1), sqrt(mu_i) = i/(n - 1), column
        j sqrt(mu_o) = j/(n - 1) (n = :attr:`correction_nodes`, S = :attr:`correction_s_nodes`)."""
        return self.kd_row + 1 + order * self.correction_s_nodes * self.correction_nodes

    @property
    def rows(self) -> int:
        return self.correction_row(TRUE_ORDERS)

    def blocks(self) -> tuple:
        n, nc, ns = self.nodes, self.correction_nodes, self.correction_s_nodes
        out = [(self.h_row(m), n, f"R{m}(s, mu), row h + k: s = k/{n - 1}, column j: mu = j/{n - 1}") for m in range(3)]
        out += [(self.constant_row(p), 1, f"{what} at s = k/{n - 1} (column k)") for p, what in CONSTANT_ROWS]
        out.append((self.kd_row, 1, f"kd/c(kd) at kd = k/{n - 1} (column k)"))
        out += [
            (
                self.correction_row(m),
                ns * nc,
                f"Q{m}(s, mu_i, mu_o), row q + k {nc} + i: s = k/{ns - 1}, "
                f"sqrt(mu_i) = i/{nc - 1}, column j: sqrt(mu_o) = j/{nc - 1}",
            )
            for m in range(TRUE_ORDERS)
        ]
        return tuple(out)

    def lines(self) -> tuple:
        """The layout in words (the generated files and docs/codegen.md quote it)."""
        n, r, nc, ns = self.nodes, self.rows, self.correction_nodes, self.correction_s_nodes
        q = [self.correction_row(m) for m in range(TRUE_ORDERS + 1)]
        return (
            f"Texture: {n} columns x {r} rows of float32 (R32F), {n * r * 4} bytes; texel (column x, row y); the raw",
            f"file is little-endian float32, row 0 first, each row from column 0. N = {n} nodes per axis.",
            f"Rows {self.h_row(0)}-{n - 1}, {n}-{2 * n - 1}, {2 * n}-{3 * n - 1}: R0, R1, R2 (row 'first + k': "
            f"s = sqrt(1 - c) = k/{n - 1};",
            f"column j: mu = j/{n - 1}), H_m = exp(mu (Psi_m(mu) log(1 + 1/mu) + c (p_m(mu) + R_m(s, mu)))).",
            f"Rows {3 * n}-{3 * n + 5}: l, m - 1, B/c - B1, C/c - C1, D/c - D1, F/c - F1 at s = k/{n - 1} (column k);",
            f"B1, C1, D1, F1 = {', '.join(str(FIRST_ORDER[x]) for x in 'BCDF')} (exact O(c) terms).",
            f"Row {self.kd_row}: kd/c(kd) at kd = k/{n - 1} (column k).",
            f"Rows {q[0]}-{q[1] - 1}, {q[1]}-{q[2] - 1}, {q[2]}-{q[3] - 1}: Q0, Q1, Q2, the true-phase correction "
            f"(fm_m,true - fm_m,three-term)/fm_0,three-term;",
            f"row 'first + k {nc} + i': s = k/{ns - 1}, sqrt(mu_i) = i/{nc - 1}; column j < {nc}: "
            f"sqrt(mu_o) = j/{nc - 1}.",
            "Lookup: position p = x (n - 1), x in [0, 1];",
            "cubic: Lagrange cubics on the 4 nodes i..i+3, i = min(max(floor(p) - 1, 0), n - 4); linear:",
            "nodes i, i+1, i = min(floor(p), n - 2). docs/codegen.md, 'Tables as engines ship them'.",
        )


def layout(nodes: int, correction_s: tuple = DEFAULT_CORRECTION_S) -> TableLayout:
    """The layout of a table of ``nodes`` nodes per axis (one of :data:`NODES`) whose correction is read along s as
    ``correction_s`` says (one of :data:`CORRECTION_S_CHOICES`)."""
    if nodes not in NODES:
        raise ValueError(
            f"nodes must be one of {', '.join(map(str, NODES))} (N - 1 divides 64: every node a node of "
            f"the exact tables), not {nodes}"
        )
    if tuple(correction_s) not in CORRECTION_S_CHOICES:
        raise ValueError(
            f"the correction's reading along s must be one of {CORRECTION_S_CHOICES}, not {correction_s!r}"
        )
    return TableLayout(nodes, correction_s[1])


def _grid_index(values: np.ndarray, wanted: np.ndarray, what: str, source: Path) -> np.ndarray:
    """The indices of ``wanted`` in ``values`` (exact matches), or a ValueError naming the table."""
    index = np.searchsorted(values, wanted)
    index = np.minimum(index, values.size - 1)
    if not np.array_equal(values[index], wanted):
        raise ValueError(f"{source}: its {what} grid lacks the nodes {what} = k/64 the export reads")
    return index


@cache
def _stored_function(order: int, quantity: str):
    """numpy f(H, mu, c) of the stored quantity (:data:`QUANTITIES`)."""
    h = sp.Symbol("h", positive=True)
    expr = {
        "remainder": log_exp_remainder(order, h),
        "log": c * (log_exp_remainder(order, h) + first_order(order)),
        "h": h,
    }[quantity]
    return sp.lambdify((h, mu, c), expr, "numpy")


def _h_of_stored(order: int, stored: sp.Expr, quantity: str) -> sp.Expr:
    """H_order from the looked-up stored quantity (the inverse of :func:`_stored_function`)."""
    if quantity == "h":
        return stored
    return log_exp(order, stored if quantity == "remainder" else stored / c - first_order(order))


def _stored_h(order: int, nodes: int, data_dir: Path, quantity: str = DEFAULT_QUANTITY) -> np.ndarray:
    """The stored quantity of H_order on the nodes (rows s = k/(N-1), columns mu = j/(N-1)), from h{order}.csv."""
    t = read_h(order, data_dir)
    s_all, mu_all = np.unique(t[:, 0]), np.unique(t[:, 2])
    h = t[:, 3].reshape(s_all.size, mu_all.size)
    grid = np.linspace(0.0, 1.0, nodes)
    # H itself is 1 at mu = 0; the other quantities have a limit there, read at mu = LIMIT_MU
    mus = grid if quantity == "h" else np.concatenate(([LIMIT_MU], grid[1:]))
    rows = _grid_index(s_all, grid, "s", data_dir / h_file(order))
    cols = _grid_index(mu_all, mus, "mu", data_dir / h_file(order))
    s, m = np.meshgrid(s_all[rows], mus, indexing="ij")
    cc = 1.0 - s**2
    with np.errstate(divide="ignore", invalid="ignore"):
        r = _stored_function(order, quantity)(h[np.ix_(rows, cols)], m, cc) + np.zeros(m.shape)
    # at c = 0, H = 1 and the first-order part is exact: the remainder and log H are 0
    return r if quantity == "h" else np.where(cc == 0.0, 0.0, r)


def _stored_constants(nodes: int, data_dir: Path) -> list[np.ndarray]:
    table = read_constants(data_dir)
    grid = np.linspace(0.0, 1.0, nodes)
    idx = _grid_index(table["s"], grid, "s", data_dir / CONSTANTS_FILE)
    cc = table["c"][idx]
    out = []
    for part, _ in CONSTANT_ROWS:
        x = table[part][idx]
        with np.errstate(divide="ignore", invalid="ignore"):
            if part == "l":
                v = x
            elif part == "m":
                v = x - 1.0
            else:
                v = x / cc - float(FIRST_ORDER[part])
        out.append(np.where(cc == 0.0, 0.0, v))  # every stored quantity is 0 at c = 0
    return out


def _stored_kd_ratio(nodes: int, data_dir: Path) -> np.ndarray:
    """kd/c at kd = k/(N-1): c is the root in s of kd_true(1 - s^2) = kd (the kd table's spline in s),
    c = 1 - s^2; at kd = 0 the limit kd_true'(0), the table's kd/c at its first four positive albedos
    extrapolated to c = 0 by the cubic through them (kd/c is smooth in c; :func:`kd_ratio_limit`)."""
    from scipy.optimize import brentq

    kd_of_c = kd_interpolant(data_dir)

    def ratio(k: float) -> float:
        s = brentq(lambda s: float(kd_of_c(1.0 - s * s)) - k, 0.0, 1.0, xtol=1e-15, rtol=1e-15)
        return k / (1.0 - s * s)

    grid = np.linspace(0.0, 1.0, nodes)
    return np.array([kd_ratio_limit(data_dir)] + [ratio(k) for k in grid[1:]])


def kd_ratio_limit(data_dir: Path | None = None) -> float:
    """lim kd_true/c as c -> 0 (the spherical albedo of single scattering per unit c), from the kd table: the cubic
    through kd/c at its four smallest positive albedos, at c = 0."""
    table = read_kd(tables_dir(data_dir))
    order = np.argsort(table["c"])
    c, kd = table["c"][order], table["kd_true"][order]
    keep = c > 0.0
    c, q = c[keep][:4], kd[keep][:4] / c[keep][:4]
    return float(np.polyval(np.polyfit(c, q, 3), 0.0))


def _lagrange_weights(nodes: np.ndarray, x: float) -> np.ndarray:
    """The weights w_k of the polynomial through ``nodes`` at ``x``, p(x) = sum_k w_k p(nodes[k]), computed exactly
    (the nodes' binary values as fractions) and rounded once."""
    from fractions import Fraction

    exact = [Fraction(float(v)) for v in nodes]
    at = Fraction(float(x))
    return np.array([float(np.prod([(at - b) / (a - b) for b in exact if b != a])) for a in exact])


#: the correction at s = 1 (c = 0) is the polynomial through this many s nodes of the exact table below it, there
CORRECTION_LIMIT_NODES = 4


def stored_correction(nodes: int, data_dir: Path | None = None,
                      correction_s: tuple = DEFAULT_CORRECTION_S) -> np.ndarray:  # fmt: skip
    """Q_m(s, mu_i, mu_o) = (fm_m,true - fm_m,three-term)/fm_0,three-term on the correction's nodes, shape
    (3, S, n, n): s = k/(S - 1), the nodes of :data:`..targets.table_files.TRUE_S_GRID` that ``correction_s`` keeps,
    sqrt(mu_i) = i/(n - 1), sqrt(mu_o) = j/(n - 1), from true_orders.csv.

    Q is a ratio of two multiple scatterings, each O(c^2) and each with the log pole at mu_i = mu_o = 0, so it is
    bounded and smooth in (s, sqrt(mu)) where the difference itself is not (docs/model.md, "The exported
    tables").  Two nodes are limits: mu = 0 is read at the table's mu = 1e-9, and s = 1 (c = 0, where both
    orders are 0) is Q extrapolated from the :data:`CORRECTION_LIMIT_NODES` nodes of TRUE_S_GRID below it by
    the polynomial through them."""
    lay = layout(nodes, correction_s)
    data_dir = tables_dir(data_dir)
    t = read_true_orders(data_dir)
    nc = lay.correction_nodes
    full = len(np.unique(t["mu_i"]))
    step = (full - 1) // (nc - 1)
    idx = np.arange(0, full, step)
    i, j = np.triu_indices(full)
    s_all = np.unique(t["s"])
    if not np.array_equal(s_all, TRUE_S_GRID):
        raise ValueError(f"{data_dir / TRUE_FILE}: its s grid is not the one fitlab tabulate writes ({TRUE_GRID_TEXT})")
    # the lookup reads slab k at s = k/(S - 1): the nodes kept must be those
    if not np.array_equal(lay.correction_s, np.linspace(0.0, 1.0, lay.correction_s_nodes)):
        raise ValueError(f"the correction's s nodes {lay.correction_s} are not equally spaced on [0, 1]")
    out = np.zeros((TRUE_ORDERS, s_all.size, full, full))
    base = t["fm0_three_term"]
    for m in range(TRUE_ORDERS):
        with np.errstate(divide="ignore", invalid="ignore"):
            q = (t[f"fm{m}_true"] - t[f"fm{m}_three_term"]) / base
        q = q.reshape(s_all.size, i.size)
        out[m][:, i, j] = q
        out[m][:, j, i] = q
    # s = 1: c = 0, both orders 0; the polynomial through the nodes below it, there
    below = np.arange(s_all.size - 1 - CORRECTION_LIMIT_NODES, s_all.size - 1)
    weights = _lagrange_weights(TRUE_S_GRID[below], TRUE_S_GRID[-1])
    out[:, -1] = sum(w * out[:, k] for w, k in zip(weights, below))
    keep_s = np.flatnonzero(np.isin(TRUE_S_GRID, lay.correction_s))
    return out[:, keep_s][:, :, idx][:, :, :, idx]


@cache
def _texture(nodes: int, data_dir: Path, quantity: str, correction_s: tuple) -> Texture:
    lay = layout(nodes, correction_s)
    rows = [_stored_h(m, nodes, data_dir, quantity) for m in range(3)]
    rows += [v[None, :] for v in _stored_constants(nodes, data_dir)]
    rows.append(_stored_kd_ratio(nodes, data_dir)[None, :])
    q = stored_correction(nodes, data_dir, correction_s)
    slabs = np.zeros((q.shape[0] * q.shape[1] * q.shape[2], nodes))
    slabs[:, : q.shape[3]] = q.reshape(-1, q.shape[3])
    rows.append(slabs)
    return Texture(np.concatenate(rows, axis=0), lay.blocks(), lay.lines())


def texture(nodes: int = DEFAULT_NODES, data_dir: Path | None = None, quantity: str = DEFAULT_QUANTITY,
            correction_s: tuple = DEFAULT_CORRECTION_S) -> Texture:  # fmt: skip
    """The texture of ``nodes`` nodes per axis from the tables in ``data_dir`` (None:
    :func:`..targets.table_files.tables_dir`); ``quantity``: what its H rows hold (:data:`QUANTITIES`),
    ``correction_s``: how its correction is read along s (:data:`CORRECTION_S_CHOICES`; the others than the
    defaults are measured, not shipped)."""
    _check(nodes, DEFAULT_LOOKUP, quantity, correction_s)
    return _texture(nodes, tables_dir(data_dir), quantity, tuple(correction_s))


def _check(nodes: int, lookup: str, quantity: str, correction_s: tuple = DEFAULT_CORRECTION_S) -> None:
    layout(nodes, correction_s)
    if lookup not in LOOKUPS:
        raise ValueError(f"lookup must be one of {', '.join(LOOKUPS)}, not {lookup!r}")
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {', '.join(QUANTITIES)}, not {quantity!r}")


_LOOKUP_2D = {"cubic": "bicubic", "linear": "bilinear"}


def _correction(lay: TableLayout, lookup: str, s_lookup: str, factors) -> sp.Expr:
    """sum_m factors[m] Q_m(mu_i, mu_o, c) from the texture: one lookup in (sqrt(mu_o), sqrt(mu_i), s), ``lookup``
    across the cosines and ``s_lookup`` along s, its weights and indices shared by the orders."""
    nc, ns = lay.correction_nodes, lay.correction_s_nodes
    tables = [(lay.correction_row(m), f) for m, f in enumerate(factors) if f != 0]
    return combined_lookup_3d(tables, sp.sqrt(mu_o), sp.sqrt(mu_i), _S, nc, nc, ns, lookup, s_lookup)


#: cos(m phi), m = 0, 1, 2, in cos phi
_AZIMUTH = (sp.S.One, cos_phi, 2 * cos_phi**2 - 1)


def _part_routines(lay: TableLayout, lookup: str, quantity: str, s_lookup: str) -> list[Routine]:
    n, out = lay.nodes, []
    for m in range(3):
        target = TARGETS[f"H{m}"]
        expr = _h_of_stored(m, lookup_2d(lay.h_row(m), mu, _S, n, n, lookup), quantity)
        out.append(Routine(target.routine, ("mu", "c"), expr,
                           f"H{m}(mu, c) from the table: exp(mu (Psi{m}(mu) log(1 + 1/mu) + c (p{m}(mu) + R{m}(s, mu)))), "
                           f"R{m} read {_LOOKUP_2D[lookup]} (rows {lay.h_row(m)}-"
                           f"{lay.h_row(m) + n - 1}). mu, c in [0, 1].",
                           domain={a: target.domain[a] for a in ("mu", "c")}))  # fmt: skip
    for part, what in CONSTANT_ROWS:
        target = TARGETS[part]
        stored = lookup_1d(lay.constant_row(part), _S, n, "cubic")
        expr = {"l": stored, "m": 1 + stored}.get(part, c * (FIRST_ORDER.get(part, 0) + stored))
        out.append(Routine(target.routine, ("c",), expr,
                           f"The constant {part}(c) from the table: row {lay.constant_row(part)} holds {what} at "
                           f"s = k/{n - 1}, read cubic. c in [0, 1].", domain={"c": target.domain["c"]}))  # fmt: skip
    across = f"{'cubic' if lookup == 'cubic' else 'linear'} in sqrt(mu_o), sqrt(mu_i)"
    out.append(Routine(CORRECTION, ("mu_i", "mu_o", "cos_phi", "c"), _correction(lay, lookup, s_lookup, _AZIMUTH),
                       "sum over m = 0, 1, 2 of Q_m cos(m phi), Q_m = (fm_m,true - fm_m,three-term)/fm_0,three-term, "
                       "the correction of Fourier order m of the multiple scattering to the whole phase function: "
                       f"one lookup for the three orders (rows {lay.correction_row(0)}-{lay.rows - 1}), {across} "
                       f"and {s_lookup} in s on {lay.correction_s_nodes} nodes, the texels of the orders combined "
                       "at each node. mu_i, mu_o, c in [0, 1], cos_phi in [-1, 1].",
                       domain={"mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "cos_phi": (-1.0, 1.0),
                               "c": (0.0, 1.0)}))  # fmt: skip
    target = TARGETS["c_of_kd"]
    out.append(Routine(target.routine, ("kd",), kd / lookup_1d(lay.kd_row, kd, n, "cubic"),
                       f"The particle albedo c of the spherical albedo kd (kd_true) from the table: kd over kd/c, row {lay.kd_row}, "
                       f"kd = k/{n - 1}, read cubic. kd in [0, 1].", domain={"kd": target.domain["kd"]}))  # fmt: skip
    return out


#: the routine of the correction, sum_m Q_m cos(m phi)
CORRECTION = "true_correction"

_BRDF_NOTE = (
    f"The three-term orders fm_m come from the H tables; {CORRECTION} = sum_m Q_m cos(m phi) corrects each "
    "to the whole phase function; orders m >= 3 of the true multiple scattering are left out (docs/model.md, "
    "'The exported tables'). One routine: the terms and the correction are inlined, every lookup's weights "
    "and indices computed once."
)


@cache
def _routines(nodes: int, lookup: str, quantity: str, correction_s: tuple) -> tuple[Routine, ...]:
    """Every routine of the program, in file order, each clamping its inputs (no per-material set-up); brdf is one
    routine, the terms and the correction inlined, so that every lookup's weights and indices are computed once
    (those in s shared by H0, H1, H2 and the constants, those in mu by the three H at mu_i and at mu_o)."""
    lay = layout(nodes, correction_s)
    routines = _part_routines(lay, lookup, quantity, correction_s[0])
    by_name = {r.name: r.expr for r in routines}
    parts = {p: by_name[TARGETS[p].routine] for p in (*RUNTIME_PARTS, ORDER2_PART)}
    routines += brdf_routines(
        RUNTIME_TERMS,
        1,
        "The Lambert-sphere BRDF from the exported tables",
        parts,
        correction=call(CORRECTION, mu_i, mu_o, cos_phi, c),
    )
    routines.append(local_routine("brdf"))
    # unevaluated: substituting the clamped inputs would have sympy compare every nested max and min again
    # (tens of seconds) and change nothing that is printed
    with sp.evaluate(False):
        clamped = [with_domain(r) for r in routines]
        named = {r.name: r for r in clamped}
        brdf = named["brdf"]
        named["brdf"] = replace(brdf, expr=inline_calls(brdf.expr, named), doc=f"{brdf.doc} {_BRDF_NOTE}")
    return tuple(named[r.name] for r in clamped)


def texels_per_call(nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP,
                    correction_s: tuple = DEFAULT_CORRECTION_S) -> int:  # fmt: skip
    """The texels one call of brdf reads (distinct texel reads of its expression)."""
    _check(nodes, lookup, DEFAULT_QUANTITY, correction_s)
    brdf = next(r for r in _routines(nodes, lookup, DEFAULT_QUANTITY, tuple(correction_s)) if r.name == "brdf")
    return len({e for e in sp.preorder_traversal(brdf.expr) if getattr(e, "func", None) == sp.Function(TEXEL)})


@cache
def _program(nodes: int, lookup: str, digests: tuple) -> Program:
    lay = layout(nodes)
    routines = _routines(nodes, lookup, DEFAULT_QUANTITY, DEFAULT_CORRECTION_S)
    spec = MaterialSpec(("c",), {"eval": "brdf", "eval_local": "brdf_local"}, {"prepare": ("kd", "c_of_kd")})
    s_lookup = DEFAULT_CORRECTION_S[0]
    about = (f"The Lambert-sphere BRDF (d'Eon, EGSR 2021) from its exact tables: H0, H1, H2 and the constants read "
             f"{_LOOKUP_2D[lookup]} from one texture of {nodes} x {lay.rows} float32 (docs/codegen.md, 'Tables as "
             "engines ship them').",
             "Terms of brdf: single, m0, m1, m2 (three-term orders), each order corrected to the whole phase "
             f"function by Q0, Q1, Q2 ({CORRECTION}: one lookup for the three, {s_lookup} in s): the true BRDF up to "
             "the lookups' error and the orders m >= 3 left out (docs/model.md, 'The exported tables'); no energy "
             "scale.",
             "From these tables (sha256):", *(f"  {file}  {digest}" for file, digest in digests))  # fmt: skip
    doc = (
        "The Lambert-sphere BRDF from its exported tables, generated by fitlab: numpy only.\n\n"
        "Every function takes numpy arrays (any broadcastable shapes; vectors have a\n"
        "last axis of 3) and returns an array of float64; the texture is read from the\n"
        f"file {NAME}.f32 beside this module.\n"
    )
    parts = (*RUNTIME_PARTS, ORDER2_PART, "c_of_kd")
    return Program(routines, (), RUNTIME_TERMS, NAME, about, doc, parts, None, material_of(routines, spec))


def _digests(data_dir: Path) -> tuple:
    """(name, sha256) of each table the texture is made from, each read with every check first."""
    names = (*(h_file(m) for m in range(3)), CONSTANTS_FILE, KD_FILE, TRUE_FILE)
    for name in names:
        read_checked(name, data_dir)  # a TableError names a bad one; a FIFO is refused before it is opened
    return tuple(
        (name, hashlib.sha256(read_regular_file(data_dir / name, MAX_TABLE_BYTES)).hexdigest()) for name in names
    )


def program(nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP, data_dir: Path | None = None) -> Program:
    """The program of the texture of ``nodes`` nodes per axis read by ``lookup`` (cubic or linear): the parts
    (h0, h1, h2, const_l ... const_f, c_of_kd), the correction (true_correction), the terms, brdf, brdf_local and
    the per-material set-up (prepare_c, prepare, eval, eval_local).  Built once per process for each choice."""
    _check(nodes, lookup, DEFAULT_QUANTITY)
    return _program(nodes, lookup, _digests(tables_dir(data_dir)))


def command(lang: str, nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP) -> str:
    """The command that prints these files (named in their banner; not --data or --out)."""
    words = ["fitlab codegen --tables", f"--lang {lang}"]
    if nodes != DEFAULT_NODES:
        words.append(f"--nodes {nodes}")
    if lookup != DEFAULT_LOOKUP:
        words.append(f"--lookup {lookup}")
    return " ".join(words)


#: the steps of :func:`generate` (a progress bar's total)
GENERATE_STEPS = 3


def generate(lang: str, nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP, data_dir: Path | None = None,
             tick=None) -> dict[str, bytes]:  # fmt: skip
    """{file name: bytes} of the exported tables in ``lang`` (c, glsl or python; see
    :func:`fitlab.codegen.texture.emit_textured`); ``tick()`` after each of :data:`GENERATE_STEPS` steps (the
    texture, the program, the files)."""
    if lang not in LANGUAGES:
        raise ValueError(f"the exported tables are printed in {', '.join(LANGUAGES)}, not {lang!r}")
    tex = texture(nodes, data_dir)
    if tick:
        tick()
    prog = program(nodes, lookup, data_dir)
    if tick:
        tick()
    files = emit_textured(prog, tex, lang, command(lang, nodes, lookup))
    if tick:
        tick()
    return files


def memory_bytes(nodes: int, correction_s: tuple = DEFAULT_CORRECTION_S) -> int:
    """Bytes of the texture of ``nodes`` nodes per axis (float32)."""
    return layout(nodes, correction_s).rows * nodes * 4


# -- numpy: the report's methods and the tests' reference ----------------------------------------------------
def _numpy_routines(routines, data: np.ndarray) -> dict:
    """{routine name: numpy function of its arguments (positional)}: each routine lambdified on its own, calling
    the others (as the generated module does), the texel function reading ``data``."""
    rows, cols = data.shape

    def read(row, col):
        row, col = np.asarray(row, dtype=float), np.asarray(col, dtype=float)
        i = np.where((row >= 0) & (row <= rows - 1), row, 0).astype(np.intp)
        j = np.where((col >= 0) & (col <= cols - 1), col, 0).astype(np.intp)
        return data[i, j]

    namespace = {TEXEL: read}
    for r in routines:  # a routine calls only the routines before it
        namespace[r.name] = sp.lambdify(symbols(r.args), r.expr, modules=[dict(namespace), "numpy"], cse=True)
    return namespace


@cache
def _numpy_functions(nodes: int, lookup: str, data_dir: Path, quantity: str, correction_s: tuple) -> dict:
    data = texture(nodes, data_dir, quantity, correction_s).data.astype(np.float64)
    return _numpy_routines(_routines(nodes, lookup, quantity, correction_s), data)


def _vectorised(f):
    def g(*x):
        arrays = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in x))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.asarray(f(*arrays), dtype=float) + np.zeros(arrays[0].shape)

    return g


def numpy_brdf(nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP, data_dir: Path | None = None,
               quantity: str = DEFAULT_QUANTITY, correction_s: tuple = DEFAULT_CORRECTION_S):  # fmt: skip
    """f(mu_i, mu_o, phi, c) of the exported tables in numpy: the routines lambdified one by one, reading the
    texture's float32 values (what the generated code computes, in double)."""
    _check(nodes, lookup, quantity, correction_s)
    brdf = _numpy_functions(nodes, lookup, tables_dir(data_dir), quantity, tuple(correction_s))["brdf"]
    return _vectorised(lambda mi, mo, phi, c: brdf(mi, mo, np.cos(phi), c))


def numpy_part(target: str, nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP, data_dir: Path | None = None,
               quantity: str = DEFAULT_QUANTITY):  # fmt: skip
    """The part ``target`` (H0, H1, H2, l, m, B, C, D, F, c_of_kd) of the exported tables as a numpy function of
    the target's inputs, positionally."""
    _check(nodes, lookup, quantity)
    functions = _numpy_functions(nodes, lookup, tables_dir(data_dir), quantity, DEFAULT_CORRECTION_S)
    return _vectorised(functions[TARGETS[target].routine])


@cache
def _numpy_order(order: int, nodes: int, lookup: str, data_dir: Path, correction_s: tuple):
    lay = layout(nodes, correction_s)
    factors = [1 if m == order else 0 for m in range(TRUE_ORDERS)]
    routine = Routine(f"q{order}", ("mu_i", "mu_o", "c"), _correction(lay, lookup, correction_s[0], factors), "",
                      domain={"mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "c": (0.0, 1.0)})  # fmt: skip
    with sp.evaluate(False):
        routine = with_domain(routine)
    data = texture(nodes, data_dir, DEFAULT_QUANTITY, correction_s).data.astype(np.float64)
    return _numpy_routines((routine,), data)[routine.name]


def numpy_correction(order: int, nodes: int = DEFAULT_NODES, lookup: str = DEFAULT_LOOKUP, data_dir: Path | None = None,
                     correction_s: tuple = DEFAULT_CORRECTION_S):  # fmt: skip
    """Q_order(mu_i, mu_o, c) of the exported tables in numpy, read from the float32 texture as the routine
    ``true_correction`` reads the orders: (fm_order,true - fm_order,three-term)/fm_0,three-term up to the lookup's
    error."""
    _check(nodes, lookup, DEFAULT_QUANTITY, correction_s)
    if order not in range(TRUE_ORDERS):
        raise ValueError(f"the correction has orders 0 to {TRUE_ORDERS - 1}, not {order!r}")
    return _vectorised(_numpy_order(order, nodes, lookup, tables_dir(data_dir), tuple(correction_s)))
