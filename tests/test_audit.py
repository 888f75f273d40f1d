"""The audit's helpers and the one owner of each rule they share: a preset measured on its
validation set (fitlab.fit.refit.preset_metrics, as the fit records state it), the richer refit
forms (the report's rule), the exact inverse of the spherical albedo, and the furnace's quadrature (the
directional albedo) against the exact engine."""

import json
from pathlib import Path

import numpy as np
import pytest

from fitlab.families.lambert_sphere.exact import albedo, albedo_inverse, brdf, solve_albedo, spherical_albedo
from fitlab.families.lambert_sphere.program.report.audit import directional_albedo, richer_forms
from fitlab.fit.refit import preset_metrics

FITS = Path(__file__).resolve().parents[1] / "fitlab" / "fits"


# kd_of_c's validation set (kd_true at 130 albedos, about 140 s cold): on the worker that runs
# test_residuals.py's test of it too, so that a cold run computes it once (xdist_group)
@pytest.mark.xdist_group("kd_true-validation")
@pytest.mark.parametrize("target", ["m", "kd_of_c"])
def test_preset_metrics_reproduce_the_fit_records(target):
    record = json.loads((FITS / f"{target}.json").read_text())
    for p in record["published"]:
        got = preset_metrics(target, p["form"], p["preset"])
        for key in ("max_rel", "max_rel_nonzero", "rms_rel", "points"):
            want = p["validation"][key]
            want = float(want) if isinstance(want, str) else want  # "inf" in the JSON
            assert got[key] == want or got[key] == pytest.approx(want, rel=1e-12), (p["form"], p["preset"], key)


def test_richer_forms_follow_the_reports_rule(tmp_path):
    # the committed refits: the order-2 model's forms are each part's most accurate (their recorded
    # validation errors are recomputed by test_stored_figures)
    assert richer_forms(FITS) == {"H0": "log_exp", "H1": "log_exp", "l": "cubic", "m": "quadratic",
                                  **{n: "c2_rational_4_3" for n in "BCDF"}}  # fmt: skip
    # a folder without richer refits has none; discovered fits never count
    for name in ("m.json", "m.quadratic.json"):
        (tmp_path / name).write_text((FITS / name).read_text())
    assert richer_forms(tmp_path) == {"m": "quadratic"}
    rec = json.loads((FITS / "m.quadratic.json").read_text())
    rec["origin"] = {"method": "fitlab discover"}
    (tmp_path / "m.quadratic.json").write_text(json.dumps(rec))
    assert richer_forms(tmp_path) == {}


def test_albedo_inverse_inverts_the_spherical_albedo():
    # the whole-phase albedo solves its order 0 at every new c (about 1 s): one kd of it
    for phase, kds in (("three_term", (0.05, 0.5, 0.9)), ("mixed", (0.05, 0.5, 0.9)), ("true", (0.5,))):
        for kd in kds:
            c = albedo_inverse(kd, phase)
            assert float(spherical_albedo(c, phase)) == pytest.approx(kd, abs=1e-12)
            assert albedo_inverse(kd, phase, guess=c + 0.003) == pytest.approx(c, abs=1e-12)
    assert albedo_inverse(0.0) == 0.0 and albedo_inverse(1.1) == 1.0
    assert solve_albedo(np.sqrt, 0.5) == pytest.approx(0.25, abs=1e-12)


def test_directional_albedo_quadrature_matches_the_exact_engine():
    """The audit's furnace rule (graded Gauss in mu_o, Gauss-Legendre in phi) integrates the exact BRDF to
    its directional albedo (moved here from tests/test_refit.py)."""
    for mu in (0.0, 0.3, 0.9):
        assert directional_albedo(brdf, mu, 0.7) == pytest.approx(float(albedo(mu, 0.7)), abs=1e-8)
