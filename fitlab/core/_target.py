r"""A target: one function a family approximates, with everything that defines it.

A :class:`Target` owns its inputs and their domains, its exact values (through
its training and validation sets, and ``exact`` for points of one's choosing),
its error measure, its forms and default form, its published presets and the
name of the routine generated code gives it.  Errors are
|approx - exact| / scale(dataset) (``scale`` defaults to |exact|); where the
scale is 0 (an exact zero of the target) the error is 0 if the approximation is
exactly 0 there too and inf otherwise.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from fitlab.core._dataset import Dataset
from fitlab.core._input import Input

__all__ = ["Target"]


def _abs_y(ds: Dataset) -> np.ndarray:
    return np.abs(ds.y)


@dataclass(frozen=True, eq=False)
class Target:
    """A function a family approximates.

    name: unique over every registered family (``"H0"``, ``"c_of_kd"``).
    description: what it is, with its domain, in one line.
    variables: its inputs (:class:`Input`: name and domain), in argument order.
    default_form: the form ``refit`` and ``codegen`` take when none is named.
    published: (form, preset) pairs of the published approximations.
    training, validation: the exact values the fit sees, and the denser set it never sees.
    exact_grid: exact values on a tensor grid, ``exact_grid(axes) -> (inputs, y, aux)``: axes are 1-D
        arrays by name (:attr:`residual_axes`), inputs every input on the grid (those that follow from
        the axes included), aux what ``scale`` needs; None where only the sets exist.
    routine: the name of the target's routine in generated code (None: not exported).
    claimed: the accuracy its source claims.
    error_measure, scale: how errors are measured (text, and the divisor as a function of a dataset).
    minimax: whether the refit ends with a minimax refinement (False where the sup of the error is pinned).
    emphasis, emphasis_text: extra training weight (not in the metrics), and why.
    note: anything a user of the target must know.
    axes: the axes residual grids are drawn over, when they differ from the inputs (an input that
        follows from another left out).
    family: the registering family's name (set by :func:`fitlab.core.register_family`).
    physics: the physics its exact values are of, as the family names it (the Lambert sphere's ``"three_term"``,
        ``"mixed"``, ``"true"``: the ``phase`` of its exact engine); a fit of the target states the physics it was
        fitted against (the fit file's ``physics``), which is this one unless the fit was made to other physics.
    """

    name: str
    description: str
    variables: tuple[Input, ...]
    default_form: str
    published: tuple[tuple[str, str], ...]
    training: Callable[[], Dataset]
    validation: Callable[[], Dataset]
    exact_grid: Callable[[Mapping[str, np.ndarray]], tuple] | None = None
    routine: str | None = None
    claimed: str = "none stated"
    error_measure: str = "relative: |approx - exact| / |exact|"
    scale: Callable[[Dataset], np.ndarray] = _abs_y
    minimax: bool = True
    emphasis: Callable[[Dataset], np.ndarray] | None = None
    emphasis_text: str = ""
    note: str = ""
    axes: tuple[str, ...] | None = None
    family: str = ""
    physics: str = "exact"

    def __post_init__(self):
        names = [v.name for v in self.variables]
        if len(set(names)) != len(names):
            raise ValueError(f"target {self.name}: repeated input names {names}")

    @property
    def inputs(self) -> tuple[str, ...]:
        """The input names, in argument order."""
        return tuple(v.name for v in self.variables)

    @property
    def domain(self) -> dict[str, tuple[float, float]]:
        """name -> (lo, hi) of every input: the whole domain the target is defined and claimed on."""
        return {v.name: v.domain for v in self.variables}

    @property
    def residual_axes(self) -> tuple[str, ...]:
        return self.axes or self.inputs

    @property
    def forms(self) -> Mapping:
        """name -> :class:`fitlab.forms.Form` of every form registered for this target (set on registration)."""
        forms = self.__dict__.get("_forms")
        if forms is None:
            raise KeyError(f"target {self.name} is not registered (fitlab.core.register_family)")
        return forms
