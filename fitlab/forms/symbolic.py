r"""The symbolic vocabulary every form is written in, and its numeric back ends.

A form is one sympy expression; this module turns it into numpy and JAX
functions (and, later, C and GLSL source) so that no formula is written twice.

``safe_pow(x, p)`` is x^p for x > 0 and 0 for x <= 0 (forms only use it with
x >= 0 and p > 0).  It exists because x**p written directly makes the gradient
in p equal log(x) x^p = (-inf)(0) = NaN at x = 0 (mu = 0, s = 0, kd = 1), which
would reach the optimizer; here the gradient is exactly 0 there.  In C it
prints as pow(x, p), which has the same values for x >= 0, p > 0.
"""

from __future__ import annotations

import ast
import math
import operator
import re
from functools import lru_cache

import numpy as np
import sympy as sp

__all__ = [
    "safe_pow",
    "symbols",
    "lambdify_numpy",
    "lambdify_jax",
    "parse_expression",
    "FUNCTIONS",
    "CONSTANTS",
    "expression_text",
]


class safe_pow(sp.Function):  # noqa: N801 (the name printed in every back end)
    """x^p for x > 0, 0 for x <= 0; numeric arguments evaluate at once."""

    nargs = 2

    @classmethod
    def eval(cls, x, p):
        if x.is_Number and p.is_Number:
            return x**p if x > 0 else sp.S.Zero
        return None


def symbols(names):
    """Real sympy symbols, one per name (a tuple, even for one name)."""
    return tuple(sp.Symbol(n, real=True) for n in names)


def _np_safe_pow(x, p):
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(x > 0.0, np.power(np.where(x > 0.0, x, 1.0), p), 0.0)


def _jax_safe_pow(x, p):
    import jax.numpy as jnp

    pos = x > 0.0
    # the inner where keeps log(0) out of the backward pass
    return jnp.where(pos, jnp.exp(p * jnp.log(jnp.where(pos, x, 1.0))), 0.0)


#: how many distinct expressions the memoised translations below keep (each is a pure function of its
#: arguments; sympy's cse and printers cost 0.1 s per expression, and a report or a refit asks for the same
#: expressions many times)
_MEMO = 256
#: the longest expression text the parser's memo keeps (the packaged fits' longest is 7245 characters)
_MEMO_TEXT = 16_384


def lambdify_numpy(args, expr):
    """A numpy function of ``args`` (symbols) computing ``expr`` (an expression, or a list of them)."""
    return _lambdify(args, expr, "numpy")


def lambdify_jax(args, expr):
    """A jax.numpy function of ``args`` computing ``expr`` (jit- and grad-able)."""
    return _lambdify(args, expr, "jax")


def _lambdify(args, expr, backend):
    # a list of expressions (a library of terms) is translated each time: it is not hashable, and a tuple
    # would make the function return a tuple instead of a list; so are arguments that are not a flat sequence
    # of symbols (a bare symbol is kept as one)
    if isinstance(expr, sp.Basic):
        key = _symbol_key(args)
        if key is not None:
            return _lambdify_memo(key, expr, backend)
    return _translate(args, expr, backend)


def _symbol_key(args):
    """``args`` (a symbol, or sequences of them nested, as lambdify takes them) as nested tuples; None where a
    leaf is not a sympy object."""
    if isinstance(args, sp.Basic):
        return args
    if isinstance(args, (list, tuple)):
        parts = tuple(_symbol_key(a) for a in args)
        return None if any(p is None for p in parts) else parts
    return None


def _translate(args, expr, backend):
    safe = _np_safe_pow if backend == "numpy" else _jax_safe_pow
    return sp.lambdify(args, expr, modules=[{"safe_pow": safe}, backend], cse=True)


_lambdify_memo = lru_cache(maxsize=_MEMO)(_translate)


def expression_text(expr) -> str:
    """The text stored in fits JSON; :func:`parse_expression` reads it back."""
    return _text_memo(expr) if isinstance(expr, sp.Basic) else _text(expr)


def _text(expr) -> str:
    return sp.sstr(expr, full_prec=True)


_text_memo = lru_cache(maxsize=_MEMO)(_text)


#: the functions an expression in a fit file may call, with their number of arguments
FUNCTIONS = {
    "sqrt": (sp.sqrt, 1),
    "log": (sp.log, 1),
    "exp": (sp.exp, 1),
    "cos": (sp.cos, 1),
    "sin": (sp.sin, 1),
    "acos": (sp.acos, 1),
    "atan": (sp.atan, 1),
    "tanh": (sp.tanh, 1),
    "Abs": (sp.Abs, 1),
    "Max": (sp.Max, None),
    "Min": (sp.Min, None),
    "safe_pow": (safe_pow, 2),
}
#: named constants an expression may use
CONSTANTS = {"pi": sp.pi, "E": sp.E}
#: limits on what a parser accepts: text length, nesting depth, arguments per call, magnitude of an exponent
MAX_TEXT = 100_000
MAX_DEPTH = 100
MAX_ARGS = 64
MAX_EXPONENT = 64
#: limits on every number the parser forms (literal, or made by sympy from constant parts) and on the value of
#: every constant part: at most MAX_MAGNITUDE in magnitude and, unless exactly 0, at least 1/MAX_MAGNITUDE;
#: integers, and the numerator and denominator of fractions, of at most MAX_DIGITS digits (literals too)
MAX_MAGNITUDE = 1e300
MAX_DIGITS = 300
_MAX_BITS = int(MAX_DIGITS * math.log2(10))  # 996: a 300-digit integer has at most 997 bits

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}  # fmt: skip


def _pow(x, p):
    if x == 0.0 and p < 0.0:
        raise ZeroDivisionError
    return math.pow(x, p)


#: the value of each operation and function on floats, for the constant parts of an expression: the
#: parser's operators (ast) and functions, and the sympy classes the formed expressions are made of
_FLOAT = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv, ast.Pow: _pow,
    sp.Add: lambda *v: math.fsum(v), sp.Mul: lambda *v: math.prod(v), sp.Pow: _pow,
    sp.sqrt: math.sqrt, sp.log: math.log, sp.exp: math.exp, sp.cos: math.cos, sp.sin: math.sin, sp.acos: math.acos,
    sp.atan: math.atan, sp.tanh: math.tanh, sp.Abs: abs, sp.Max: max, sp.Min: min,
    sp.re: lambda x: x, sp.im: lambda x: 0.0,  # sympy's, of constant parts whose values are real (checked)
    safe_pow: lambda x, p: _pow(x, p) if x > 0.0 else 0.0,
}  # fmt: skip
#: the operations whose value is 0 from nonzero operands only by underflow
_UNDERFLOW = (ast.Mult, ast.Div, ast.Pow, sp.Mul, sp.Pow, sp.exp)
_NOT_FINITE = (sp.core.numbers.NaN, sp.core.numbers.ComplexInfinity, sp.core.numbers.Infinity,
               sp.core.numbers.NegativeInfinity)  # fmt: skip


def _float_value(op, values) -> float:
    """``op`` applied to ``values`` in floats, refused (ValueError) when it is not finite and real or out of bounds."""
    try:
        v = float(_FLOAT[op](*values))
    except ZeroDivisionError:
        raise ValueError("divides by zero") from None
    except OverflowError:
        raise ValueError(f"is beyond {MAX_MAGNITUDE:g} in magnitude") from None
    except ValueError:
        raise ValueError("has no finite real value") from None
    underflow = v == 0.0 and all(values) and (op in _UNDERFLOW or (op is safe_pow and values[0] > 0.0))
    return _bounded(v, underflow=underflow)


def _bounded(v: float, underflow: bool = False) -> float:
    if math.isnan(v):
        raise ValueError("has no finite real value")
    if abs(v) > MAX_MAGNITUDE:  # inf too: made of finite values, it is an overflow
        raise ValueError(f"is beyond {MAX_MAGNITUDE:g} in magnitude")
    if underflow or 0.0 < abs(v) < 1.0 / MAX_MAGNITUDE:
        raise ValueError(f"is not 0 and below {1.0 / MAX_MAGNITUDE:g} in magnitude")
    return v


def _coefficient(x):
    """The number that multiplies ``x`` (x itself for a number), or None."""
    if x.is_Number:
        return x
    if x.is_Mul and x.args[0].is_Number:
        return x.args[0]
    return None


def _log10(c) -> float:
    return math.log10(abs(float(c))) if not c.is_zero else 0.0


def _bits(r) -> int:
    """The size of a fraction p/q: the bits of the larger of |p| and q."""
    return max(abs(r.p).bit_length(), r.q.bit_length())


def _powers(x) -> dict:
    """{b: r} for the fractions b that sympy raises to a power when it raises x to one or multiplies it: x or
    its factors, b or b**r (b and r fractions)."""
    out = {}
    for f in x.args if x.is_Mul else (x,):
        if f.is_Rational:
            out[f] = sp.S.One
        elif f.is_Pow and f.base.is_Rational and f.exp.is_Rational:
            out[f.base] = f.exp
    return out


def _power_bits(b, r) -> int:
    """The size (bits) of the numbers sympy may make forming b**r, b and r = p/q fractions: b**|p| or b**(q - 1)."""
    return _bits(b) * max(abs(r.p), r.q)


def _check_scale(log10: float) -> None:
    if log10 > math.log10(MAX_MAGNITUDE):
        raise ValueError(f"would make a number beyond {MAX_MAGNITUDE:g} in magnitude")
    if log10 < -math.log10(MAX_MAGNITUDE):
        raise ValueError(f"would make a number below {1.0 / MAX_MAGNITUDE:g} in magnitude")


def _check_power(base, e) -> None:
    """Refuses base**e (e a number; sympy forms no number from a power to anything else) when sympy would make
    a number out of bounds to form it: b**(r e) for each power b**r of a fraction in base (a power of a product
    is the product of the powers), the number multiplying base raised to e."""
    if not e.is_Number:
        return
    if abs(float(e)) > MAX_EXPONENT:
        raise ValueError(f"raises to the power {sp.sstr(e)[:20]}; at most {MAX_EXPONENT} in magnitude")
    if e.is_Rational and any(_power_bits(b, r * e) > _MAX_BITS for b, r in _powers(base).items()):
        raise ValueError(f"would make a number of more than {MAX_DIGITS} digits")
    c = _coefficient(base)
    if c is not None and not c.is_zero:
        _check_scale(float(e) * _log10(c))


class _Bounds:
    """The checks of :func:`parse_expression` on what it forms.

    :meth:`before` is called with an operation and its operands (already checked) before sympy forms
    the result, and refuses it when sympy would make a number out of bounds forming it: the value of
    a constant part (computed in floats from its parts' values) out of bounds, not finite or not real;
    a division by zero; the numbers sympy computes at once for a power or a product (a power of the
    number multiplying a part, b**(r e) for (b**r)**e and b**(r1 + r2) for b**r1 b**r2 with b and r
    fractions, x**k for exp(k log(x))) beyond :data:`MAX_MAGNITUDE` or :data:`MAX_DIGITS`, or raised
    beyond :data:`MAX_EXPONENT`.  :meth:`check` walks what sympy formed (each part once: the ones
    seen before are remembered) and refuses any number, constant part or exponent out of bounds, a
    power b**r of fractions whose forms (b**|p|, b**(q - 1)) would be, a power x**(k + y) whose
    x**k would be (sympy takes it apart so, forming later powers), and nan, zoo, oo and I wherever
    sympy made them.  So every step sympy takes works on numbers of bounded size.
    """

    def __init__(self):
        self.values = {}  # id of a checked part -> its value in floats (None: it holds a name)
        self.parts = []  # the checked parts, kept alive so that their ids stay theirs

    def value(self, expr):
        if id(expr) not in self.values:
            self.check(expr)
        return self.values[id(expr)]

    def before(self, op, *args) -> None:
        values = [self.value(a) for a in args]
        if all(v is not None for v in values):
            _float_value(op, values)
        elif op is ast.Div and values[1] == 0.0:
            raise ValueError("divides by zero")
        if op in (ast.Mult, ast.Div):
            # b**r1 times b**r2 is b**(r1 + r2); the numbers multiplying the operands are multiplied
            sign = 1 if op is ast.Mult else -1
            left, right = _powers(args[0]), _powers(args[1])
            if any(_power_bits(b, r + sign * right[b]) > _MAX_BITS for b, r in left.items() if b in right):
                raise ValueError(f"would make a number of more than {MAX_DIGITS} digits")
            cl, cr = _coefficient(args[0]), _coefficient(args[1])
            if cl is not None and cr is not None and not cl.is_zero and not cr.is_zero:
                _check_scale(_log10(cl) + sign * _log10(cr))
        elif op is ast.Pow or (op is safe_pow and args[0].is_Number and args[1].is_Number and args[0] > 0):
            _check_power(*args)
        elif op is sp.sqrt:
            _check_power(args[0], sp.S.Half)
        if op is sp.exp or (op in (ast.Pow, safe_pow) and args[0] is sp.E):
            # exp(k log(x) + y) is x**k exp(y)
            for term in sp.Add.make_args(args[-1]):
                k, rest = term.as_coeff_Mul()
                if isinstance(rest, sp.log):
                    _check_power(rest.args[0], k)

    def check(self, expr):
        """``expr``, once every part of it not seen before is checked (ValueError: the reason it is refused)."""
        stack = [(expr, False)]
        while stack:
            e, ready = stack.pop()
            if id(e) in self.values:
                continue
            if e.args and not ready:
                stack.append((e, True))
                stack.extend((a, False) for a in e.args if id(a) not in self.values)
                continue
            self.values[id(e)] = self._value(e)
            self.parts.append(e)
        return expr

    def _value(self, e):
        if isinstance(e, _NOT_FINITE):
            raise ValueError(f"makes {e}, not a finite number")
        if e is sp.I:
            raise ValueError("makes the imaginary unit I, not a real number")
        if e.is_Symbol:
            return None
        if e.is_Rational:
            if _bits(e) > _MAX_BITS:
                raise ValueError(f"makes a number of more than {MAX_DIGITS} digits")
            return _bounded(float(e))
        if e.is_Float:
            v = float(e)
            if math.isinf(v):
                raise ValueError(f"makes {sp.sstr(e)[:40]}, beyond {MAX_MAGNITUDE:g} in magnitude")
            return _bounded(v, underflow=v == 0.0 and not e.is_zero)
        if e.is_NumberSymbol:
            return float(e)
        if e.is_Atom:
            raise ValueError(f"makes {type(e).__name__}, which is not a real number")
        if e.is_Pow and e.exp.is_Number and abs(float(e.exp)) > MAX_EXPONENT:
            raise ValueError(f"makes the power {e.exp}; at most {MAX_EXPONENT} in magnitude")
        if e.is_Pow and e.base.is_Rational and e.exp.is_Rational and _power_bits(e.base, e.exp) > _MAX_BITS:
            base = sp.sstr(e.base)[:20]
            raise ValueError(f"makes a power of {base} that needs numbers of more than {MAX_DIGITS} digits")
        if e.is_Pow and not e.exp.is_Number and e.base is not sp.E:
            # sympy takes x**(k + y) apart as x**k x**y (forming a power of this one, or one with this one in its
            # exponent; expanding): x**k must be one it can form
            k = e.exp.as_coeff_Add()[0]
            try:
                _check_power(e.base, k)
            except ValueError as exc:
                raise ValueError(f"makes a power with {sp.sstr(k)[:20]} added to its exponent: {exc}") from None
        values = [self.values[id(a)] for a in e.args]
        if any(v is None for v in values):
            return None
        if type(e) not in _FLOAT:
            raise ValueError(f"makes a constant {type(e).__name__}, which is not checked")
        return _float_value(type(e), values)


def parse_expression(text: str, names) -> sp.Expr:
    """Parse an expression written by :func:`expression_text`, without evaluating any code.

    The text is parsed by Python's ``ast`` (which only parses) and the tree is walked with a
    whitelist: numbers (int and finite float literals), the names ``names`` (inputs and
    parameters), the constants :data:`CONSTANTS`, the functions :data:`FUNCTIONS` called with
    their number of positional arguments, and + - * / ** with unary minus.  Anything else
    (attributes, subscripts, keywords, strings, lambdas, comprehensions, unknown names, dunder
    names), text longer than :data:`MAX_TEXT`, nesting deeper than :data:`MAX_DEPTH` and a literal
    exponent beyond :data:`MAX_EXPONENT` in magnitude is refused with one ValueError line.  The
    result equals what sympy's own parser makes of the same text (number literals become
    Integer and Float exactly as there).

    Every number is bounded before it is formed, and every part that sympy forms is checked once
    formed (:class:`_Bounds`): a number or constant part (one without names, e.g. ``acos(2)``,
    ``exp(800)``) whose value is not finite, not real, beyond :data:`MAX_MAGNITUDE` in magnitude
    (or, not 0, below its inverse), an integer or fraction of more than :data:`MAX_DIGITS` digits (or
    a power that sympy would compute with such numbers), an exponent beyond :data:`MAX_EXPONENT`
    that sympy makes by combining powers or adds to a power's exponent, a division by zero, and a
    part sympy fails to form are refused with one ValueError line, the same way, before any larger
    number is made.
    """
    if not isinstance(text, str):
        raise ValueError(f"expression must be a string, not {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise ValueError(f"expression is {len(text)} characters long; at most {MAX_TEXT} are read")
    # memoised on the text and the names (at most _MEMO texts of at most _MEMO_TEXT characters are kept; a longer
    # one is parsed each time); a refusal is not kept, it is raised again
    return (_parse_memo if len(text) <= _MEMO_TEXT else _parse)(text, tuple(names))


def _parse(text: str, names: tuple) -> sp.Expr:
    allowed = {n: sp.Symbol(n, real=True) for n in names}
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ValueError(f"cannot parse expression: {type(exc).__name__}") from None
    source = text.strip()
    lines = [line.encode("utf-8") for line in re.findall(r"[^\r\n]*(?:\r\n|\r|\n)|[^\r\n]+$", source)]
    bounds = _Bounds()

    def segment(node) -> str:
        # ast.get_source_segment (lines end at \r, \n or \r\n; offsets count UTF-8 bytes) without splitting
        # the whole text again for every node
        first, last = node.lineno - 1, node.end_lineno - 1
        if first == last:
            return lines[first][node.col_offset : node.end_col_offset].decode("utf-8")
        parts = [lines[first][node.col_offset :], *lines[first + 1 : last], lines[last][: node.end_col_offset]]
        return b"".join(parts).decode("utf-8")

    def formed(node, make, op=None, *args):
        """``make(*args)``: checked by ``bounds`` before (``op``) and after it is formed; a refusal names the node."""
        try:
            if op is not None:
                bounds.before(op, *args)
            return bounds.check(make(*args))
        except Exception as exc:  # noqa: BLE001 (a value sympy cannot form, whatever its error, is refused)
            reason = str(exc) if isinstance(exc, ValueError) else f"cannot be formed ({type(exc).__name__})"
            text = segment(node)
            raise ValueError(f"expression part {text if len(text) <= 40 else text[:37] + '...'!r} {reason}") from None

    def walk(node, depth):
        if depth > MAX_DEPTH:
            raise ValueError(f"expression nests deeper than {MAX_DEPTH}")
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"expression holds a {type(v).__name__} literal; only numbers are allowed")
            if isinstance(v, int):
                if v.bit_length() > _MAX_BITS:
                    raise ValueError(f"expression holds an integer of more than {MAX_DIGITS} digits")
                return formed(node, sp.Integer, None, v)
            if not math.isfinite(v):
                raise ValueError("expression holds a non-finite number")
            literal = segment(node) or repr(v)
            if sum(ch.isdigit() for ch in literal) > MAX_DIGITS:
                raise ValueError(f"expression holds a number literal of more than {MAX_DIGITS} digits")
            return formed(node, sp.Float, None, literal)
        if isinstance(node, ast.Name):
            if node.id in allowed:
                return allowed[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            raise ValueError(f"expression uses unknown name {node.id!r}; allowed: {sorted(allowed)}")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            x = walk(node.operand, depth + 1)
            return formed(node, operator.neg, None, x) if isinstance(node.op, ast.USub) else x
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = walk(node.left, depth + 1), walk(node.right, depth + 1)
            if isinstance(node.op, ast.Pow) and right.is_Number and abs(float(right)) > MAX_EXPONENT:
                raise ValueError(f"expression raises to the power {right}; at most {MAX_EXPONENT} in magnitude")
            return formed(node, _BINARY[type(node.op)], type(node.op), left, right)
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                what = node.func.id if isinstance(node.func, ast.Name) else type(node.func).__name__
                raise ValueError(f"expression calls {what!r}; allowed functions: {', '.join(FUNCTIONS)}")
            f, nargs = FUNCTIONS[node.func.id]
            if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
                raise ValueError(f"expression calls {node.func.id} with keyword or starred arguments")
            if (nargs is not None and len(node.args) != nargs) or not 0 < len(node.args) <= MAX_ARGS:
                raise ValueError(f"expression calls {node.func.id} with {len(node.args)} arguments")
            return formed(node, f, f, *(walk(a, depth + 1) for a in node.args))
        raise ValueError(
            f"expression holds a {type(node).__name__}; only numbers, names, + - * / ** and calls are allowed"
        )

    try:
        return walk(tree.body, 0)
    except RecursionError:
        raise ValueError(f"expression nests deeper than {MAX_DEPTH}") from None


_parse_memo = lru_cache(maxsize=_MEMO)(_parse)
