r"""The exact tables (:mod:`...targets.table_files`) with interpolation, as an evaluation method of the report.

Interpolation (chosen by its error on the H validation sets, stated in the report):

* H_m(mu, c), m = 0, 1, 2: an interpolating bicubic spline of g = log(H)/mu in
  (s, log mu), s = sqrt(1 - c), on every table node s = k/64 and
  0 < mu <= 1 (1e-12 ... 1e-3, j/64); H = exp(mu g), and H(0) = 1 exactly.
  Near mu = 0, H - 1 ~ -Psi_m(0) mu log mu, so g ~ -Psi_m(0) log mu + const is
  smooth in log mu, and the spline resolves the gap between the nodes 1e-3 and
  1/64 where the BRDF's grazing terms (H_i H_o - 1)/(mu_i + mu_o) amplify any
  error of H - 1.  On the H validation sets this gives max relative errors of
  1.3e-6 (H0) and 3.7e-6 (H1), against 9e-5 and 6e-5 for a bicubic spline of
  log H in (s, sqrt(mu)).
* each constant (l, m, B, C, D, F) and kd_true: a not-a-knot cubic spline in s on
  s = k/64; c(kd): a cubic spline of c against kd_true (kd <= 1).

Two BRDF methods are built from them:

* the runtime model (docs/model.md, "The runtime BRDF"),
  max(0, f_1 + fm0 + fm1 cos phi), with the
  tabulated H0, H1 and constants in place of fitted ones (its floor is the
  dropped fm2 cos 2phi);
* all three orders, max(0, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi), with
  fm2 = 15 c S^2 (H2(mu_i) H2(mu_o) - 1) / (256 pi (mu_i + mu_o))
  (docs/model.md, "Order 2": the
  order-2 BRDF 15 c H2 H2 S^2 / (256 pi (mu_i + mu_o)) minus its three-term single
  scattering): the exact BRDF up to the interpolation error.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab.families.lambert_sphere.exact import CONSTANT_NAMES
from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS, runtime_terms
from fitlab.families.lambert_sphere.targets.table_files import read_constants, read_h, read_kd, tables_dir
from fitlab.forms.symbolic import symbols

__all__ = [
    "h_interpolant",
    "constant_interpolant",
    "kd_interpolant",
    "c_of_kd_interpolant",
    "table_brdf",
    "table_part",
    "memory_bytes",
]

mu_i, mu_o, phi, c, mu = symbols(("mu_i", "mu_o", "phi", "c", "mu"))


def h_interpolant(order: int, data_dir: Path | None = None):
    """H_order(mu, c) from the table h{order}.csv: f(mu, c) on numpy arrays (mu, c in [0, 1]).
    ``data_dir``: the tables' folder (None: :func:`...targets.table_files.tables_dir`), as in every function here."""
    return _h_interpolant(order, tables_dir(data_dir))


@cache
def _h_spline(order: int, data_dir: Path):
    from scipy.interpolate import RectBivariateSpline

    t = read_h(order, data_dir)
    s, mus = np.unique(t[:, 0]), np.unique(t[:, 2])
    h = t[:, 3].reshape(s.size, mus.size)
    keep = (mus > 0.0) & np.isfinite(mus)
    return RectBivariateSpline(s, np.log(mus[keep]), np.log(h[:, keep]) / mus[keep], kx=3, ky=3)


@cache
def _h_interpolant(order: int, data_dir: Path):
    spline = _h_spline(order, data_dir)

    def f(mu, c):
        mu, c = np.broadcast_arrays(np.asarray(mu, dtype=float), np.asarray(c, dtype=float))
        pos = mu > 0.0
        g = spline.ev(np.sqrt(1.0 - c), np.log(np.where(pos, mu, 1.0)))
        return np.where(pos, np.exp(mu * g), 1.0)

    return f


def constant_interpolant(name: str, data_dir: Path | None = None):
    """A constant of the table constants.csv (l, m, A..F) as f(c): cubic spline in s = sqrt(1 - c)."""
    return _constant_interpolant(name, tables_dir(data_dir))


@cache
def _constant_interpolant(name: str, data_dir: Path):
    from scipy.interpolate import CubicSpline

    table = read_constants(data_dir)
    if name not in table or name in ("s", "c"):
        raise KeyError(f"{Path(data_dir) / 'constants.csv'} has no constant {name!r}")
    spline = CubicSpline(table["s"], table[name])
    return lambda c: spline(np.sqrt(1.0 - np.asarray(c, dtype=float)))


def kd_interpolant(data_dir: Path | None = None):
    """kd_true(c) from the table kd.csv: cubic spline in s = sqrt(1 - c)."""
    return _kd_interpolant(tables_dir(data_dir))


@cache
def _kd_interpolant(data_dir: Path):
    from scipy.interpolate import CubicSpline

    t = read_kd(data_dir)
    spline = CubicSpline(t["s"], t["kd_true"])
    return lambda c: spline(np.sqrt(1.0 - np.asarray(c, dtype=float)))


def c_of_kd_interpolant(data_dir: Path | None = None):
    """c(kd), the inverse of kd_true, from the table kd.csv: cubic spline of c against kd (kd <= 1)."""
    return _c_of_kd_interpolant(tables_dir(data_dir))


@cache
def _c_of_kd_interpolant(data_dir: Path):
    from scipy.interpolate import CubicSpline

    t = read_kd(data_dir)
    keep = t["kd_true"] <= 1.0
    order = np.argsort(t["kd_true"][keep])
    spline = CubicSpline(t["kd_true"][keep][order], t["c"][keep][order])
    return lambda kd: spline(np.asarray(kd, dtype=float))


def memory_bytes(data_dir: Path | None = None, order2: bool = False) -> int:
    """The bytes of float64 a table BRDF (:func:`table_brdf`) reads: its splines' knots and coefficients (H0, H1,
    H2 with ``order2``; the six constants of the runtime model)."""
    data_dir = tables_dir(data_dir)
    count = 0
    for order in range(3 if order2 else 2):
        tx, ty, coeffs = _h_spline(order, data_dir).tck
        count += tx.size + ty.size + coeffs.size
    table = read_constants(data_dir)
    from scipy.interpolate import CubicSpline

    for part in RUNTIME_PARTS:
        if part not in ("H0", "H1"):
            spline = CubicSpline(table["s"], table[part])
            count += spline.x.size + spline.c.size
    return 8 * count


def _fm2(h2) -> sp.Expr:
    s2 = (1 - mu_i**2) * (1 - mu_o**2)
    return 15 * c * s2 * (h2.subs(mu, mu_i) * h2.subs(mu, mu_o) - 1) / (256 * sp.pi * (mu_i + mu_o))


def table_brdf(data_dir: Path | None = None, order2: bool = False):
    """f(mu_i, mu_o, phi, c) from the tables: the runtime model (``order2=False``) or all three orders.

    Returns a numpy function; the parts are spline calls (see the module docstring)."""
    data_dir = tables_dir(data_dir)
    funcs = {"tab_H0": h_interpolant(0, data_dir), "tab_H1": h_interpolant(1, data_dir)}
    parts = {}
    for part in RUNTIME_PARTS:
        name = f"tab_{part}"
        if part in ("H0", "H1"):
            parts[part] = sp.Function(name)(mu, c)
        else:
            parts[part] = sp.Function(name)(c)
            funcs[name] = constant_interpolant(part, data_dir)
    t = runtime_terms(parts)
    total = t["single"] + t["m0"] + t["m1"] * sp.cos(phi)
    if order2:
        funcs["tab_H2"] = h_interpolant(2, data_dir)
        total += _fm2(sp.Function("tab_H2")(mu, c)) * sp.cos(2 * phi)
    raw = sp.lambdify((mu_i, mu_o, phi, c), sp.Max(0, total, evaluate=False), modules=[funcs, "numpy"], cse=True)

    def f(mu_i, mu_o, phi, c):
        arrays = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (mu_i, mu_o, phi, c)))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.asarray(raw(*arrays), dtype=float)

    return f


def table_part(target: str, data_dir: Path | None = None):
    """(f, source) of a part's interpolant from the tables, f taking the target's inputs positionally;
    (None, "") for a target the tables do not hold."""
    data_dir = tables_dir(data_dir)
    if target in ("H0", "H1"):
        order = int(target[1])
        return h_interpolant(order, data_dir), f"table h{order}.csv, spline of log(H)/mu in (s, log mu)"
    if target in CONSTANT_NAMES and target in RUNTIME_PARTS:
        return constant_interpolant(target, data_dir), "table constants.csv, cubic spline in s"
    if target == "kd_of_c":
        return kd_interpolant(data_dir), "table kd.csv (kd_true), cubic spline in s"
    if target == "c_of_kd":
        return c_of_kd_interpolant(data_dir), "table kd.csv, cubic spline of c against kd_true"
    return None, ""
