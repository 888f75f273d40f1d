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

import numpy as np
import sympy as sp

__all__ = [
    "safe_pow",
    "symbols",
    "lambdify_numpy",
    "lambdify_jax",
    "parse_expression",
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


def parse_expression(text: str, names) -> sp.Expr:
    """Parse an expression written by :func:`expression_text`.

    ``names`` are the input and parameter names it may use; any other free
    name is an error (a typo in a hand-edited JSON should not become a
    silently-unbound symbol).  Note that sympy parsing evaluates Python, so only
    parse files you trust (your own fits/).
    """
    local = {n: sp.Symbol(n, real=True) for n in names}
    local["safe_pow"] = safe_pow
    try:
        expr = sp.sympify(text, locals=local)
    except (sp.SympifyError, SyntaxError, TypeError) as exc:
        raise ValueError(f"cannot parse expression {text!r}: {exc}") from None
    extra = sorted(str(s) for s in expr.free_symbols if str(s) not in local)
    if extra:
        raise ValueError(f"expression uses unknown names {extra}; allowed: {sorted(names)}")
    return expr
