"""The array namespaces the physics is written against: numpy, jax.numpy and sympy (docs/architecture.md)."""

from __future__ import annotations

import contextlib
import math
from functools import cache
from typing import Any

import numpy as np

__all__ = ["Namespace", "namespace", "NUMPY", "jax_namespace", "sympy_namespace"]


class Namespace:
    """The functions a physics formula calls besides + - * / and ``**``: numpy's names, each the back end's own.

    Beyond numpy's names, the primitives whose careful form differs between back ends:

    * ``ratio(num, den, at_zero)``: num / den, and ``at_zero`` where den <= 0 (a limit the formula states); sympy
      writes num / den (the limit is a point of measure zero, where generated code is not evaluated);
    * ``sin_of(x)``: sqrt(1 - x^2) of a cosine x in [-1, 1]: sqrt((1 - x)(1 + x)) in floating point (no cancellation
      near |x| = 1), sqrt(Max(0, 1 - x^2)) in sympy (clamped against the rounding of printed code);
    * ``nonneg_times(x, y)``: x y of an x >= 0, and 0 where x = 0 whatever y (an infinite y there: a limit); sympy
      writes x y;
    * ``positive_part(x)``: max(x, 0); sympy writes safe_pow(x, 1), which every back end of fitlab.forms prints;
    * ``pow_nonneg(x, p)``: x^p of a base that is >= 0 on the domain; sympy writes safe_pow(x, p), whose gradient in
      p stays finite at x = 0 (fitlab.forms);
    * ``rational(p, q)``: p / q, exact in sympy;
    * ``quiet()``: a context in which a division by zero or an invalid operation is silent (numpy's errstate).
    """

    name: str
    pi: Any
    sqrt_pi: Any

    def __init__(self, name: str, module: Any, erfc: Any, beta: Any) -> None:
        self.name = name
        self._module = module
        self.pi = module.pi
        self.sqrt_pi = math.sqrt(math.pi)  # a Python float: it keeps float32 arrays float32
        self.erfc = erfc
        self.beta = beta
        for f in ("sqrt", "exp", "log", "sin", "cos", "arccos", "arcsin", "abs", "hypot", "maximum", "minimum", "where",
                  "clip"):  # fmt: skip
            setattr(self, f, getattr(module, f))

    def ratio(self, num: Any, den: Any, at_zero: Any) -> Any:
        m = self._module
        positive = den > 0
        return m.where(positive, num / m.where(positive, den, 1), at_zero)

    def sin_of(self, x: Any) -> Any:
        return self._module.sqrt((1 - x) * (1 + x))

    def nonneg_times(self, x: Any, y: Any) -> Any:
        return self._module.where(x > 0, x * y, 0)

    def positive_part(self, x: Any) -> Any:
        return self._module.maximum(x, 0.0)

    def pow_nonneg(self, x: Any, p: Any) -> Any:
        return x**p

    @staticmethod
    def rational(p: int, q: int) -> float:
        return p / q

    def quiet(self) -> contextlib.AbstractContextManager[Any]:
        if self._module is np:
            return np.errstate(divide="ignore", invalid="ignore", over="ignore")
        return contextlib.nullcontext()

    def __getattr__(self, item: str) -> Any:  # for the type checker: the numpy names set in __init__
        raise AttributeError(item)


def _scipy_erfc(x: Any) -> Any:
    from scipy.special import erfc

    return erfc(x)


def _scipy_beta(a: Any, b: Any) -> Any:
    from scipy.special import beta

    return beta(a, b)


#: numpy (scipy for erfc and beta)
NUMPY = Namespace("numpy", np, _scipy_erfc, _scipy_beta)


@cache
def jax_namespace() -> Namespace:
    """jax.numpy (jax.scipy.special for erfc and beta), imported when first asked for."""
    import jax.numpy as jnp
    from jax.scipy.special import beta, erfc

    return Namespace("jax", jnp, erfc, beta)


class _Sympy(Namespace):
    """sympy: expressions for the forms and the printers (fitlab.forms, fitlab.codegen)."""

    def __init__(self) -> None:
        import sympy as sp

        from fitlab.forms.symbolic import safe_pow

        self.name = "sympy"
        self._sp = sp
        self._safe_pow = safe_pow
        self.pi = sp.pi
        self.sqrt_pi = sp.sqrt(sp.pi)
        self.sqrt, self.exp, self.log, self.sin, self.cos = sp.sqrt, sp.exp, sp.log, sp.sin, sp.cos
        self.arccos, self.arcsin, self.abs, self.erfc, self.beta = sp.acos, sp.asin, sp.Abs, sp.erfc, sp.beta
        self.maximum, self.minimum = sp.Max, sp.Min

    def hypot(self, x: Any, y: Any) -> Any:
        return self._sp.sqrt(x**2 + y**2)

    def where(self, cond: Any, a: Any, b: Any) -> Any:
        sp = self._sp
        if isinstance(cond, (bool, sp.logic.boolalg.BooleanAtom)):
            return a if cond else b
        return sp.Piecewise((a, cond), (b, True))

    def clip(self, x: Any, lo: Any, hi: Any) -> Any:
        return self._sp.Min(hi, self._sp.Max(lo, x))

    def ratio(self, num: Any, den: Any, at_zero: Any) -> Any:
        return num / den

    def sin_of(self, x: Any) -> Any:
        sp = self._sp
        return sp.sqrt(sp.Max(0, 1 - x**2, evaluate=False))

    def nonneg_times(self, x: Any, y: Any) -> Any:
        return x * y

    def positive_part(self, x: Any) -> Any:
        return self._safe_pow(x, 1)

    def pow_nonneg(self, x: Any, p: Any) -> Any:
        return self._safe_pow(x, p)

    def rational(self, p: int, q: int) -> Any:  # type: ignore[override]
        return self._sp.Rational(p, q)

    def quiet(self) -> contextlib.AbstractContextManager[Any]:
        return contextlib.nullcontext()


@cache
def sympy_namespace() -> Namespace:
    """sympy, imported when first asked for."""
    return _Sympy()


def namespace(*values: Any) -> Namespace:
    """The namespace of the arguments of a formula: sympy if any is a sympy object, jax.numpy if any is a JAX array
    (a tracer too), else numpy (numbers and numpy arrays)."""
    modules = [type(v).__module__ for v in values]
    if any(m.startswith("sympy") for m in modules):
        return sympy_namespace()
    if any(m.startswith(("jax", "jaxlib")) for m in modules):
        return jax_namespace()
    return NUMPY
