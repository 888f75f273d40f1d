"""Scene files of the microsurface walk: every problem refused, with its line, before any work."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import fitlab
from fitlab.families.microfacet_energy.mc import SceneError, load_scene, parse_scene
from fitlab.families.microfacet_energy.mc.scene import with_overrides
from fitlab.families.microfacet_energy.mc.simulate import simulate_file

GOOD = """
[scene]
name = "ok"
[[material]]
kind = "conductor"
distribution = "ggx"
alpha = 0.5
[incident]
mu_i = [0.5]
[precision]
target_se = 0.01
"""


def test_a_good_scene_and_its_defaults():
    s = parse_scene(GOOD, "ok.toml")
    assert s.materials[0].fresnel == "one" and s.materials[0].alpha_x == s.materials[0].alpha_y == 0.5
    assert len(s.mu_edges) == 9 and len(s.phi_edges) == 7 and s.orders == 4
    assert s.target_se == {"lobe": 0.01, "albedo": 0.01}


def test_every_problem_is_reported_with_its_line():
    bad = GOOD.replace("alpha = 0.5", "alpha = nan\ncolour = 1").replace('kind = "conductor"', 'kind = "glass"')
    bad = bad.replace("mu_i = [0.5]", "mu_i = [0.0]")
    with pytest.raises(SceneError) as exc:
        parse_scene(bad, "bad.toml")
    lines = str(exc.value).splitlines()
    assert len(lines) == 4
    assert any(line.startswith("bad.toml:5: material[0].kind:") for line in lines)
    assert any("material[0].alpha:" in line and "finite" in line for line in lines)
    assert any("material[0].colour: unknown field" in line for line in lines)
    assert any("incident.mu_i:" in line for line in lines)


@pytest.mark.parametrize(
    "change,field",
    [
        ('fresnel = "schlick"', "material[0].f0: missing"),
        ('fresnel = "conductor"\neta = 0.2', "material[0].k: missing"),
        ("albedo = 0.5", "material[0].albedo: not used"),
        ("alpha_x = 0.3", "give alpha, or alpha_x and alpha_y"),
    ],
)
def test_material_parameters_must_fit_the_kind(change, field):
    with pytest.raises(SceneError, match=re.escape(field)):
        parse_scene(GOOD.replace("alpha = 0.5", "alpha = 0.5\n" + change))


def test_target_se_per_row_kind():
    """target_se as a table (fitlab.scenes.Checker.per_key, shared with the Lambert sphere's scenes): a value per
    row kind; an unknown kind, a bad value and a kind left out are each refused on its own line."""
    table = GOOD.replace("target_se = 0.01", "target_se = {lobe = 0.02, albedo = 1e-3}")
    assert parse_scene(table).target_se == {"lobe": 0.02, "albedo": 1e-3}
    bad = GOOD.replace("target_se = 0.01", "[precision.target_se]\nlobe = -1\ncolour = 0.1")
    with pytest.raises(SceneError) as exc:
        parse_scene(bad, "bad.toml")
    lines = str(exc.value).splitlines()
    assert len(lines) == 3
    assert "bad.toml:12: precision.target_se.lobe: expected a positive finite number, got -1" in lines
    assert "bad.toml:13: precision.target_se.colour: unknown row kind 'colour' (known: lobe, albedo)" in lines
    assert any(line.endswith("precision.target_se: no target for row kind 'albedo'") for line in lines)
    with pytest.raises(SceneError, match="expected a positive finite number or a table per row kind, got 0"):
        parse_scene(GOOD.replace("target_se = 0.01", "target_se = 0"))


def test_not_toml_and_wrong_types():
    with pytest.raises(SceneError, match="not valid TOML"):
        parse_scene("[scene\n")
    with pytest.raises(SceneError, match="precision.batch: expected an integer"):
        parse_scene(GOOD + "batch = 1.5\n")
    with pytest.raises(SceneError, match="outgoing.mu_o: bin edges must increase"):
        parse_scene(GOOD.replace("[precision]", "[outgoing]\nmu_o = [0.0, 0.5, 0.5, 1.0]\n[precision]"))


def test_overrides_take_the_file_rules():
    s = parse_scene(GOOD)
    assert with_overrides(s, seed="12", max_paths=5000).seed == 12
    with pytest.raises(SceneError) as exc:
        with_overrides(s, seed=-1, target_se="x")
    assert len(str(exc.value).splitlines()) == 2


def test_shipped_scenes_validate():
    folder = Path(fitlab.__file__).parent / "data" / "microfacet_energy" / "scenes"
    files = sorted(folder.glob("microsurface_*.toml"))
    assert files
    for f in files:
        assert load_scene(f).materials


def test_simulate_file_refuses_a_bad_output_before_any_work(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(GOOD)
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(SceneError, match="--out"):
        simulate_file(scene, blocker)
    with pytest.raises(SceneError, match="a microsurface scene is a .toml file"):
        simulate_file(tmp_path / "s.json", tmp_path / "out")


def test_binary_garbage_is_refused_in_one_line(tmp_path):
    p = tmp_path / "garbage.toml"
    p.write_bytes(b"[scene]\n\xfc\xff\x00\x81 binary")
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    assert str(exc.value) == f"{p}:1: (file): not a UTF-8 text file (byte 0xfc at offset 8)"


def test_the_walk_precision_is_a_scene_choice():
    """``[precision] float`` picks the walk's arithmetic for the scene's jobs (default float32); any other value
    is refused with its line."""
    from fitlab.families.microfacet_energy.mc.simulate import job_config

    s = parse_scene(GOOD, "ok.toml")
    assert s.walk_precision == "float32" and job_config(s, s.materials[0]).precision == "float32"
    s = parse_scene(GOOD + 'float = "float64"\n', "ok.toml")
    assert job_config(s, s.materials[0]).precision == "float64"
    with pytest.raises(SceneError, match=r"ok.toml:12: precision.float: .*float16"):
        parse_scene(GOOD + 'float = "float16"\n', "ok.toml")
