r"""The targets of the microfacet_energy family: what each approximates, on which data, measured how.

Three quantities of Kulla-Conti energy compensation (f_ms = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)),
F = 1) for each of three single-scattering BRDFs:

============================  ==================  ==========================================================
target (= generated routine)  inputs              value
============================  ==================  ==========================================================
E_ggx_sep                     mu, alpha in [0,1]  directional albedo E, GGX, separable Smith G1(mu_i) G1(mu_o)
one_minus_E_ggx_sep           mu, alpha in [0,1]  1 - E, the same model (the energy f_ms restores)
E_avg_ggx_sep                 alpha in [0, 1]     E_avg = 2 int_0^1 E(mu) mu dmu (Kulla-Conti's normalisation)
E_ggx_cor, ...                (the same)          GGX, height-correlated Smith 1/(1 + Lambda_i + Lambda_o)
E_on, ...                     (the same)          Oren-Nayar, A with 0.33, sigma = (pi/2) alpha (the blog's)
============================  ==================  ==========================================================

alpha is GGX's own parameter (the one in D; a renderer's perceptual roughness r has alpha = r^2), and for
Oren-Nayar the blog's alpha with sigma = (pi/2) alpha radians.  alpha = 0 is the mirror (GGX, E = 1)
and Lambert (Oren-Nayar, E = 1).

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.targets``."""

from __future__ import annotations

import numpy as np

from fitlab.core import Dataset, Input, Target
from fitlab.families.microfacet_energy.targets import datasets as d
from fitlab.families.microfacet_energy.targets.lobes import LOBE_TARGETS

__all__ = ["INPUTS", "TARGETS", "MODEL_SUFFIX", "ONE_MINUS_E_FLOOR", "ON_NEGATIVE", "target_name"]

#: the models that have targets, by the suffix of their targets' names
MODEL_SUFFIX = {"ggx_separable": "ggx_sep", "ggx_correlated": "ggx_cor", "oren_nayar": "on"}

#: the floor of the scale of the 1 - E targets: below it only the absolute error counts (docs/microfacet_energy_derivation.md)
ONE_MINUS_E_FLOOR = 1e-3

#: where Oren-Nayar's 1 - E goes below 0, as its target's description states it: E > 1 (the model gains energy)
#: for alpha < 0.2076 near grazing (mu up to 0.49 as alpha -> 0); the minimum on [0, 1]^2 is at mu = 0, where
#: 1 - E = 1 - A - B/2, for alpha = 0.1264 (the exact engine; tests/test_microfacet_energy_targets.py
#: recomputes every figure)
ON_NEGATIVE = (
    "below 0 where E > 1 (the model gains energy: alpha < 0.2076, mu below 0.49), down to -0.01518 at "
    "mu = 0, alpha = 0.1264"
)

MU = Input("mu", (0.0, 1.0), "cosine of the direction (outgoing, or by reciprocity incident) with the normal")
ALPHA_GGX = Input("alpha", (0.0, 1.0), "GGX roughness alpha, the parameter of D (perceptual roughness squared); "
                                       "0 is the mirror")  # fmt: skip
ALPHA_ON = Input("alpha", (0.0, 1.0), "Oren-Nayar roughness as the blog writes it: sigma = (pi/2) alpha radians; "
                                      "0 is Lambert")  # fmt: skip

#: the inputs of each model's targets
INPUTS = {"ggx_separable": ALPHA_GGX, "ggx_correlated": ALPHA_GGX, "oren_nayar": ALPHA_ON}

_DESCRIPTION = {
    "ggx_separable": "GGX, separable Smith G1(mu_i) G1(mu_o)",
    "ggx_correlated": "GGX, height-correlated Smith 1/(1 + Lambda_i + Lambda_o)",
    "oren_nayar": "Oren-Nayar (A with 0.33, sigma = (pi/2) alpha)",
}


def target_name(quantity: str, model: str) -> str:
    """The target of ``quantity`` ("E", "one_minus_E", "E_avg") for ``model`` (a key of :data:`MODEL_SUFFIX`)."""
    return f"{quantity}_{MODEL_SUFFIX[model]}"


def _absolute(ds: Dataset) -> np.ndarray:
    return np.ones_like(ds.y)


def _one_minus_e_scale(ds: Dataset) -> np.ndarray:
    return np.maximum(np.abs(ds.y), ONE_MINUS_E_FLOOR)


def _complement(ds: Dataset) -> Dataset:
    return Dataset(dict(ds.inputs), 1.0 - ds.y, ds.grid + "; values 1 - E")


def _complement_grid(grid):
    def one_minus(axes):
        inputs, y, aux = grid(axes)
        return inputs, 1.0 - np.asarray(y), aux

    return one_minus


_ABSOLUTE = dict(
    error_measure="absolute: |approx - exact| (a fraction of the energy; targets.py says why)",
    scale=_absolute,
)
_RELATIVE_FLOORED = dict(
    error_measure=(
        f"relative to max(|1 - E|, {ONE_MINUS_E_FLOOR:g}): |approx - exact| / max(|exact|, "
        f"{ONE_MINUS_E_FLOOR:g}) (the relative error of the compensation lobe's factor where it "
        "holds at least 0.1 % of the energy; targets.py says why)"
    ),
    scale=_one_minus_e_scale,
)


def _albedo_targets(model: str, defaults: dict) -> tuple[Target, ...]:
    """E, 1 - E and E_avg of ``model`` (``defaults``: quantity -> default form)."""
    alpha = INPUTS[model]
    what = _DESCRIPTION[model]
    e_name, om_name, avg_name = (target_name(q, model) for q in ("E", "one_minus_E", "E_avg"))
    grazing = ("" if model == "oren_nayar" else
               " For small alpha, E changes on the scale mu ~ alpha next to grazing (datasets.py): the sets "
               "hold lines at alpha down to 1e-6 there.")  # fmt: skip
    return (
        Target(
            e_name,
            f"E(mu, alpha): directional albedo (F = 1), {what}; mu, alpha in [0, 1]",
            (MU, alpha),
            defaults["E"],
            PUBLISHED[e_name],
            lambda: d.albedo_training(model),
            lambda: d.albedo_validation(model),
            d.albedo_grid(model),
            e_name,
            note=grazing.strip(),
            **_ABSOLUTE,
        ),
        Target(
            om_name,
            f"1 - E(mu, alpha): the energy Kulla-Conti's f_ms restores, {what}; mu, alpha in [0, 1]"
            + (f"; {ON_NEGATIVE}" if model == "oren_nayar" else ""),
            (MU, alpha),
            defaults["one_minus_E"],
            PUBLISHED[om_name],
            lambda: _complement(d.albedo_training(model)),
            lambda: _complement(d.albedo_validation(model)),
            _complement_grid(d.albedo_grid(model)),
            om_name,
            note=(
                "The published approximations are of E; here they are 1 - (that E), measured relative to "
                "1 - E." + grazing
            ),
            **_RELATIVE_FLOORED,
        ),
        Target(
            avg_name,
            f"E_avg(alpha) = 2 int_0^1 E(mu) mu dmu (Kulla-Conti), {what}; alpha in [0, 1]",
            (alpha,),
            defaults["E_avg"],
            PUBLISHED[avg_name],
            lambda: d.average_training(model),
            lambda: d.average_validation(model),
            d.average_grid(model),
            avg_name,
            note="Kulla-Conti's E_avg in [0, 1]; the blog's E_avg is pi times it.",
            **_ABSOLUTE,
        ),
    )


#: (form, preset) of the published approximations of each target (:mod:`..forms` has their sources)
PUBLISHED = {
    "E_ggx_sep": (
        ("sforza_ratpoly3", "sforza_pellacini_2022"),
        ("knarkowicz_poly", "knarkowicz_2014"),
        ("karis_linear", "karis_2014"),
    ),
    "E_ggx_cor": (
        ("materialx_ratquad", "materialx"),
        ("materialx_ratquad", "materialx_pre_2022"),
        ("karis_linear", "karis_2014"),
    ),
    "E_avg_ggx_sep": (("patapom_quartic", "patapom"), ("patapom_zonal", "patapom"), ("karis_linear", "karis_2014")),
    "E_avg_ggx_cor": (("karis_linear", "karis_2014"),),
    "E_on": (("materialx_rational", "materialx"),),
    "E_avg_on": (("patapom_quartic", "patapom"), ("patapom_zonal", "patapom")),
}
# the 1 - E targets carry their E target's presets, as 1 - E
PUBLISHED.update({f"one_minus_{k}": v for k, v in list(PUBLISHED.items()) if k.startswith("E_") and not
                  k.startswith("E_avg")})  # fmt: skip

_DEFAULTS = {
    # the best form for the target (the refit table of the family's report): each beats the published presets of its
    # target many times over on the whole domain, the grazing layer included, where the published shapes cannot go
    # below about 0.1 (they are smooth in mu and alpha, and the layer's width scales with alpha).  Separable 1 - E
    # keeps grazing_rational although a refit of rational_v_alpha_4 has the smaller max and RMS error: that one's
    # 1 - E = (D - N)/(1 + D) goes slightly below 0 at small alpha (a negative lobe, which the floor of the error's
    # scale does not punish) and cancels in float, where grazing_rational's v^2 P/(1 + Q) is >= 0 and exact at 0
    "ggx_separable": {"E": "rational_v_alpha_4", "one_minus_E": "grazing_rational", "E_avg": "log_rational"},
    "ggx_correlated": {"E": "grazing_log_rational", "one_minus_E": "grazing_log_rational", "E_avg": "log_rational"},
    "oren_nayar": {"E": "abg_cubic", "one_minus_E": "abg_cubic", "E_avg": "a_plus_kappa_b"},
}

TARGETS: dict[str, Target] = {t.name: t for model in MODEL_SUFFIX for t in _albedo_targets(model, _DEFAULTS[model])}

# the parameters of the fitted multiple-scattering lobes by order: targets.lobes owns them
TARGETS.update(LOBE_TARGETS)
