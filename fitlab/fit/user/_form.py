"""The form of a fit of one's own table: its text read by the restricted parser, its start values, and the checks
at the start values (finite on every fitted row; a Jacobian of full numerical rank)."""

from __future__ import annotations

import ast
import math
from typing import TYPE_CHECKING, cast

import numpy as np

from fitlab.fit.user._limits import RANK_ROWS, RANK_RTOL, UserDataError
from fitlab.fit.user._names import PARAMETER
from fitlab.fit.user._table import UserTable

if TYPE_CHECKING:  # imported where used: importing fitlab.fit.user stays light
    import sympy as sp

__all__ = ["names_in", "user_form", "initial_values", "check_start", "jacobian"]


def names_in(text: str) -> list[str]:
    """The names an expression text uses as values (not the functions it calls), in order of first use."""
    from fitlab.forms.symbolic import MAX_TEXT

    if not isinstance(text, str) or not text.strip():
        raise UserDataError("the form is empty; write an expression such as (a0 + a1*x)/(1 + a2*x)")
    if len(text) > MAX_TEXT:
        raise UserDataError(f"the form is {len(text)} characters long; at most {MAX_TEXT} are read")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        raise UserDataError(f"cannot read the form {text.strip()[:60]!r}: {type(exc).__name__}") from None
    called = {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and id(node) not in called and node.id not in out:
            out.append(node.id)
    return out


def user_form(text: str, inputs, columns=None):
    """(expression, parameters, inputs used) of the form ``text``: parameters are the names a<digits>, in
    numeric order; every other name must be one of ``inputs`` (or a constant pi, E).  ``columns``: the table's
    other columns, named in the message when the form uses one that is not an input.  Parsed by the restricted
    parser; :class:`UserDataError` on any refusal, on no parameters, and on a parameter that cancels."""
    from fitlab.forms.symbolic import CONSTANTS, parse_expression
    from fitlab.store import fit_limits

    limits = fit_limits()
    names = names_in(text)
    long = next((n for n in names if len(n) > limits.name), None)
    if long is not None:  # a parameter a<400 digits> is refused here, before its number is read
        raise UserDataError(
            f"the form names {long[:20]}... ({len(long)} characters); a fit file holds names of at most "
            f"{limits.name} characters"
        )
    params = sorted((n for n in names if PARAMETER.match(n)), key=lambda n: int(n[1:]))
    if len(params) > limits.params:
        raise UserDataError(f"the form has {len(params)} parameters; a fit file holds at most {limits.params}")
    unknown = [n for n in names if n not in params and n not in inputs and n not in CONSTANTS]
    if unknown:
        where = f" (the inputs are {', '.join(inputs)})" if inputs else ""
        hint = (
            ""
            if columns is None
            else "; it is a column: add it to the inputs"
            if unknown[0] in columns
            else f"; the table's columns are {', '.join(columns)[:200]}"
        )
        raise UserDataError(
            f"the form names {unknown[0]!r}, which is neither an input{where} nor a parameter a0, a1, ...{hint}"
        )
    if not params:
        raise UserDataError("the form has no parameters (a0, a1, ...): nothing to fit")
    try:
        expr = parse_expression(text, (*inputs, *params))
    except ValueError as exc:
        raise UserDataError(f"the form: {exc}") from None
    present = {s.name for s in cast("set[sp.Symbol]", expr.free_symbols)}  # sympy annotates them as Basic
    gone = [p for p in params if p not in present]
    if gone:
        raise UserDataError(f"{gone[0]} cancels out of the form as written ({text.strip()[:60]}); remove it")
    return expr, tuple(params), tuple(n for n in inputs if n in present)


def initial_values(params, start) -> dict:
    """The start values: ``start``'s, else a<k> = 1/(k + 1) (distinct values, so that terms of one shape, as a
    rational's numerator and denominator have, do not start equal and leave the fit undetermined)."""
    values = {p: 1.0 / (int(p[1:]) + 1) for p in params}
    for name, value in (start or {}).items():
        if name not in values:
            raise UserDataError(
                f"start: {name!r} is not a parameter of the form; its parameters are {', '.join(params)}"
            )
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise UserDataError(f"start: {name}={value!r} is not a number") from None
        if not math.isfinite(v):
            raise UserDataError(f"start: {name}={v!r} is not finite")
        values[name] = v
    return values


def check_start(form, start: dict, train, scale, table: UserTable, rows: np.ndarray) -> None:
    """The form at the start values: finite on every fitted row, and its Jacobian of full numerical rank."""
    theta = form.vector(start)
    xs = [train.inputs[n] for n in form.inputs]
    value = form.numpy_fit_function(theta, *xs)
    bad = ~np.isfinite(value)
    if np.any(bad):
        i = int(np.argmax(bad))
        point = ", ".join(f"{n}={x[i]:.6g}" for n, x in zip(form.inputs, xs))
        raise UserDataError(
            f"{table.name} {table.where(int(rows[i]))}: the form is not finite at {point} with the "
            f"start values ({_start_text(start)}); give other start values"
        )
    jac, used = jacobian(form, theta, xs, scale)
    if not np.all(np.isfinite(jac)):
        i, k = (int(v) for v in np.argwhere(~np.isfinite(jac))[0])
        i = int(used[i])
        point = ", ".join(f"{n}={x[i]:.6g}" for n, x in zip(form.inputs, xs))
        raise UserDataError(
            f"{table.name} {table.where(int(rows[i]))}: the form's derivative in {form.params[k]} is "
            f"not finite at {point} with the start values ({_start_text(start)}); the fit cannot "
            "start there: give other start values"
        )
    norms = np.sqrt(np.sum(jac**2, axis=0))
    dead = [p for p, nrm in zip(form.params, norms) if not nrm > 0.0]
    if dead:
        raise UserDataError(
            f"{dead[0]} has no effect on the fitted rows at the start values ({_start_text(start)}): "
            "the data cannot determine it; change the form or the start values"
        )
    _, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
    if rank < len(form.params):
        direction = vt[-1] / norms  # in the parameters themselves, the largest component 1
        direction = direction / direction[np.argmax(np.abs(direction))]
        terms = [(c, p) for c, p in zip(direction, form.params) if abs(c) > 0.05]
        combo = (
            " ".join(
                f"{'-' if c < 0 else '+'} {'' if abs(abs(c) - 1) < 5e-3 else f'{abs(c):.2g} '}{p}" for c, p in terms
            )
            .removeprefix("+ ")
            .replace("- ", "-", 1 if terms[0][0] < 0 else 0)
        )
        raise UserDataError(
            f"the data cannot determine the form's {len(form.params)} parameters: at the start values "
            f"its Jacobian on the fitted rows has rank {rank} (moving the parameters along {combo} "
            "leaves the fit unchanged), as in a0*a1*x; change the form, or the start values if terms "
            "were started equal"
        )


def _start_text(start: dict) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in start.items())


def jacobian(form, theta, xs, scale) -> tuple[np.ndarray, np.ndarray]:
    """(J, rows): J_ik = d r_i / d theta_k of r = f(theta; x)/scale at ``theta`` (JAX, float64), on ``rows``, at
    most :data:`RANK_ROWS` evenly spaced rows."""
    from fitlab.core import float64

    n = len(scale)
    rows = np.unique(np.linspace(0, n - 1, min(n, RANK_ROWS)).astype(int))

    @float64
    def jac():
        import jax
        import jax.numpy as jnp

        data = tuple(jnp.asarray(x[rows]) for x in xs)
        inv = jnp.asarray(1.0 / scale[rows])
        f = form.jax_function
        return np.asarray(jax.jacfwd(lambda t: f(t, *data) * inv)(jnp.asarray(theta, dtype=jnp.float64)))

    return jac(), rows
