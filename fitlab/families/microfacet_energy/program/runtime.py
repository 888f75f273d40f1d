r"""The runtime multiple-scattering lobes: each model's lobe of every order as one sympy expression, built
from the lobe-parameter targets' forms (presets or fits), and evaluated in numpy.

A model's multiple-scattering BRDF for light from mu_i (facet albedo rho for diffuse facets, F = 1 for
conductors) is

    f_ms(mu_i, mu_o, cos_phi; alpha[, rho]) = sum_{S = 2..5} w_S f_S,   w_S = rho^S (diffuse; rho^5 for the
    tail above 4, an upper bound of its weight sum_{S > 4} rho^S a_S / sum a_S), w_S = 1 (conductors),

f_S the model's lobe of order S (5: the tail) with its parameters' functions of (alpha, mu_i, S):

* ``blog_text``, ``blog_code``: the blog's final lobe with its published expressions (presets of
  :mod:`..forms.lobes`; diffuse facets only): orders 2 and 3 with the order-2 shape, sigma_3 = 0.3639 sigma_2;
* ``blog_refit``: the same lobe and the same forms, refitted (``fitlab refit``, the forms
  ``blog_quadratic``, ``blog_cubic``);
* ``blog_rich``: the same lobe with the targets' default (richer) forms;
* ``tilted``: the tilted lobe (:func:`..lobes.shapes.tilted_lobe`), every parameter per order (the tilt targets'
  default forms).

Reference models, not built from lobe targets: ``none`` (single scattering only: f_ms = 0) and
``kulla_conti`` (conductors: (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)) of height-correlated GGX, the
walk's order 1; exact E from the engine for accuracy, the fitted E_ggx_cor and E_avg_ggx_cor in the
generated code, :mod:`.spec`).
"""

from __future__ import annotations

from pathlib import Path

import sympy as sp

from fitlab.core import get_target
from fitlab.families.microfacet_energy.lobes.fitting import BOUNDS
from fitlab.families.microfacet_energy.lobes.shapes import SHAPE_INPUTS, blog_lobe, tilted_lobe
from fitlab.families.microfacet_energy.targets.lobe_parts import lobe_target_names
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import fit_path, fits_folder, load

__all__ = [
    "MODELS",
    "ORDERS",
    "model_forms",
    "parameter_expressions",
    "order_lobes",
    "lobe_functions",
    "multiple_scattering",
    "rho",
    "parameter_bounds",
]

ORDERS = (2, 3, 4, 5)
rho, order = symbols(("rho", "order"))

#: model -> (the lobe ("blog" or "tilt"), {parameter: form}, preset or None, description)
MODELS = {
    "blog_text": (
        "blog",
        {"eta": "blog_quadratic", "flattening": "blog_cubic", "scale": "blog_cubic"},
        "blog_text",
        "the blog's lobe, text coefficients",
    ),
    "blog_code": (
        "blog",
        {"eta": "blog_quadratic", "flattening": "blog_cubic", "scale": "blog_cubic"},
        "blog_code",
        "the blog's lobe, code coefficients (normalisation 2/pi)",
    ),
    "blog_refit": (
        "blog",
        {"eta": "blog_quadratic", "flattening": "blog_cubic", "scale": "blog_cubic"},
        None,
        "the blog's lobe and forms, refitted",
    ),
    "blog_rich": ("blog", {}, None, "the blog's lobe, parameters in the targets' richer default forms"),
    "tilted": ("tilt", {}, None, "the tilted lobe, every parameter per order"),
}


def model_forms(model: str, kind: str) -> dict[str, str]:
    """{target: form} of a model's parameters for ``kind``."""
    lobe, forms, _, _ = MODELS[model]
    out = {}
    for name in lobe_target_names(lobe, kind):
        param = name.removeprefix(f"ms_{lobe}_").removesuffix(f"_{kind}")
        out[name] = forms.get(param, get_target(name).default_form)
    return out


def parameter_expressions(model: str, kind: str, fits_dir: Path | None = None) -> dict[str, sp.Expr]:
    """{target: expression in alpha, mu_i (and order)} of a model's parameters: its preset, or its fits in
    ``fits_dir`` (None: the packaged fits)."""
    _, _, preset, _ = MODELS[model]
    out = {}
    for target, form_name in model_forms(model, kind).items():
        if preset is not None:
            form = get_target(target).forms[form_name]
            if preset not in form.presets:
                raise KeyError(f"{target}/{form_name} has no preset {preset!r} (the blog fitted diffuse facets only)")
            out[target] = form.substituted(preset)
        else:
            out[target] = load(fit_path(fits_folder(fits_dir), target, form_name)).expression
    return out


def parameter_bounds() -> dict[str, tuple]:
    """The interval each runtime parameter is clamped into: the per-lobe fits' own (:data:`..lobes.fitting.BOUNDS`;
    eta from alpha_l's), and scales >= 0.  Inside them every parameter function is what it was fitted as; a
    function extrapolated to a lobe that carries no energy (below 1e-3 of it, outside the shape targets' sets)
    cannot blow the lobe up, and a published polynomial cannot make it negative."""
    lo, hi = BOUNDS["alpha_l"]
    eta = (2.0 ** (10.0 * (1.0 - hi)) - 1.0, 2.0 ** (10.0 * (1.0 - lo)) - 1.0)
    return {
        "eta": eta,
        "flattening": BOUNDS["sigma_n"],
        "b": BOUNDS["b"],
        "k": BOUNDS["k"],
        "scale": (0.0, None),
        "sigma": (0.0, None),
    }


def _clamped(value, bounds):
    lo, hi = bounds
    value = sp.Max(value, sp.Float(repr(float(lo)))) if lo is not None else value
    return sp.Min(value, sp.Float(repr(float(hi)))) if hi is not None else value


def order_lobes(model: str, kind: str, parts: dict) -> dict[int, sp.Expr]:
    """{order: f_S} of a model for ``kind`` from ``parts`` ({target: expression, or any sympy expression in
    alpha, mu_i and order, e.g. a call of the target's generated routine}), in the shape inputs
    (mu_o, cos_phi, mu_i, alpha); every parameter clamped into :func:`parameter_bounds`."""
    lobe = MODELS[model][0]
    bounds = parameter_bounds()
    out = {}
    for s in ORDERS:
        p = {name.removeprefix(f"ms_{lobe}_").removesuffix(f"_{kind}"): sp.sympify(e, strict=True).subs(order, s)
             for name, e in parts.items()}  # fmt: skip
        p = {k: _clamped(v, bounds[k]) for k, v in p.items()}
        if lobe == "blog":
            out[s] = blog_lobe(p["scale"], p["eta"], p["flattening"])
        else:
            out[s] = tilted_lobe(p["sigma"], p["eta"], p["flattening"], p["b"], p["k"])
    return out


def multiple_scattering(kind: str, lobes: dict) -> sp.Expr:
    """sum_S w_S f_S (module docstring): the diffuse facets' weights rho^S, the conductors' 1."""
    return sp.Add(*((rho**s if kind == "diffuse" else 1) * f for s, f in lobes.items()))


def lobe_functions(model: str, kind: str, fits_dir: Path | None = None) -> dict[int, object]:
    """{order: f_S(mu_o, cos_phi, mu_i, alpha)} in numpy (broadcasting), from :func:`parameter_expressions`.
    Parameters are evaluated where the forms are defined: alpha and mu_i clamped into [0.05, 1]."""
    lobes = order_lobes(model, kind, parameter_expressions(model, kind, fits_dir))
    xs = symbols(SHAPE_INPUTS)
    return {s: lambdify_numpy(xs, e) for s, e in lobes.items()}
