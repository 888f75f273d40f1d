"""Parametric forms, each defined once as a sympy expression.

A :class:`Form` is a symbolic expression with named inputs and parameters; the
families define theirs and register them (``fitlab.core.get_form(target, name)``
finds one).  :mod:`fitlab.forms.symbolic` turns an expression into numpy and JAX
functions; :mod:`fitlab.codegen` prints it as C, GLSL and Python.
"""

from fitlab.forms.form import Form
from fitlab.forms.symbolic import parse_expression, safe_pow

__all__ = ["Form", "parse_expression", "safe_pow"]
