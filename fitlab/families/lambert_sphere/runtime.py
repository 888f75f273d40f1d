r"""The runtime Lambert-sphere BRDF (docs/model.md, "The runtime BRDF"),
assembled from forms with numbers.

``runtime_model(variant)`` builds f_r(mu_i, mu_o, phi, c) =
max(0, f_1 + fm0 + fm1 cos phi) (see :func:`fitlab.forms.runtime_brdf`) from

* a published preset set: ``"paper_printed"`` (every coefficient and both
  normalisations as printed, the separable H1 read as printed),
  ``"paper"`` (printed coefficients, the renderer reading of H1, the exact
  3 pi / 192 pi normalisations), ``"renderer"`` (the author's renderer
  coefficients where they differ, exact normalisations); or
* saved fits: ``runtime_model(fits_dir=Path("fits"))`` takes fits/H0.json,
  H1.json, l.json, m.json, B.json ... F.json (the default forms), or with
  ``forms={"H0": "hapke_rational", ...}`` the files of other forms.

The result is a :class:`RuntimeModel`: the sympy expression (what codegen
consumes) and a numpy callable.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab.core import get_form, get_target
from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS, runtime_brdf
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import fit_path, load

__all__ = ["RuntimeModel", "runtime_model", "PRESET_VARIANTS"]

PRESET_VARIANTS = {
    "paper_printed": ({"H0": ("hapke", "paper"), "H1": ("separable_printed", "paper"), "l": ("quadratic", "paper"),
                       "m": ("linear", "paper"), **{n: ("printed", "paper") for n in "BCDF"}}, "printed"),
    "paper": ({"H0": ("hapke", "paper"), "H1": ("separable", "paper"), "l": ("quadratic", "paper"),
               "m": ("linear", "paper"), **{n: ("printed", "paper") for n in "BCDF"}}, "corrected"),
    "renderer": ({"H0": ("hapke", "paper"), "H1": ("separable", "renderer"), "l": ("quadratic", "renderer"),
                  "m": ("linear", "renderer"), **{n: ("printed", "paper") for n in "BCDF"}}, "corrected"),
}  # fmt: skip

INPUTS = ("mu_i", "mu_o", "phi", "c")


@dataclass(frozen=True, eq=False)
class RuntimeModel:
    name: str
    expr: sp.Expr
    sources: dict  # part -> "form / preset" or fit file

    def __post_init__(self):
        object.__setattr__(self, "_f", lambdify_numpy(symbols(INPUTS), self.expr))

    def __call__(self, mu_i, mu_o, phi, c):
        arrays = [np.asarray(x, dtype=float) for x in (mu_i, mu_o, phi, c)]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self._f(*arrays)
        return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(a.shape for a in arrays))).copy()


def runtime_model(
    variant: str | None = None, *, fits_dir: Path | None = None, forms: dict | None = None, normalisation: str = "corrected"
) -> RuntimeModel:

    if (variant is None) == (fits_dir is None):
        raise ValueError("give a preset variant or fits_dir")
    parts, sources = {}, {}
    if variant is not None:
        if variant not in PRESET_VARIANTS:
            raise ValueError(f"unknown runtime variant {variant!r}; choose one of {', '.join(PRESET_VARIANTS)}")
        choice, normalisation = PRESET_VARIANTS[variant]
        for part in RUNTIME_PARTS:
            form_name, preset = choice[part]
            parts[part] = get_form(part, form_name).substituted(preset)
            sources[part] = f"{form_name} / {preset}"
        name = variant
    else:

        for part in RUNTIME_PARTS:
            form_name = (forms or {}).get(part, get_target(part).default_form)
            path = fit_path(Path(fits_dir), part, form_name)
            fit = load(path)
            parts[part] = fit.expression
            sources[part] = path.name  # the file, wherever its folder is (audit.json stays the same)
        name = "refit" if not forms else "refit (" + ", ".join(f"{k}: {v}" for k, v in forms.items()) + ")"
    return RuntimeModel(name, runtime_brdf(parts, normalisation), sources)
