r"""Exact values of the Lambert-sphere targets on tensor grids (for residual maps).

``exact_grid(target)(axes)`` takes 1-D axes by name and returns (inputs on the
grid, exact values, aux): the inputs include those that follow from the axes
(kd = kd_true(c) for ``fast_brdf``; for ``c_of_kd`` the axis is c and the input
is kd_true(c), the exact pair being (kd_true(c), c)).  The BRDF and kd_true are those of the
material, :func:`fitlab.families.lambert_sphere.exact.brdf` and its spherical albedo with the
whole phase function; fm1 is the order-1 multiple scattering of the three-term half space, the
part of the runtime structure its forms model.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from fitlab.core import BrdfGrid
from fitlab.families.lambert_sphere.exact import (
    brdf,
    brdf_modes,
    constants,
    h_function,
    multiple_scattering_modes,
)
from fitlab.families.lambert_sphere.targets.datasets import kd_true

__all__ = ["exact_grid", "GRID_AXES", "BRDF_AXES", "BRDF_MEASURE", "brdf_grid"]

#: targets whose grid axes differ from their inputs (an input follows from another)
GRID_AXES = {"c_of_kd": ("c",), "fast_brdf": ("mu_i", "mu_o", "phi", "c"), "brdf": ("mu_i", "mu_o", "phi", "c")}


def _check_pole(g: dict) -> None:
    if np.any((g["mu_i"] == 0.0) & (g["mu_o"] == 0.0)):
        raise ValueError(
            "the grid holds mu_i = mu_o = 0, the pole of the BRDF (the exact value is infinite there); "
            "leave 0 out of one of the two axes"
        )


@lru_cache(maxsize=8)
def _constants(c: tuple) -> dict:
    """constants() on a c axis, once for all six constant targets."""
    return constants(np.array(c))


def _mesh(axes: dict) -> dict:
    return dict(zip(axes, np.meshgrid(*axes.values(), indexing="ij")))


def _h(order: int):
    def grid(axes):
        g = _mesh(axes)
        return g, h_function(order, g["mu"], g["c"]), {}

    return grid


def _constant(name: str):
    def grid(axes):
        return _mesh(axes), _constants(tuple(np.asarray(axes["c"], dtype=float)))[name].copy(), {}

    return grid


def _kd_of_c(axes):
    g = _mesh(axes)
    return g, kd_true(g["c"]), {}


def _c_of_kd(axes):
    c = np.asarray(axes["c"], dtype=float)
    # kd_true(1) = 1 to about 1e-14 (energy conservation of the whole phase function): the map's domain
    # is kd <= 1, so rounding above 1 is clipped
    kd = np.minimum(kd_true(c), 1.0)
    return {"kd": kd}, c.copy(), {}


def _fm1(axes):
    g = _mesh(axes)
    _check_pole(g)
    y = multiple_scattering_modes(g["mu_i"], g["mu_o"], g["c"], phase="three_term")[1]
    return g, y, {"f0": brdf_modes(g["mu_i"], g["mu_o"], g["c"])[0]}


def _brdf(with_kd: bool):
    def grid(axes):
        g = _mesh(axes)
        _check_pole(g)
        y = brdf(g["mu_i"], g["mu_o"], g["phi"], g["c"])
        if with_kd:
            c = np.asarray(axes["c"], dtype=float)
            g["kd"] = np.broadcast_to(kd_true(c), y.shape).copy()
        return g, y, {}

    return grid


_GRIDS = {
    "H0": _h(0),
    "H1": _h(1),
    **{n: _constant(n) for n in ("l", "m", "B", "C", "D", "F")},
    "kd_of_c": _kd_of_c,
    "c_of_kd": _c_of_kd,
    "fm1": _fm1,
    "fast_brdf": _brdf(True),
    "brdf": _brdf(False),
}


def exact_grid(target: str):
    """The grid function of ``target`` (see the module docstring)."""
    return _GRIDS[target]


#: the axes of the whole BRDF's grid, and its error measure (:func:`fitlab.residuals.brdf_residuals`)
BRDF_AXES = GRID_AXES["brdf"]
BRDF_MEASURE = "relative: |approx - exact| / |exact|, exact = fitlab.families.lambert_sphere.exact.brdf"


def brdf_grid() -> BrdfGrid:
    """The family's exact BRDF grid (``LambertSphere.brdf_grid()``): (axes, grid function of the exact BRDF, error
    measure)."""
    return BrdfGrid(BRDF_AXES, _GRIDS["brdf"], BRDF_MEASURE)
