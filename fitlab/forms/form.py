r"""One parametric form: a symbolic expression with named inputs and parameters.

A :class:`Form` is the single definition from which fitlab derives the JAX
function the optimizer differentiates, the numpy function fits are evaluated
with, and (through fitlab.codegen) C, GLSL and Python source.  Forms are
immutable; parameter values live outside them (a preset, or a fit).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import cast

import numpy as np
import sympy as sp

from fitlab.forms.symbolic import expression_text, lambdify_jax, lambdify_numpy, symbols

__all__ = ["Form"]


@dataclass(frozen=True, eq=False)
class Form:
    """A parametric approximation of one target.

    target: what it approximates (``"H0"``, ``"c_of_kd"``, ...).
    name: the form's name within the target (``"hapke"``, ``"rational_3_2"``).
    inputs: names of the inputs, the inputs of its target (checked when its family registers it).
    params: names of the parameters, in the order of parameter vectors.
    expr: sympy expression in the input and parameter symbols.
    presets: published parameter values, by preset name (``"paper"``, ``"renderer"``).
    start: values the optimizer starts from (default: the first preset).
    fixed: parameters held during a fit, with their values (a scale that
        the rest of the form makes redundant, or a value an exact limit needs).
    description: the maths in words: source equation, shape, what is exact.
    refit_by_default: whether ``fitlab refit --all`` fits it.
    """

    target: str
    name: str
    inputs: tuple[str, ...]
    params: tuple[str, ...]
    expr: sp.Expr
    presets: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    start: Mapping[str, float] | None = None
    fixed: Mapping[str, float] = field(default_factory=dict)
    description: str = ""
    refit_by_default: bool = True

    def __post_init__(self):
        unknown = [n for n in self.inputs if not n.isidentifier()]
        if unknown:
            raise ValueError(f"form {self.target}/{self.name}: input names {unknown} are not identifiers")
        names = set(self.inputs) | set(self.params)
        free = {str(s) for s in self.expr.free_symbols}
        if not free <= names:
            raise ValueError(f"form {self.target}/{self.name}: expression uses undeclared {sorted(free - names)}")
        for preset, values in {**self.presets, "start": self.start or {}}.items():
            if values and set(values) != set(self.params):
                raise ValueError(
                    f"form {self.target}/{self.name}: preset {preset!r} does not set exactly {self.params}"
                )
        if self.start is None and not self.presets:
            raise ValueError(f"form {self.target}/{self.name}: needs a preset or start values")
        if not set(self.fixed) <= set(self.params):
            raise ValueError(f"form {self.target}/{self.name}: fixed parameters must be parameters")

    # -- identity ---------------------------------------------------------
    @property
    def key(self) -> str:
        return f"{self.target}/{self.name}"

    @property
    def free_params(self) -> tuple[str, ...]:
        return tuple(p for p in self.params if p not in self.fixed)

    @property
    def fit_expr(self) -> sp.Expr:
        """The expression the optimizer sees: ``expr`` without an outer max(0, g).

        A clamped point has zero gradient, so the clamp would hide from the
        optimizer every point it should pull back above zero; fits are made on
        g and evaluated (validated, saved, generated) with the clamp.
        """
        e = self.expr
        if isinstance(e, sp.Max) and len(e.args) == 2 and sp.S.Zero in e.args:
            return next(cast(sp.Expr, a) for a in e.args if a != sp.S.Zero)  # sympy annotates .args as Basic
        return e

    @property
    def expression(self) -> str:
        return expression_text(self.expr)

    @property
    def start_values(self) -> dict[str, float]:
        values = dict(self.start) if self.start is not None else dict(next(iter(self.presets.values())))
        values.update(self.fixed)
        return values

    def vector(self, values: Mapping[str, float] | str) -> np.ndarray:
        """Parameter vector (in ``params`` order) from a mapping or a preset name."""
        if isinstance(values, str):
            if values not in self.presets:
                raise KeyError(f"{self.key} has no preset {values!r}; presets: {sorted(self.presets)}")
            values = self.presets[values]
        missing = [p for p in self.params if p not in values]
        if missing:
            raise KeyError(f"{self.key}: missing parameter values {missing}")
        return np.array([float(values[p]) for p in self.params])

    # -- back ends ----------------------------------------------------------
    @cached_property
    def _symbols(self):
        return symbols(self.params), symbols(self.inputs)

    @cached_property
    def numpy_function(self):
        """f(theta, *inputs) on numpy arrays, theta a vector in ``params`` order."""
        return self._numpy(self.expr)

    @cached_property
    def numpy_fit_function(self):
        """Like :attr:`numpy_function`, of :attr:`fit_expr`."""
        return self._numpy(self.fit_expr)

    def _numpy(self, expr):
        ps, xs = self._symbols
        raw = lambdify_numpy([ps, *xs], expr)

        def f(theta, *inputs):
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                out = raw(tuple(np.asarray(theta, dtype=float)), *inputs)
            return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(np.shape(x) for x in inputs)))

        return f

    @cached_property
    def jax_function(self):
        """f(theta, *inputs) in jax.numpy of :attr:`fit_expr` (differentiable in theta and the inputs)."""
        import jax.numpy as jnp

        ps, xs = self._symbols
        raw = lambdify_jax([ps, *xs], self.fit_expr)

        def f(theta, *inputs):
            out = raw(tuple(theta[i] for i in range(len(self.params))), *inputs)
            shape = jnp.broadcast_shapes(*(jnp.shape(x) for x in inputs))
            return jnp.broadcast_to(jnp.asarray(out, dtype=float), shape)

        return f

    def __call__(self, values: Mapping[str, float] | str, *inputs):
        """Evaluate with parameter ``values`` (mapping or preset name) on numpy inputs."""
        return self.numpy_function(self.vector(values), *inputs)

    def substituted(self, values: Mapping[str, float] | str) -> sp.Expr:
        """The expression with numbers in place of the parameters."""
        theta = self.vector(values)
        ps, _ = self._symbols
        return self.expr.subs({p: sp.Float(repr(float(v)), 17) for p, v in zip(ps, theta)})
