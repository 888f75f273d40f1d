r"""Sparse regression of a library's linearised model, with pysindy's optimizers.

For y = P + Q (n0 + sum a f)/(d0 + sum b g) write u = (y - P)/Q; then

    u d0 - n0 = sum_k a_k f_k - sum_j b_j (u g_j),

linear in (a, b): the denominator's fixed term d0 (1 for most libraries)
pins its scale, and each denominator term enters as the column -u g_j (the
linearisation of y * den - num = 0).  Row i is weighted by
w_i = |Q_i| / (scale_i |D_i|), so that the weighted residual is the relative
error of y to first order (scale is the target's error scale, |y| for most;
D the denominator of the previous solve, d0 at first: Sanathanan-Koerner
iteration).  Columns are scaled to unit
RMS and the target to unit RMS, so a threshold is the smallest contribution a
term may make, as a fraction of the target.

:class:`SparseRegression` sweeps pysindy's STLSQ threshold over a log-spaced
range and adds the forward path of pysindy's FROLS (one more term at each
step), so the supports it returns cover every sparsity level either finds.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from fitlab.discover.library import Library

__all__ = ["Candidate", "SparseRegression", "DEFAULT_THRESHOLDS"]

DEFAULT_THRESHOLDS = np.logspace(-5, 0, 41)


@dataclass(frozen=True)
class Candidate:
    """A sparse model: coefficients of the numerator and denominator terms it keeps (by label)."""

    num: dict
    den: dict
    found_by: str  # "STLSQ threshold 1.2e-03" or "FROLS step 4"
    library: str = ""  # the name of the library whose terms the labels name

    @property
    def support(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        return tuple(sorted(self.num)), tuple(sorted(self.den))

    @property
    def n_terms(self) -> int:
        return len(self.num) + len(self.den)


class SparseRegression:
    """Estimator in pysindy's style: ``SparseRegression(library).fit(inputs, y, scale).candidates_``.

    thresholds: STLSQ thresholds swept (fractions of the target's RMS, on unit-RMS columns).
    frols_steps: length of the FROLS forward path (0: none; default: every column).
    sk_rounds: Sanathanan-Koerner reweightings of each support's least squares.
    ridge: STLSQ's ridge parameter alpha (on unit-RMS columns).
    path_rows: rows (evenly spaced) the FROLS path is computed on.
    """

    def __init__(self, library: Library, thresholds=DEFAULT_THRESHOLDS, frols_steps: int | None = None,
                 sk_rounds: int = 3, ridge: float = 1e-10, path_rows: int = 6000):  # fmt: skip
        self.library = library
        self.thresholds = np.asarray(thresholds, dtype=float)
        self.frols_steps = frols_steps
        self.sk_rounds = sk_rounds
        self.ridge = ridge
        self.path_rows = path_rows

    # -- the linear system ---------------------------------------------------
    def _system(self, inputs, y, scale):
        lib = self.library
        v = lib.evaluate(inputs)
        y = np.asarray(y, dtype=float)
        scale = np.asarray(scale, dtype=float)
        q = v["_factor"]
        d0 = v["_d0"]
        keep = np.isfinite(y) & (scale > 0.0) & (q != 0.0) & (d0 != 0.0)
        if np.count_nonzero(keep) < len(lib.columns) + 1:
            raise ValueError(f"{lib.name}: {np.count_nonzero(keep)} usable points for {len(lib.columns)} terms")
        u = (y[keep] - v["_offset"][keep]) / q[keep]
        cols = [v[k][keep] for k in lib.numerator] + [-u * v[f"den:{k}"][keep] for k in lib.denominator]
        g = np.column_stack([v[f"den:{k}"][keep] for k in lib.denominator]) if lib.denominator else None
        base_w = np.abs(q[keep]) / scale[keep]
        return np.column_stack(cols), u * d0[keep] - v["_n0"][keep], base_w, g, d0[keep]

    @staticmethod
    def _denominator(d0, g, b):
        return d0 if g is None or not len(b) else d0 + g @ b

    def _solve(self, X, z, base_w, g, d0, support):
        """Weighted least squares on ``support`` with SK reweighting; the full coefficient vector."""
        n_num = len(self.library.numerator)
        coef = np.zeros(X.shape[1])
        w = base_w / np.abs(d0)
        for _ in range(max(1, self.sk_rounds)):
            A = X[:, support] * w[:, None]
            sol, *_ = np.linalg.lstsq(A, z * w, rcond=None)
            coef[:] = 0.0
            coef[support] = sol
            d = self._denominator(d0, g, coef[n_num:])
            if np.any(np.asarray(d) <= 0.0):
                break  # a denominator through zero: keep the last solve, the refinement will judge it
            w = base_w / np.abs(d)
        return coef

    def fit(self, inputs, y, scale) -> SparseRegression:
        import pysindy as ps

        X, z, base_w, g, d0 = self._system(inputs, y, scale)
        w0 = base_w / np.abs(d0)
        Xw, zw = X * w0[:, None], z * w0
        col = np.sqrt(np.mean(Xw**2, axis=0))
        col[col == 0.0] = 1.0
        tgt = float(np.sqrt(np.mean(zw**2))) or 1.0
        Xn, zn = Xw / col, zw / tgt

        found: dict[tuple, str] = {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pysindy warns when a threshold removes every term
            for th in self.thresholds:
                opt = ps.STLSQ(threshold=float(th), alpha=self.ridge, max_iter=50, unbias=True)
                opt.fit(Xn, zn[:, None])
                sup = tuple(np.flatnonzero(opt.coef_[0]))
                if sup:
                    found.setdefault(sup, f"STLSQ threshold {th:.2e}")
            steps = X.shape[1] if self.frols_steps is None else self.frols_steps
            if steps:
                # pysindy's FROLS costs O(rows x columns) per candidate per step: its path (the supports)
                # is taken on evenly spaced rows; every support's coefficients are solved on all rows
                rows = np.unique(np.linspace(0, len(zn) - 1, min(len(zn), self.path_rows)).astype(int))
                opt = ps.FROLS(alpha=self.ridge, max_iter=min(steps, X.shape[1]))
                opt.fit(Xn[rows], zn[rows, None])
                for k, h in enumerate(opt.history_):
                    sup = tuple(np.flatnonzero(np.ravel(h)))
                    if sup:
                        found.setdefault(sup, f"FROLS step {k}")

        labels = self.library.columns
        n_num = len(self.library.numerator)
        self.candidates_ = []
        for sup, how in sorted(found.items(), key=lambda kv: (len(kv[0]), kv[0])):
            coef = self._solve(X, z, base_w, g, d0, list(sup))
            num = {labels[i][1]: float(coef[i]) for i in sup if i < n_num}
            den = {labels[i][1]: float(coef[i]) for i in sup if i >= n_num}
            self.candidates_.append(Candidate(num, den, how, self.library.name))
        return self

    def predict(self, inputs, candidate: Candidate) -> np.ndarray:
        """y of ``candidate`` (its linearised-solve coefficients) at ``inputs``."""
        v = self.library.evaluate(inputs)
        n = v["_n0"] + sum((a * v[k] for k, a in candidate.num.items()), 0.0)
        d = v["_d0"] + sum((b * v[f"den:{k}"] for k, b in candidate.den.items()), 0.0)
        y = v["_offset"] + v["_factor"] * n / d
        return np.maximum(y, 0.0) if self.library.nonnegative else y
