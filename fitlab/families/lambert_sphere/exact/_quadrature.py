"""Quadrature rules shared by the exact engine.

The H-functions behave like ``1 + a mu log mu`` near mu = 0, and the kernels
``1/(u + v)`` that appear in every half-space integral are nearly singular when
u is small.  A single Gauss-Legendre rule converges only algebraically there.
A composite rule on geometrically graded panels ``[r^(k+1), r^k]`` resolves both:
on each panel the nearest singularity (v = -u or v = 0) lies at a distance
comparable to the panel length, so the per-panel error falls geometrically with
the number of nodes.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from fitlab.numerics import gauss_legendre  # one rule for every family (re-exported: this module's name)

__all__ = ["graded_gauss", "gauss_legendre"]


@cache
def graded_gauss(
    nodes_per_panel: int = 16, ratio: float = 0.25, smallest: float = 1e-17
) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss-Legendre rule on [0, 1], panels graded towards 0.

    Panel edges are 0, then ratio^K, ..., ratio, 1 with ratio^K <= smallest.
    Returns increasing nodes and their weights (read-only arrays).
    """
    n_panels = int(np.ceil(np.log(smallest) / np.log(ratio)))
    edges = np.concatenate(([0.0], ratio ** np.arange(n_panels, -1, -1.0)))
    x, w = gauss_legendre(nodes_per_panel)
    a, b = edges[:-1, None], edges[1:, None]
    nodes = (a + (b - a) * x).ravel()
    weights = ((b - a) * w).ravel()
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights
