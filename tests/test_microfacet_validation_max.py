"""The microfacet validation sets find each fit's maximum error.

Before the small-mu and dense grazing lines (fitlab.families.microfacet_energy.targets.datasets), the validation
maxima of one_minus_E_ggx_cor, one_minus_E_ggx_sep and E_ggx_cor were below the true maxima: an adaptive
search from the set's worst points found 4.6, 1.05 and 1.05 times the set's maximum.  Here the search
(:func:`fitlab.fit.search.search_worst`, which climbs over the exact engine) must not find more than 5 %
above the set's maximum, for every packaged fit of the GGX E and 1 - E targets the generated code prints,
and the fit files must state the set's figures (codegen refuses a fit more than 10 % worse than its file).
"""

from __future__ import annotations

import numpy as np
import pytest

from fitlab.core import Dataset, Input, Target, get_target
from fitlab.families.microfacet_energy.targets import datasets
from fitlab.fit.search import search_worst
from fitlab.fit.verify import measure_fit
from fitlab.resources import packaged_fits
from fitlab.store import load

GGX_TARGETS = ("E_ggx_sep", "one_minus_E_ggx_sep", "E_ggx_cor", "one_minus_E_ggx_cor")


@pytest.mark.parametrize("name", GGX_TARGETS)
def test_the_validation_set_finds_the_maximum(name):
    fit = load(packaged_fits() / f"{name}.json")
    target = get_target(name)
    found = search_worst(target, fit.evaluate, target.validation())
    assert found["max_rel"] >= found["set_max_rel"]
    assert found["max_rel"] <= 1.05 * found["set_max_rel"], found
    # the file states what the set measures (to rounding)
    measured = measure_fit(fit)
    recorded = fit.record["validation"]
    for key in ("max_rel", "rms_rel"):
        assert measured[key] == pytest.approx(recorded[key], rel=1e-9)


def test_the_sets_hold_the_small_mu_and_grazing_lines():
    for model in ("ggx_separable", "ggx_correlated"):
        train = datasets.albedo_training(model)
        valid = datasets.albedo_validation(model)
        for ds, mus in ((train, datasets.TRAINING_SMALL_MU), (valid, datasets.VALIDATION_SMALL_MU)):
            for mu in mus:
                assert np.any(np.isclose(ds.inputs["mu"], mu, rtol=1e-14, atol=0.0)), (model, mu)
        # no interior validation point is a training point
        pairs = set(zip(train.inputs["mu"].tolist(), train.inputs["alpha"].tolist()))
        interior = [(m, a) for m, a in zip(valid.inputs["mu"].tolist(), valid.inputs["alpha"].tolist())
                    if 0.0 < m < 1.0 and 0.0 < a < 1.0]  # fmt: skip
        assert not pairs.intersection(interior)
        # the dense layer: t = mu/alpha steps by at most 2^(1/4) from 1/16 to 64 at the smallest alpha
        line = valid.inputs["alpha"] == datasets.VALIDATION_SMALL_ALPHA[0]
        t = np.sort(valid.inputs["mu"][line] / datasets.VALIDATION_SMALL_ALPHA[0])
        t = t[(t >= 1 / 16) & (t <= 64)]
        assert np.max(t[1:] / t[:-1]) <= 2.0**0.25 * (1 + 1e-12)


def _toy_target(peak_at: float) -> Target:
    """exact = 1 on [0, 1]: the error of approx is |approx - 1|, with one narrow peak at ``peak_at``."""

    def grid(axes):
        x = np.asarray(axes["x"], dtype=float)
        return {"x": x.copy()}, np.ones_like(x), {}

    ds = lambda: Dataset({"x": np.linspace(0.0, 1.0, 11)}, np.ones(11), "toy")  # noqa: E731
    return Target("toy_peak", "a toy", (Input("x", (0.0, 1.0), "x"),), "none", (), ds, ds, grid,
                  scale=lambda d: np.ones_like(d.y))  # fmt: skip


def test_search_climbs_to_a_peak_between_the_set_points():
    peak = 0.0123
    target = _toy_target(peak)

    def approx(x):
        return 1.0 + np.exp(-(np.log(np.maximum(x, 1e-300) / peak) ** 2))

    found = search_worst(target, approx, target.validation())
    assert found["set_max_rel"] < 0.3  # the 11 points miss the peak
    assert found["max_rel"] == pytest.approx(1.0, abs=1e-5)
    assert found["worst"]["x"] == pytest.approx(peak, rel=5e-3)


def test_search_refuses_a_target_without_exact_grids():
    target = _toy_target(0.5)
    bare = Target(target.name, target.description, target.variables, "none", (), target.training,
                  target.validation)  # fmt: skip
    with pytest.raises(ValueError, match="no exact values on grids"):
        search_worst(bare, lambda x: x, bare.validation())
