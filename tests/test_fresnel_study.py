"""docs/fresnel.md and fresnel.json: the committed figures are what the engine gives now (re-measured here by
other code), and the study's measures are what they say they are."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fitlab.core import get_target
from fitlab.families.fresnel import exact
from studies.fresnel import fresnel_study

DOCS = Path(__file__).resolve().parents[1] / "docs"


@pytest.fixture(scope="module")
def committed():
    return json.loads((DOCS / "fresnel.json").read_text())


def test_committed_study_covers_every_material_and_form(committed):
    assert list(committed["materials"]) == list(exact.MATERIALS)
    text = (DOCS / "fresnel.md").read_text()
    for m, row in committed["materials"].items():
        assert set(row["approximations"]) == set(committed["forms"])
        assert f"fresnel_{m}.png" in text and (DOCS / f"fresnel_{m}.png").is_file()


@pytest.mark.parametrize("material", list(exact.MATERIALS))
def test_committed_schlick_figures_are_recomputed(committed, material):
    # Schlick's construction by hand, on the validation angles, against the stored max error and F_avg error
    row = committed["materials"][material]
    mu = get_target(f"F_{material}_r").validation().inputs["mu"]
    f = exact.reflectance(material, mu)
    f0 = exact.reflectance(material, 1.0)
    schlick = f0[None, :] + (1 - f0[None, :]) * (1 - mu[:, None]) ** 5
    meas = row["approximations"]["schlick"]["construction"]
    assert meas["max_abs"] == pytest.approx(float(np.max(np.abs(schlick - f))), rel=1e-9, abs=1e-15)
    f_avg = exact.average_reflectance(material)
    want = float(np.max(np.abs((20 * f0 + 1) / 21 - f_avg)))  # Schlick's F_avg in closed form
    assert meas["f_avg_error"] == pytest.approx(want, rel=1e-9, abs=1e-13)
    np.testing.assert_allclose(row["F0"]["srgb"], f0, rtol=1e-12)
    np.testing.assert_allclose(row["F_avg"]["acescg"], exact.average_reflectance(material, "acescg"), rtol=1e-12)


def test_committed_best_errors_are_the_packaged_refits(committed):
    # the default refits the family ships (fitlab/fits) are the study's unweighted refits of the same form
    from fitlab.resources import packaged_fits
    from fitlab.store import read_fit

    for m, row in committed["materials"].items():
        for c, channel in enumerate(exact.CHANNELS):
            rec = read_fit(packaged_fits() / f"F_{m}_{channel}.json")
            study = row["approximations"][rec["form"]]["refit"]["max_abs_channel"][c]
            assert study == pytest.approx(rec["validation"]["max_rel"], rel=1e-6, abs=1e-14)


@pytest.mark.e2e
def test_study_measures_hold_on_one_material():
    pytest.importorskip("colour")
    result = fresnel_study.run(["glass"], progress=False)
    row = result["materials"]["glass"]
    by = row["approximations"]
    assert by["gulbrandsen"]["construction"] is None  # a metals' construction
    assert by["gulbrandsen"]["refit"]["max_abs"] < 1e-13  # g = 0 is the exact dielectric
    assert by["gulbrandsen"]["refit"]["delta_e00"] < 1e-10
    for name in ("schlick", "f82_tint"):
        assert by[name]["refit"]["max_abs"] <= by[name]["construction"]["max_abs"]  # minimax beats the construction
    # the cosine-weighted refit spends its accuracy on F_avg: never a worse F_avg than the unweighted one of Schlick
    assert by["schlick"]["refit_cosine"]["f_avg_error"] <= by["schlick"]["refit"]["f_avg_error"]
    assert row["dip"]["depth"] == [0.0, 0.0, 0.0]  # a dielectric's F rises from F0
    text = fresnel_study.markdown(result)
    assert "| glass (n = 1.5) | 3.6e-02 |" in text  # Schlick's construction, as the committed study states
