r"""The refit targets: what each approximates, on which data, measured how.

Errors are relative, |approx - exact| / scale, with scale = |exact| except for
B, C, D, F, whose scale is A = 69c/128 (the constant term of Q in eq. 30):
B changes sign near c = 0.94 and D, F vanish at c = 1, so |dX|/|X| is
unbounded for any approximation, while an error dX moves Q, and so f^(0), by
at most 2 |dX| against A.  Where the scale is 0 (an exact zero of the target)
the error is 0 if the approximation is exactly 0 there too and inf otherwise.
"""

from __future__ import annotations

import math

import numpy as np

from fitlab.core import Dataset, Input, Target
from fitlab.families.lambert_sphere.exact import PHASES, h_function
from fitlab.families.lambert_sphere.targets import datasets as d
from fitlab.families.lambert_sphere.targets.grids import GRID_AXES, exact_grid

__all__ = ["INPUTS", "TARGETS", "THREE_TERM", "MIXED", "TRUE"]


#: the inputs of every Lambert-sphere target, each defined once (symbol and domain)
INPUTS = {
    i.name: i
    for i in (
        Input("mu", (0.0, 1.0), "cosine of a direction with the normal"),
        Input("mu_i", (0.0, 1.0), "cosine of the incident direction"),
        Input("mu_o", (0.0, 1.0), "cosine of the outgoing direction"),
        Input("phi", (-math.pi, math.pi), "relative azimuth (radians); phi = 0 is back-scattering"),
        Input("c", (0.0, 1.0), "particle (single-scattering) albedo"),
        Input("kd", (0.0, 1.0), "spherical (Bond) albedo of the material"),
    )
}


def _inputs(*names: str) -> tuple[Input, ...]:
    return tuple(INPUTS[n] for n in names)


def _h_grid(order: int):
    """Exact H_order on a tensor grid of (mu, c) axes (the ``exact_grid`` of a target)."""

    def grid(axes):
        g = dict(zip(axes, np.meshgrid(*axes.values(), indexing="ij")))
        return g, h_function(order, g["mu"], g["c"]), {}

    return grid


def _scale_a(ds: Dataset) -> np.ndarray:
    return 69.0 * ds.inputs["c"] / 128.0


#: the physics of each target's exact values (:attr:`fitlab.core.Target.physics`), named as the exact engine's
#: ``phase``: the H-functions and constants are the three-term half space's, kd the true BRDF's spherical albedo,
#: the sampler optimised for the mixed reference (:mod:`..exact.sampling`)
TRUE, THREE_TERM, MIXED = PHASES


def _constant_target(name: str, forms: tuple[str, str], published, description: str, **kw) -> Target:
    return Target(
        name=name,
        description=description,
        variables=_inputs("c"),
        default_form=forms[0],
        published=published,
        training=lambda: d.constant_training(name),
        validation=lambda: d.constant_validation(name),
        exact_grid=exact_grid(name),
        routine=f"const_{name.lower()}",
        physics=THREE_TERM,
        **kw,
    )


_BF = dict(
    error_measure="relative to A = 69c/128: |approx - exact| / A (the constant term of Q, eq. 30)",
    scale=_scale_a,
)

TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target(
            "H0",
            "H0(mu, c), mu and c in [0, 1]",
            _inputs("mu", "c"),
            "hapke",
            (("hapke", "paper"),),
            lambda: d.h_training(0),
            lambda: d.h_validation(0),
            exact_grid("H0"),
            "h0",
            physics=THREE_TERM,
            claimed="relative error < 1 % on (mu, c) in [0, 1]^2 (paper, sec. 3.4)",
            emphasis=lambda ds: 1.0 / (ds.inputs["c"] + 0.1),
            emphasis_text=(
                "training residuals weighted by 1/(c + 0.1): the runtime model uses H0 in fm0 = f0 - f0_ss, which is "
                "O(c^2) while f0 is O(c), so an error of H0 at small c costs 1/c times more in f_r; the max error "
                "(set at c = 1, the floor of the form) is unchanged by it"
            ),
        ),
        Target(
            "H1",
            "H1(mu, c), mu and c in [0, 1]",
            _inputs("mu", "c"),
            "separable",
            (
                ("separable_printed", "paper"),
                ("separable_printed", "paper_variant"),
                ("separable", "paper"),
                ("separable", "renderer"),
            ),
            lambda: d.h_training(1),
            lambda: d.h_validation(1),
            exact_grid("H1"),
            "h1",
            physics=THREE_TERM,
            claimed="relative error < 0.5 % (paper, sec. 3.3)",
        ),
        Target(
            "H2",
            "H2(mu, c), mu and c in [0, 1]: the H-function of Fourier order 2 (eq. 15), for fm2",
            _inputs("mu", "c"),
            "log_exp",
            (("unity", "paper"),),
            lambda: d.h_training(2),
            lambda: d.h_validation(2),
            _h_grid(2),
            "h2",
            physics=THREE_TERM,
            claimed="none: the paper drops fm2 (eq. 21), i.e. takes H2 = 1 (form unity)",
        ),
        _constant_target(
            "l", ("quadratic",), (("quadratic", "paper"), ("quadratic", "renderer")), "l(c) of f^(1) (eq. 22)"
        ),
        _constant_target("m", ("linear",), (("linear", "paper"), ("linear", "renderer")), "m(c) of f^(1) (eq. 22)"),
        *(
            _constant_target(n, ("rational_3_2",), (("printed", "paper"),), f"{n}(c) of Q in f^(0) (eq. 30)", **_BF)
            for n in "BCDF"
        ),
        Target(
            "kd_of_c",
            "kd(c): spherical albedo of fitlab.families.lambert_sphere.exact.brdf (kd_true), c in [0, 1]",
            _inputs("c"),
            "printed_c0",
            (("printed", "paper"),),
            d.kd_of_c_training,
            d.kd_of_c_validation,
            exact_grid("kd_of_c"),
            "kd_of_c",
            physics=TRUE,
        ),
        Target(
            "c_of_kd",
            "c(kd): inverse of kd_true, kd in [0, 1]",
            _inputs("kd"),
            "rational_power",
            (("rational_power", "paper"), ("rational_power", "renderer")),
            d.c_of_kd_training,
            d.c_of_kd_validation,
            exact_grid("c_of_kd"),
            "c_of_kd",
            axes=GRID_AXES["c_of_kd"],
            physics=TRUE,
        ),
        Target(
            "fm1",
            "fm1(mu_i, mu_o, c): multiple scattering of Fourier order 1 (eq. 28, corrected)",
            _inputs("mu_i", "mu_o", "c"),
            "fast",
            (("fast", "paper"),),
            d.fm1_training,
            d.fm1_validation,
            exact_grid("fm1"),
            physics=THREE_TERM,
            error_measure=(
                "relative to f^(0): |approx - exact| / f^(0)(mu_i, mu_o, c), f^(0) the azimuthal mean of the exact "
                "BRDF (fm1 itself vanishes at c = 0 and mu = 1, and grows only like log(1/mu) at grazing, where "
                "eq. 29 grows like mu^(-1/2): |dfm1|/|fm1| is unbounded, the error it makes in f_r is not)"
            ),
            scale=lambda ds: ds.aux["f0"],
        ),
        Target(
            "fast_brdf",
            "f_r(mu_i, mu_o, phi, c, kd = kd_true(c)) against fitlab.families.lambert_sphere.exact.brdf",
            _inputs("mu_i", "mu_o", "phi", "c", "kd"),
            "paper",
            (("paper", "paper"),),
            d.brdf_training,
            d.brdf_validation,
            exact_grid("fast_brdf"),
            "brdf_fast",
            axes=GRID_AXES["fast_brdf"],
            minimax=False,
            physics=TRUE,
            note=(
                "At phi = pi, mu_i = mu_o = mu -> 0 the exact f_r grows like log(1/mu) while every member of the "
                "eq. 41 family stays bounded (f_1 -> 0 there, the other terms are bounded), so the supremum of the "
                "relative error is 1 for every parameter vector: the max is pinned at the grazing pole and the refit "
                "minimises the RMS instead (no minimax refinement)."
            ),
        ),
        *(
            Target(
                name,
                f"{what}, mu_i and c in [0, 1]",
                _inputs("mu_i", "c"),
                form,
                (),
                lambda name=name: d.sampling_training(name),
                lambda name=name: d.sampling_validation(name),
                routine=name,
                physics=MIXED,
                claimed="none: no published sampler (renderers draw cosine-weighted directions, w = 0)",
                minimax=False,
                note=(
                    "What matters is the sampler's variance, not this parameter's relative error: the variance is "
                    "flat about its optimum, and the optimum moves fast within mu_i in [0.99, 1] (exact.sampling), "
                    "which a smooth form follows only in the mean; the max of the relative error is set there, so "
                    "the refit minimises the RMS (no minimax refinement). docs/model.md measures the variance."
                ),
            )
            for name, form, what in (
                (
                    "sample_weight",
                    "logistic_poly",
                    "w(mu_i, c): the weight of the back-scatter lobe in the variance-optimal sampling mixture (exact.sampling)",
                ),
                (
                    "sample_exponent",
                    "exp_poly",
                    "n(mu_i, c): the exponent of the back-scatter lobe in the variance-optimal sampling mixture (exact.sampling)",
                ),
            )
        ),
    )
}
