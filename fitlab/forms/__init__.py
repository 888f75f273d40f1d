"""Parametric forms, each defined once as a sympy expression.

``get_form(target, name)`` returns a :class:`Form`; ``forms_for(target)``
lists a target's forms.  Every published approximation of SPEC 6 is here with
its coefficients as a named preset ("paper", and "renderer" where the author's
renderer plugin differs); richer forms of the same families sit beside them.
"""

from __future__ import annotations

from . import albedo_maps, brdf, constants, h_functions
from .brdf import RUNTIME_PARTS, RUNTIME_TERMS, runtime_brdf, runtime_terms
from .form import Form
from .symbolic import parse_expression, safe_pow

__all__ = ["Form", "FORMS", "get_form", "forms_for", "runtime_brdf", "runtime_terms", "RUNTIME_PARTS", "RUNTIME_TERMS", "parse_expression", "safe_pow"]

FORMS: dict[str, dict[str, Form]] = {}
for _f in (*h_functions.FORMS, *constants.FORMS, *albedo_maps.FORMS, *brdf.FORMS):
    FORMS.setdefault(_f.target, {})[_f.name] = _f


def forms_for(target: str) -> dict[str, Form]:
    if target not in FORMS:
        raise KeyError(f"unknown target {target!r}; targets: {', '.join(FORMS)}")
    return FORMS[target]


def get_form(target: str, name: str) -> Form:
    forms = forms_for(target)
    if name not in forms:
        raise KeyError(f"target {target} has no form {name!r}; forms: {', '.join(forms)}")
    return forms[name]
