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
    res = simulate(load_scene(ROOT / "fitlab" / "data" / "lambert_sphere" / "scenes" / "order1_normalisation.toml"), progress=False)
    rows = [r for r in res.rows["multiple"] if r["m"] == 1 and r["se"] > 0]
    assert len(rows) == 2 * 3 * 2 * 5
    assert all(abs(r["z_ref"]) < 4 for r in rows)
    assert all(abs(r["z_alt"]) > 10 for r in rows if r["quantity"] == "f")
    assert all(s["converged"] for s in res.summary)
