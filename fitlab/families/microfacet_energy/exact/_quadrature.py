"""Quadrature rules of the exact engine: Gauss-Legendre on [0, 1], composite rules on
per-point panels (vectorised over many points at once) and geometrically graded panels.

Every rule here returns read-only arrays; the per-point rules take arrays of panel ends
of shape (P,) and return nodes and weights of shape (P, N), so that one numpy expression
integrates P different (mu, alpha) points at once.
"""

from __future__ import annotations

import numpy as np

from fitlab.numerics import gauss_legendre  # one rule for every family (re-exported: this module's name)

__all__ = ["gauss_legendre", "composite", "graded_edges"]


def composite(edges: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite n-point Gauss-Legendre rule on the panels between consecutive ``edges``.

    edges: shape (..., K + 1), non-decreasing along the last axis (a zero-length panel gets
    zero weights).  Returns nodes and weights of shape (..., K * n).
    """
    x, w = gauss_legendre(n)
    edges = np.asarray(edges, dtype=float)
    lo, hi = edges[..., :-1, None], edges[..., 1:, None]
    nodes = lo + (hi - lo) * x
    weights = (hi - lo) * w
    shape = edges.shape[:-1] + (-1,)
    return nodes.reshape(shape), weights.reshape(shape)


def graded_edges(lo, hi, panels: int, ratio: float, toward: str) -> np.ndarray:
    """Panel edges on [lo, hi], geometrically graded towards one end.

    toward="hi": lo, hi - L r, hi - L r^2, ..., hi - L r^(panels-1), hi with L = hi - lo
    and r = ratio (each panel is 1/r times longer than its neighbour nearer the end);
    toward="lo" mirrors it.  The smallest panel has length L r^(panels - 1).  A singular or
    peaked behaviour at the graded end is resolved down to that length, since each panel
    sees the end at a distance comparable to its own length.  lo, hi: arrays of shape (P,);
    returns shape (P, panels + 1).
    """
    lo, hi = np.broadcast_arrays(np.asarray(lo, dtype=float), np.asarray(hi, dtype=float))
    powers = ratio ** np.arange(panels, dtype=float)  # 1, r, ..., r^(panels-1)
    length = (hi - lo)[..., None]
    if toward == "hi":
        inner = hi[..., None] - length * powers[1:]
        return np.concatenate((lo[..., None], inner, hi[..., None]), axis=-1)
    if toward == "lo":
        inner = lo[..., None] + length * powers[1:][::-1]
        return np.concatenate((lo[..., None], inner, hi[..., None]), axis=-1)
    raise ValueError(f"toward must be 'lo' or 'hi', got {toward!r}")
