"""A saved fit as a function: :class:`FitFunction` (a record's expression, evaluated in numpy on its domain),
:func:`load` (a fit file), and the :class:`fitlab.forms.Form` a record defines."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import numpy as np
import sympy as sp

from fitlab.core import get_target
from fitlab.forms import Form
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store._check import checked_fit
from fitlab.store._files import fit_source, read_checked_fit

__all__ = ["FitFunction", "load", "form_from_fit", "resolve_form"]


class FitFunction:
    """A saved fit as a callable on numpy arrays.

    ``f(mu=..., c=...)`` or positionally in the order of ``f.inputs``; inputs
    broadcast.  Inputs outside the fit's domain raise ValueError: a fit says
    nothing outside the domain it was validated on.
    """

    def __init__(self, record: dict, path: Path | None = None, *, checked: tuple[dict, sp.Expr] | None = None):
        # ``checked``: the (record, expression) pair :func:`read_checked_fit` already made (``load``)
        record, expr = checked if checked is not None else checked_fit(record, str(path or "fit"))
        self.record = record
        self.path = path
        self.target = record["target"]
        self.form = record["form"]
        self.inputs = tuple(record["inputs"])
        self.params = dict(record["params"])
        self.domain = {k: tuple(float(x) for x in v) for k, v in record["domain"].items()}
        # xreplace, not subs: the same substitution of symbols by numbers, without subs's matching (10x faster)
        expr = expr.xreplace({sp.Symbol(p, real=True): sp.Float(repr(float(v)), 17) for p, v in self.params.items()})
        self.expression = cast(sp.Expr, expr)  # sympy annotates xreplace as giving a Basic
        self._f = None  # the numpy function, made on the first call: codegen reads only the expression
        #: what :func:`fitlab.fit.verify.verify_fit` measured (error figures, the set and domain measured on), or None
        self.measured: dict | None = None

    def __repr__(self) -> str:
        return f"FitFunction({self.target}/{self.form}, inputs={self.inputs})"

    @property
    def physics(self) -> str:
        """The physics the fit was fitted against: the record's ``physics``, else (a file older than the field) its
        target's (:attr:`fitlab.core.Target.physics`)."""
        stated = self.record.get("physics")
        if stated is not None:
            return str(stated)
        try:
            return get_target(self.target).physics
        except KeyError:  # a fit of a table of one's own: its own values
            return "exact"

    def __call__(self, *args, **kwargs):
        if len(args) > len(self.inputs):
            raise TypeError(f"{self!r} takes {len(self.inputs)} inputs {self.inputs}")
        values = dict(zip(self.inputs, args))
        for k, v in kwargs.items():
            if k in values:
                raise TypeError(f"input {k!r} given twice")
            if k not in self.inputs:
                raise TypeError(f"unknown input {k!r}; this fit takes {self.inputs}")
            values[k] = v
        missing = [n for n in self.inputs if n not in values]
        if missing:
            raise TypeError(f"missing inputs {missing}; this fit takes {self.inputs}")
        arrays = []
        for name in self.inputs:
            a = np.asarray(values[name], dtype=float)
            lo, hi = self.domain[name]
            if np.any(np.isnan(a)) or np.any((a < lo) | (a > hi)):
                raise ValueError(f"{name} must lie in [{lo}, {hi}] (the domain this fit was validated on)")
            arrays.append(a)
        return self.evaluate(*arrays)

    def evaluate(self, *arrays) -> np.ndarray:
        """The fit's expression at ``arrays`` (positional, in the order of :attr:`inputs`), without the domain
        check of a call: how a fit is measured beyond the domain it was made on."""
        arrays = [np.asarray(a, dtype=float) for a in arrays]
        if self._f is None:
            self._f = lambdify_numpy(symbols(self.inputs), self.expression)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self._f(*arrays)
        return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(a.shape for a in arrays))).copy()


def load(path) -> FitFunction:
    """Load a fit file written by ``fitlab refit`` as a :class:`FitFunction` (checked as :func:`read_checked_fit`
    checks it: every refusal one :class:`FitFileError` line).  What the fit claims is measured again by
    :func:`fitlab.fit.verify.verify_fit` (``verify_fit(load(path))``), which sets its ``measured`` figures."""
    checked = read_checked_fit(path)
    return FitFunction(checked[0], Path(path), checked=checked)


def form_from_fit(record: dict):
    """The :class:`fitlab.forms.Form` a fit record defines (its expression, parameters and fixed
    values), starting from the record's parameters: how a form found outside fitlab.forms (by
    ``fitlab discover``) is refitted like any other."""
    return _form(*checked_fit(record, f"{record.get('target')}/{record.get('form')}"))


def _form(record: dict, expr: sp.Expr) -> Form:
    return Form(
        target=record["target"],
        name=record["form"],
        inputs=tuple(record["inputs"]),
        params=tuple(record["params"]),
        expr=expr,
        start={k: float(v) for k, v in record["params"].items()},
        fixed={k: float(v) for k, v in record.get("fixed", {}).items()},
        description=record.get("form_description", ""),
        refit_by_default=False,
    )


def resolve_form(target_name: str, form_name: str | None, fits_dir: Path | None = None) -> Form:
    """A target's form by name: from fitlab.forms, else (a form found by ``fitlab discover``) from
    the saved fit fits_dir/TARGET.FORM.json (None: the packaged fits), which holds the form's expression."""
    target = get_target(target_name)
    form_name = form_name or target.default_form
    if form_name in target.forms:
        return target.forms[form_name]
    path = fit_source(fits_dir, target.name, form_name)
    if path.exists():
        return _form(*read_checked_fit(path))
    raise KeyError(
        f"target {target.name} has no form {form_name!r} (and there is no {path}); forms: {', '.join(target.forms)}"
    )
