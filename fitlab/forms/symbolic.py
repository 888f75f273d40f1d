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


def lambdify_numpy(args, expr):
    """A numpy function of ``args`` (symbols) computing ``expr``."""
    return sp.lambdify(args, expr, modules=[{"safe_pow": _np_safe_pow}, "numpy"], cse=True)


def lambdify_jax(args, expr):
    """A jax.numpy function of ``args`` computing ``expr`` (jit- and grad-able)."""
    return sp.lambdify(args, expr, modules=[{"safe_pow": _jax_safe_pow}, "jax"], cse=True)


def expression_text(expr) -> str:
    """The text stored in fits JSON; :func:`parse_expression` reads it back."""
    return sp.sstr(expr, full_prec=True)


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

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}  # fmt: skip


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
    """
    if not isinstance(text, str):
        raise ValueError(f"expression must be a string, not {type(text).__name__}")
    if len(text) > MAX_TEXT:
        raise ValueError(f"expression is {len(text)} characters long; at most {MAX_TEXT} are read")
    allowed = {n: sp.Symbol(n, real=True) for n in names}
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise ValueError(f"cannot parse expression: {type(exc).__name__}") from None
    source = text.strip()

    def walk(node, depth):
        if depth > MAX_DEPTH:
            raise ValueError(f"expression nests deeper than {MAX_DEPTH}")
        if isinstance(node, ast.Constant):
            v = node.value
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"expression holds a {type(v).__name__} literal; only numbers are allowed")
            if isinstance(v, int):
                return sp.Integer(v)
            if not math.isfinite(v):
                raise ValueError("expression holds a non-finite number")
            return sp.Float(ast.get_source_segment(source, node) or repr(v))
        if isinstance(node, ast.Name):
            if node.id in allowed:
                return allowed[node.id]
            if node.id in CONSTANTS:
                return CONSTANTS[node.id]
            raise ValueError(f"expression uses unknown name {node.id!r}; allowed: {sorted(allowed)}")
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            x = walk(node.operand, depth + 1)
            return -x if isinstance(node.op, ast.USub) else x
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            left, right = walk(node.left, depth + 1), walk(node.right, depth + 1)
            if isinstance(node.op, ast.Pow) and right.is_Number and abs(float(right)) > MAX_EXPONENT:
                raise ValueError(f"expression raises to the power {right}; at most {MAX_EXPONENT} in magnitude")
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                what = node.func.id if isinstance(node.func, ast.Name) else type(node.func).__name__
                raise ValueError(f"expression calls {what!r}; allowed functions: {', '.join(FUNCTIONS)}")
            f, nargs = FUNCTIONS[node.func.id]
            if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
                raise ValueError(f"expression calls {node.func.id} with keyword or starred arguments")
            if (nargs is not None and len(node.args) != nargs) or not 0 < len(node.args) <= MAX_ARGS:
                raise ValueError(f"expression calls {node.func.id} with {len(node.args)} arguments")
            return f(*(walk(a, depth + 1) for a in node.args))
        raise ValueError(f"expression holds a {type(node).__name__}; only numbers, names, + - * / ** and calls are allowed")

    try:
        return walk(tree.body, 0)
    except RecursionError:
        raise ValueError(f"expression nests deeper than {MAX_DEPTH}") from None
