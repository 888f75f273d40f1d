r"""Expression printers: one sympy expression in, C, GLSL, numpy or Dr.Jit text out.

Every printer extends sympy's own (C99, NumPy or Python) with the few things fitlab's
forms need:

* ``safe_pow(x, p)`` prints as a call of the generated helper (x^p for x > 0,
  0 otherwise); the helper is emitted once per file by :mod:`.languages`.
* calls of other routines (sympy ``Function("h0")(mu_i, c)``) print as calls
  of the generated function of that routine, with the language's name.
* pi prints as a literal, not ``M_PI`` (not part of strict C99), and small
  integer powers print as products (faster than ``pow`` and exact).
* Max and Min print as conditionals (:func:`fitlab.codegen.minmax_piecewise`)
  that let NaN through, the same in every language (not fmax, max or numpy.maximum).
* symbols can be renamed, so that a routine's vector argument ``wi`` reads
  ``wi[0]`` in C, ``wi.x`` in GLSL and ``wi[..., 0]`` in numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import sympy as sp
from sympy.codegen.ast import float32, float64, real
from sympy.core.function import AppliedUndef
from sympy.printing.c import C99CodePrinter
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.precedence import precedence
from sympy.printing.pycode import PythonCodePrinter

from fitlab.codegen._policy import minmax_piecewise
from fitlab.forms.symbolic import safe_pow

__all__ = ["CPrinter", "GLSLPrinter", "MetalPrinter", "NumpyPrinter", "DrJitPrinter"]

_PI_DIGITS = "3.141592653589793238"


def _small_power(printer, expr) -> str | None:
    """x^n for n = 2 to 6, x^-n = 1/x^n for n = 2 to 6 and x^(n/2) for n = 3, 5, 7 as products (with one sqrt);
    None otherwise.

    pow() costs tens of ns where a multiply costs one (C compilers keep pow(x, 5.0) a call without
    -ffast-math); (1 - c)^(3/2) = s^3 is common in the forms (powers of s = sqrt(1 - c)), Schlick's
    (1 - mu)^5 and F82-tint's (1 - mu)^6 in every Fresnel approximation; a product of n factors is within
    n - 1 rounding errors of the power, as accurate as pow's few ulp for these n.
    """
    e = expr.exp
    base = printer.parenthesize(expr.base, precedence(sp.Mul(2, expr.base, evaluate=False)) + 1)
    # the product is bracketed: a power binds tighter than * and /, and the Mul printer puts it after a
    # "/" unbracketed when it is a denominator (x**3/y**3 must not print as x*x*x/y*y*y)
    if e.is_Integer and 2 <= int(e) <= 6:
        return "(" + "*".join([base] * int(e)) + ")"
    if e.is_Integer and -6 <= int(e) <= -2:
        return f"({printer._print(sp.S.One)}/(" + "*".join([base] * -int(e)) + "))"
    if e.is_Rational and e.q == 2 and 3 <= e.p <= 7:
        return "(" + "*".join([base] * (e.p // 2) + [printer._print(sp.sqrt(expr.base))]) + ")"
    return None


if TYPE_CHECKING:  # for the type checker, the mixin is a code printer (it is mixed into one first)
    from sympy.printing.codeprinter import CodePrinter as _MixinBase
else:
    _MixinBase = object


class _Common(_MixinBase):
    """Shared overrides: routine calls, safe_pow, symbol renames."""

    if TYPE_CHECKING:

        def doprint(self, expr, assign_to=None) -> str: ...  # without assign_to, sympy's doprint gives text

        def _conditional(self, cond: str, a: str, b: str) -> str: ...  # each language's conditional

    def __init__(self, call_name: Callable[[str], str], symbol_names: Mapping[str, str] | None = None, **settings):
        super().__init__(settings)
        self.call_name = call_name
        self.symbol_names = dict(symbol_names or {})

    def _print_Symbol(self, expr):
        return self.symbol_names.get(expr.name, expr.name)

    def _print_Function(self, expr):
        if isinstance(expr, AppliedUndef):
            return f"{self.call_name(expr.func.__name__)}({', '.join(self._print(a) for a in expr.args)})"
        if isinstance(expr, safe_pow):
            return f"{self.call_name('safe_pow')}({self._print(expr.args[0])}, {self._print(expr.args[1])})"
        return super()._print_Function(expr)

    # Max/Min: one NaN-propagating definition for every language (fitlab.codegen.minmax_piecewise);
    # the emitter puts a non-atomic argument into a temporary first, so that it is printed once.
    # Piecewise: a conditional each language spells its way.
    def _print_Max(self, expr):
        return self._print(minmax_piecewise(expr))

    _print_Min = _print_Max

    def _print_Piecewise(self, expr):
        if expr.args[-1].cond is not sp.true:
            raise ValueError("a Piecewise needs a final (value, True) branch")
        out = self._print(expr.args[-1].expr)
        for branch in reversed(expr.args[:-1]):
            out = self._conditional(self._print(branch.cond), self._print(branch.expr), out)
        return out


class CPrinter(_Common, C99CodePrinter):
    """C99 for ``double`` or ``float`` (then every literal has the F suffix and
    every libm call its float version: sqrtf, powf, ...)."""

    def __init__(self, scalar: str, call_name, symbol_names=None):
        if scalar not in ("double", "float"):
            raise ValueError("scalar must be 'double' or 'float'")
        self.scalar = scalar
        super().__init__(
            call_name, symbol_names, type_aliases={real: float64 if scalar == "double" else float32}, math_macros={}
        )

    def _literal(self, text: str) -> str:
        return text + ("F" if self.scalar == "float" else "")

    def _print_Pi(self, expr):
        return self._literal(_PI_DIGITS)

    def _print_Integer(self, expr):
        return self._literal(f"{int(expr)}.0")

    def _print_Rational(self, expr):
        return f"({self._literal(f'{expr.p}.0')}/{self._literal(f'{expr.q}.0')})"

    def _print_Pow(self, expr):
        return _small_power(self, expr) or super()._print_Pow(expr)

    def _conditional(self, cond, a, b):
        return f"(({cond}) ? ({a}) : ({b}))"


class GLSLPrinter(CPrinter):
    """GLSL (version 3.30 / ES 3.00 and later): float only, overloaded
    built-ins (sqrt, pow, max, abs, ...), no literal suffixes."""

    def __init__(self, call_name, symbol_names=None):
        super().__init__("double", call_name, symbol_names)  # double: libm names without the f suffix

    def _print_Abs(self, expr):
        return f"abs({self._print(expr.args[0])})"

    # GLSL has no expm1 / log1p: the emitter supplies them as helpers
    def _print_expm1(self, expr):
        return f"{self.call_name('expm1')}({self._print(expr.args[0])})"

    def _print_log1p(self, expr):
        return f"{self.call_name('log1p')}({self._print(expr.args[0])})"

    def _print_Pow(self, expr):
        if expr.exp == -1:
            return f"1.0/{self.parenthesize(expr.base, precedence(expr))}"
        return super()._print_Pow(expr)


class MetalPrinter(GLSLPrinter):
    """The Metal Shading Language: GLSL's overloaded built-ins (metal_stdlib), float literals with the f
    suffix (an unsuffixed literal is a double in C++, which Metal lacks)."""

    def _literal(self, text: str) -> str:
        return text + "f"

    def _print_Float(self, flt):
        return super()._print_Float(flt) + "f"


class NumpyPrinter(_Common, NumPyPrinter):
    """numpy, for arrays of any broadcastable shapes; ``import numpy`` only."""

    def __init__(self, call_name, symbol_names=None):
        super().__init__(call_name, symbol_names, fully_qualified_modules=True, inline=True)

    def _print_Pi(self, expr):
        return _PI_DIGITS

    def _print_Pow(self, expr, rational=False):
        return _small_power(self, expr) or super()._print_Pow(expr, rational=rational)

    def _conditional(self, cond, a, b):
        return f"numpy.where({cond}, {a}, {b})"


class DrJitPrinter(_Common, PythonCodePrinter):
    """Dr.Jit (``import drjit as dr``): one text for Dr.Jit arrays of any backend and precision (the caller's
    arrays choose: ``drjit.llvm.ad.Float``, ``drjit.cuda.Float64``, Mitsuba's ``Color3f``, ...) and for
    Python floats (Mitsuba's scalar variants): it calls only functions Dr.Jit defines for both.

    * A conditional is ``dr.select(cond, a, b)`` (both branches are evaluated, as in numpy); ``&`` and
      ``|`` combine conditions (``and`` would ask an array for its truth value).
    * Integers print as float literals: ``dr.select(mask, 0, 1)`` of two Python ints is an integer array.
    * An integer power above the small ones is ``dr.power(x, n)`` with an integer n, which Dr.Jit
      evaluates by multiplication (with a float n it takes exp2(n log2 x): NaN for x < 0).
    * Dr.Jit has no expm1 and log1p: they print as calls of generated helpers (as in GLSL).
    """

    #: sympy function -> Dr.Jit function of the same name for arrays and Python floats
    _FUNCTIONS = {"exp": "exp", "log": "log", "acos": "acos", "asin": "asin", "atan": "atan", "sin": "sin",
                  "cos": "cos", "tan": "tan", "Abs": "abs", "erf": "erf"}  # fmt: skip

    def __init__(self, call_name, symbol_names=None):
        super().__init__(call_name, symbol_names, fully_qualified_modules=False, inline=True)

    def _print_Function(self, expr):
        name = type(expr).__name__
        if isinstance(expr, (AppliedUndef, safe_pow)):
            return super()._print_Function(expr)
        if name in self._FUNCTIONS:
            return f"dr.{self._FUNCTIONS[name]}({', '.join(self._print(a) for a in expr.args)})"
        if name in ("expm1", "log1p"):
            return f"{self.call_name(name)}({self._print(expr.args[0])})"
        raise ValueError(f"no Dr.Jit spelling of {name}")

    _print_exp = _print_log = _print_acos = _print_asin = _print_atan = _print_Function
    _print_sin = _print_cos = _print_tan = _print_Abs = _print_erf = _print_expm1 = _print_log1p = _print_Function

    def _print_Pi(self, expr):
        return _PI_DIGITS

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"

    _print_Zero = _print_One = _print_NegativeOne = _print_Integer

    def _print_Rational(self, expr):
        return f"{expr.p}.0/{expr.q}.0"

    _print_Half = _print_Rational

    def _print_Pow(self, expr, rational=False):
        small = _small_power(self, expr)
        if small:
            return small
        base, e = self._print(expr.base), expr.exp
        if e == sp.S.Half:
            return f"dr.sqrt({base})"
        if e == -sp.S.Half:
            return f"(1.0/dr.sqrt({base}))"
        if e == -1:
            return f"(1.0/{self.parenthesize(expr.base, precedence(expr))})"
        if e.is_Integer:
            return f"dr.power({base}, {int(e)})"
        return f"dr.power({base}, {self._print(e)})"

    def _print_Relational(self, expr):
        if expr.rel_op not in ("==", "!=", "<", "<=", ">", ">="):
            raise ValueError(f"no Dr.Jit spelling of the relation {expr.rel_op}")
        return f"({self._print(expr.lhs)} {expr.rel_op} {self._print(expr.rhs)})"

    def _print_And(self, expr):
        return "(" + " & ".join(self._print(a) for a in expr.args) + ")"

    def _print_Or(self, expr):
        return "(" + " | ".join(self._print(a) for a in expr.args) + ")"

    def _print_Not(self, expr):
        # ~ negates a Dr.Jit mask but turns the Python bool True into -2
        raise ValueError(
            "no Dr.Jit spelling of a negation that serves masks and Python bools: print the opposite relation"
        )

    def _print_BooleanTrue(self, expr):
        return "True"

    def _print_BooleanFalse(self, expr):
        return "False"

    def _conditional(self, cond, a, b):
        return f"dr.select({cond}, {a}, {b})"
