r"""The lobe-parameter targets: the per-lobe fits (:mod:`..lobes.params`) as functions of alpha, mu_i and the order.

For each facet kind (``diffuse``, ``conductor``):

==============================  =====================  ====================================================
target (= generated routine)    inputs                 value (per-lobe fit of :mod:`..lobes.params`)
==============================  =====================  ====================================================
ms_blog_eta_KIND                alpha, mu_i            exponent eta of the blog's final lobe, order 2
ms_blog_flattening_KIND         alpha, mu_i            its normal flattening sigma_n, order 2
ms_blog_scale_KIND              alpha, mu_i, order     its scale, order 2..5, with the order-2 shape
ms_tilt_sigma_KIND              alpha, mu_i, order     scale of the tilted lobe (:func:`..lobes.shapes.tilted_lobe`)
ms_tilt_eta_KIND                alpha, mu_i, order     its exponent eta
ms_tilt_flattening_KIND         alpha, mu_i, order     its normal flattening sigma_n
ms_tilt_b_KIND, ms_tilt_k_KIND  alpha, mu_i, order     its azimuthal tilt b and narrowing k
==============================  =====================  ====================================================

Details: docs/blog_lobe_model.md, section ``fitlab.families.microfacet_energy.targets.lobes``."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from fitlab.core import Dataset, Input, Target
from fitlab.families.microfacet_energy.lobes.params import params_file, read_params
from fitlab.families.microfacet_energy.lobes.tables import DOMAIN, KINDS
from fitlab.families.microfacet_energy.targets.lobe_parts import (
    BLOG_PARTS,
    ENERGY_SCALE,
    TILT_PARTS,
    target_name,
)

__all__ = ["LOBE_TARGETS", "MIN_ALBEDO", "TOLERANCE", "energy_scales"]

#: lobes below this albedo are left out of the sets (docs/blog_lobe_model.md)
MIN_ALBEDO = 1e-3
#: the columns whose sets hold every lobe with any energy (the others': albedo >= MIN_ALBEDO): the tilted
#: lobe's scale (the blog's scale is fitted the blog's way, on the lobes that matter, orders 2 and 3 for it)
SCALE_COLUMNS = (ENERGY_SCALE,)
#: the parameters' standard errors are measured against this fraction of the error measure's scale
TOLERANCE = 0.05

ALPHA = Input("alpha", DOMAIN["alpha"], "GGX roughness alpha of the microsurface")
MU_I = Input("mu_i", DOMAIN["mu_i"], "cosine of the incident direction with the normal")
ORDER = Input("order", (2.0, 5.0), "scattering order: 2, 3, 4, and 5 for every order above 4")

_DEFAULT_FORM = {
    "eta": "poly",
    "flattening": "exp_poly",
    "scale": "exp_poly",
    "sigma": "exp_poly",
    "b": "sine_poly",
    "k": "sine2_poly",
}


def _tables_dir() -> Path:
    from fitlab.families.microfacet_energy.targets.datasets import tables_dir

    return tables_dir()


@cache
def _dataset(kind: str, which: str, column: str, with_order: bool, folder: Path) -> Dataset:
    p = read_params(folder, kind, which)
    if column == ENERGY_SCALE:
        p = dict(p)
        p[ENERGY_SCALE], p["se_" + ENERGY_SCALE] = energy_scales(kind, which, folder)
    # a scale is measured on every lobe (a lobe with no energy must get none); a shape where it carries energy
    keep = p["albedo"] > 0 if column in SCALE_COLUMNS else p["albedo"] >= MIN_ALBEDO
    if not with_order:
        keep &= p["order"] == 2
    inputs = {"alpha": p["alpha"][keep], "mu_i": p["mu_i"][keep]}
    if with_order:
        inputs["order"] = p["order"][keep]
    grid = f"table {params_file(kind, which)}: the per-lobe fits, {'orders 2..5' if with_order else 'order 2'}, " + (
        "lobes of albedo > 0" if column in SCALE_COLUMNS else f"lobes of albedo >= {MIN_ALBEDO:g}"
    )
    if column == ENERGY_SCALE:
        grid += "; the scale that gives the shape of the packaged tilt fits the albedo of the lobe table"
    return Dataset(inputs, p[column][keep].copy(), grid, {"se": p["se_" + column][keep].copy()})


def energy_scales(kind: str, which: str, folder: Path, fits_dir: Path | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The tilted lobe's energy-matching scale of every row of the parameter table (orders 2..5 of every job):
    A_S / I_S, A_S the simulated albedo of the lobe (lobes.tables), I_S the albedo of the tilted lobe of scale 1
    whose exponent, flattening and tilt are the fitted functions of the packaged fits (``fits_dir``), integrated
    over the bins (lobes.fitting's quadrature); its standard error sigma se(A_S)/A_S.  Why: the per-lobe scale
    trades against the lobe's other parameters, which the fitted functions smooth, so that per-lobe scales with
    fitted shapes miss the energy by 40 % (RMS, conductors; 22 % diffuse facets, validation lobes); this scale
    keeps it by construction, and only its own fit's error is left."""
    import sympy as sp

    from fitlab.families.microfacet_energy.lobes.fitting import bin_averages_numpy
    from fitlab.families.microfacet_energy.lobes.shapes import SHAPE_INPUTS
    from fitlab.families.microfacet_energy.lobes.tables import read_lobes, solid_angles
    from fitlab.families.microfacet_energy.program.runtime import order_lobes, parameter_expressions
    from fitlab.forms.symbolic import lambdify_numpy, symbols

    parts = dict(parameter_expressions("tilted", kind, fits_dir))
    parts[target_name("tilt", "sigma", kind)] = sp.Integer(1)
    unit = {s: lambdify_numpy(symbols(SHAPE_INPUTS), e) for s, e in order_lobes("tilted", kind, parts).items()}
    t = read_lobes(folder, kind, which)
    p = read_params(folder, kind, which)
    omega = solid_angles()
    scale, se = np.zeros(p["alpha"].size), np.zeros(p["alpha"].size)
    for row, (a, m, s) in enumerate(zip(p["alpha"], p["mu_i"], p["order"].astype(int))):
        j = int(np.where((t.alpha == a) & (t.mu_i == m))[0][0])
        albedo = float((bin_averages_numpy(unit[s], m, a) * omega).sum())
        scale[row] = t.albedo[j, s - 1] / albedo
        se[row] = scale[row] * t.albedo_se[j, s - 1] / t.albedo[j, s - 1] if t.albedo[j, s - 1] > 0 else 0.0
    return scale, se


def _sets(kind: str, column: str, with_order: bool):
    return (
        lambda: _dataset(kind, "training", column, with_order, _tables_dir()),
        lambda: _dataset(kind, "validation", column, with_order, _tables_dir()),
    )


def _scale(measure: str):
    if measure == "relative":
        return lambda ds: np.abs(ds.y)
    return lambda ds: np.ones_like(ds.y)


def _emphasis(measure: str):
    scale = _scale(measure)
    return lambda ds: 1.0 / np.maximum(1.0, ds.aux["se"] / (TOLERANCE * scale(ds)))


_PUBLISHED = {
    "eta": (("blog_quadratic", "blog_text"), ("blog_quadratic", "blog_code"), ("blog_exp2", "blog_text")),
    "flattening": (("blog_cubic", "blog_text"), ("blog_cubic", "blog_code")),
    "scale": (("blog_cubic", "blog_text"), ("blog_cubic", "blog_code")),
}


def _targets(kind: str) -> list[Target]:
    out = []
    what_kind = "diffuse facets of albedo 1" if kind == "diffuse" else "conductor facets with F = 1"
    for model, parts, lobe in (("blog", BLOG_PARTS, "the blog's final lobe"), ("tilt", TILT_PARTS, "the tilted lobe")):
        for param, column, measure, what, with_order in parts:
            name = target_name(model, param, kind)
            variables = (ALPHA, MU_I, ORDER) if with_order else (ALPHA, MU_I)
            training, validation = _sets(kind, column, with_order)
            published = _PUBLISHED.get(param, ()) if model == "blog" and kind == "diffuse" else ()
            out.append(Target(
                name, f"{what} of {lobe} fitted to the simulated multiple-scattering lobes of {what_kind} on GGX "
                      f"(lobes.params){'' if with_order else ', order 2'}; alpha, mu_i in [0.05, 1]"
                      + (", order 2..5" if with_order else ""),
                variables, _DEFAULT_FORM[param], published,
                training, validation, None, name,
                claimed=("none stated (the blog: 'I'm not sure my results are accurate or useable anymore')"
                         if published else "none: the blog fitted diffuse facets only"),
                error_measure=(f"{measure}: |approx - exact|" + (" / |exact|" if measure == "relative" else "")
                               + " (targets.lobes says why)"),
                scale=_scale(measure), minimax=False, emphasis=_emphasis(measure),
                emphasis_text=f"each lobe weighted by 1/max(1, se/({TOLERANCE:g} scale)) (its Monte Carlo uncertainty)",
                note=("Exact values are per-lobe fits of Monte Carlo lobes, with standard errors: the refit weighs them "
                      "by their uncertainty and minimises the RMS; the lobe's own error is in docs/microsurface_lobes.md."),
            ))  # fmt: skip
    return out


#: every lobe-parameter target, by name
LOBE_TARGETS = {t.name: t for kind in KINDS for t in _targets(kind)}
