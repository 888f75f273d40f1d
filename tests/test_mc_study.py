"""Slow Monte Carlo studies (pytest -m benchmark): the shipped scenes at their full precision."""

from pathlib import Path

import pytest

import fitlab  # noqa: F401
from fitlab.families.lambert_sphere.mc.scene import load_scene
from fitlab.families.lambert_sphere.mc.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.benchmark
def test_order1_scene_settles_the_normalisation():
    """data/scenes/order1_normalisation.toml: every f1 and fm1 row agrees with the 3 pi
    normalisation and rejects the printed 6 pi (eq. 22) and 384 pi (eq. 28)."""
    res = simulate(
        load_scene(ROOT / "fitlab" / "data" / "lambert_sphere" / "scenes" / "order1_normalisation.toml"), progress=False
    )
    rows = [r for r in res.rows["multiple"] if r["m"] == 1 and r["se"] > 0]
    assert len(rows) == 2 * 3 * 2 * 5
    assert all(abs(r["z_ref"]) < 4 for r in rows)
    assert all(abs(r["z_alt"]) > 10 for r in rows if r["quantity"] == "f")
    assert all(s["converged"] for s in res.summary)


@pytest.mark.benchmark
def test_true_phase_grazing_scene_checks_the_true_engine():
    """data/scenes/true_phase_grazing.toml (about 6 minutes): every row agrees with the true-phase engine, and the
    correlated true-minus-three-term rows resolve the exact difference of the two half spaces' multiple scattering
    at grazing incidence (mu_i = 0.05, c = 0.99, mu_o in [0.05, 0.2], order 0) at more than 5 SE."""
    import math

    res = simulate(
        load_scene(ROOT / "fitlab" / "data" / "lambert_sphere" / "scenes" / "true_phase_grazing.toml"), progress=False
    )
    rows = [
        r for e in ("multiple", "phase_difference") for r in res.rows[e] if r["se"] > 0 and math.isfinite(r["z_ref"])
    ]
    assert len(rows) == 2 * 2 * 2 * (3 * 5 * 2) + 2 * 2 * 2  # two effects' mode rows, and the albedo differences
    assert all(abs(r["z_ref"]) < 4 for r in rows)
    (grazing,) = [
        r
        for r in res.rows["phase_difference"]
        if r["quantity"] == "d_f_ms" and r["c"] == 0.99 and r["mu_i"] == 0.05 and r["mu_lo"] == 0.05 and r["m"] == 0
    ]
    assert abs(grazing["estimate"]) > 5 * grazing["se"]
    assert all(s["converged"] for s in res.summary)
