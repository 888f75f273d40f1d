"""fitlab simulate end to end: stopping rules, only the needed jobs, CSV and PNG outputs, CLI."""

import csv
from dataclasses import replace

import pytest

import fitlab  # noqa: F401
from fitlab.cli import main
from fitlab.families.lambert_sphere.mc.effects import ROW_FIELDS, plan
from fitlab.families.lambert_sphere.mc.scene import parse_scene
from fitlab.families.lambert_sphere.mc.simulate import simulate, simulate_file

SCENE = """\
[scene]
name = "tiny"
seed = 8
[[material]]
c = 0.5
[incident]
mu_i = [0.6]
[outgoing]
mu_o = [0.0, 0.5, 1.0]
fourier = [0, 1, 2]
phi = 2
[effects]
list = ["single", "multiple", "collisions", "phase_difference", "albedo", "spherical_albedo"]
collision_orders = 4
[precision]
target_se = {multiple = 4e-3, collisions = 4e-3, phase_difference = 1e-3, albedo = 3e-3, spherical_albedo = 3e-3}
max_paths = 60_000
batch = 20_000
max_collisions = 5000
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiny")
    p = out / "tiny.toml"
    p.write_text(SCENE)
    result, paths = simulate_file(p, out_dir=out / "res", progress=False)
    return result, paths


def test_outputs_are_complete(tiny):
    result, paths = tiny
    names = {p.name for p in paths}
    effects = result.scene.effects
    assert {"tiny.csv", "tiny_summary.csv"} | {f"tiny_{e}.png" for e in effects} == names
    for p in paths:
        assert p.stat().st_size > 0
        if p.suffix == ".png":
            assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(paths[0].parent.glob("*.tmp"))
    rows = list(csv.DictReader(paths[0].open()))
    assert tuple(rows[0].keys()) == ROW_FIELDS
    assert {r["effect"] for r in rows} == set(effects)
    summary = list(csv.DictReader(paths[1].open()))
    assert [s["effect"] for s in summary] == list(effects)


def test_estimates_agree_with_references(tiny):
    result, _ = tiny
    zs = [r["z_ref"] for e in result.rows.values() for r in e if r["se"] > 0 and r["z_ref"] == r["z_ref"]]
    assert len(zs) > 20
    assert max(abs(z) for z in zs) < 4
    single = result.rows["single"]
    assert all(r["se"] == 0 and r["ref"] == r["estimate"] for r in single)


def test_phi_bins_and_fourier_orders_tell_the_same_story(tiny):
    """The |phi|-bin averages equal the Fourier series averaged over the bin, within errors."""
    import math

    result, _ = tiny
    rows = [r for r in result.rows["multiple"] if r["quantity"] == "f_ms"]
    fourier = {(r["mu_lo"], r["m"]): r for r in rows if r["m"] != ""}
    for r in (r for r in rows if r["phi_lo"] != ""):
        p, q = r["phi_lo"], r["phi_hi"]
        avg = [1.0] + [(math.sin(m * q) - math.sin(m * p)) / (m * (q - p)) for m in (1, 2)]
        series = sum(fourier[(r["mu_lo"], m)]["estimate"] * avg[m] for m in range(3))
        se = math.hypot(r["se"], sum(fourier[(r["mu_lo"], m)]["se"] * abs(avg[m]) for m in range(3)))
        # the Fourier series stops at m = 2, exact for the three-term half space
        assert abs(r["estimate"] - series) < 4 * se


def test_order_one_rows_reject_the_printed_normalisation(tiny):
    result, _ = tiny
    m1 = [r for r in result.rows["multiple"] if r["m"] == 1 and r["quantity"] == "f"]
    assert m1 and all(r["alt_name"] == "printed eq. 22 (6 pi)" for r in m1)
    assert all(abs(r["z_ref"]) < 4 for r in m1)
    assert max(abs(r["z_alt"]) for r in m1) > 10


def test_collision_orders_sum_to_the_multiple_scattering_albedo(tiny):
    result, _ = tiny
    rows = result.rows["collisions"]
    by_order = sum(r["estimate"] for r in rows if r["quantity"] == "a_ms_n")
    total = next(r for r in rows if r["quantity"] == "a_ms")
    assert by_order == pytest.approx(total["estimate"], rel=1e-12)
    assert [r["n"] for r in rows if r["quantity"] == "a_ms_n"] == ["2", "3", "4", ">4"]


def test_stopping_rule_and_budget():
    scene = parse_scene(SCENE, "tiny.toml")
    loose = replace(scene, effects=("albedo",), target_se={"albedo": 0.5})
    res = simulate(loose, progress=False)
    (st,) = res.jobs.values()
    assert st.converged and st.paths == 20_000  # >= 10 000 photons, one round
    tight = replace(scene, effects=("albedo",), target_se={"albedo": 1e-6}, max_paths=30_000)
    res = simulate(tight, progress=False)
    (st,) = res.jobs.values()
    assert not st.converged and st.paths == 30_000 and st.rounds == 2  # 20 000 + the 10 000 left
    assert res.summary[0]["converged"] is False
    assert all(r["converged"] is False for r in res.rows["albedo"])


def test_only_the_jobs_and_tallies_an_effect_needs():
    scene = parse_scene(SCENE, "tiny.toml")
    full = plan(scene)
    assert sorted(j.kind for j in full) == ["both", "cosine", "fixed"]
    fixed = next(cfg for j, cfg in full.items() if j.kind == "fixed")
    assert fixed.orders and fixed.phi_edges and fixed.collision_orders == 4
    only_albedo = plan(replace(scene, effects=("albedo",)))
    (cfg,) = only_albedo.values()
    assert not cfg.orders and not cfg.phi_edges and not cfg.collision_orders and not cfg.mu_edges
    assert plan(replace(scene, effects=("single",))) == {}
    coll = plan(replace(scene, effects=("collisions",)))
    (cfg,) = coll.values()
    assert cfg.collision_orders == 4 and not cfg.orders and cfg.mu_edges


def test_cli(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE.replace("c = 0.5", "c = 8"))
    assert main(["simulate", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:5: material[0].c: 8 is outside [0.0, 1.0]" in err
    good = tmp_path / "one.toml"
    good.write_text(SCENE.replace('list = ["single", "multiple", "collisions", "phase_difference", "albedo", '
                                  '"spherical_albedo"]', 'list = ["albedo"]').replace("collision_orders = 4\n", ""))
    assert main(["simulate", str(good), "--quiet", "--no-plots", "--out", str(tmp_path / "o"),
                 "--target-se", "0.01"]) == 0
    out = capsys.readouterr().out
    assert "albedo" in out and (tmp_path / "o" / "tiny.csv").exists()
    assert not (tmp_path / "o" / "tiny_albedo.png").exists()
    assert main(["simulate", str(good), "--quiet", "--target-se", "-1"]) == 2
