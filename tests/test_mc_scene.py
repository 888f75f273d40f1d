"""Scene files: validation with file:line and field, before any simulation."""

import json
from pathlib import Path

import pytest

import fitlab  # noqa: F401
from fitlab.families.lambert_sphere.mc import scene as scene_mod
from fitlab.families.lambert_sphere.mc.scene import EFFECTS, SceneError, load_scene, parse_scene

ROOT = Path(__file__).resolve().parents[1]

GOOD = """\
[scene]
seed = 3
phase = "three_term"

[[material]]
c = 0.5
[[material]]
c = 0.9
label = "bright"

[incident]
mu_i = [0.3,
        0.7]

[outgoing]
mu_o = 4
fourier = [0, 1, 2]

[effects]
list = ["single", "multiple", "albedo"]

[precision]
target_se = 2e-3
max_paths = 50_000
batch = 10_000
"""


def _as_json(text):
    import tomllib

    return json.dumps(tomllib.loads(text), indent=2)


def test_shipped_scenes_validate():
    files = sorted((ROOT / "fitlab" / "data" / "lambert_sphere" / "scenes").glob("*.toml")) + sorted(
        (ROOT / "fitlab" / "data" / "lambert_sphere" / "scenes").glob("*.json")
    )
    names = {p.stem for p in files}
    assert {"order1_normalisation", "order2_term", "albedo_maps"} <= names
    for p in files:
        s = load_scene(p, resolve_kd=False)  # kd -> c is tested below
        assert s.effects and s.target_se
        assert s.name == p.stem


def test_toml_and_json_give_the_same_scene():
    a = parse_scene(GOOD, "x.toml")
    b = parse_scene(_as_json(GOOD), "x.json")
    assert a.materials == b.materials and a.mu_edges == b.mu_edges == (0.0, 0.25, 0.5, 0.75, 1.0)
    assert a.effects == b.effects and a.target_se == b.target_se and a.orders == b.orders
    assert a.materials[1].label == "bright" and a.mu_i == (0.3, 0.7)


def _error(text, path="s.toml"):
    with pytest.raises(SceneError) as exc:
        parse_scene(text, path)
    return str(exc.value)


@pytest.mark.parametrize(
    "old, new, expected",
    [
        ("c = 0.9\n", "c = 1.5\n", "s.toml:8: material[1].c: 1.5 is outside [0.0, 1.0]"),
        ("        0.7]", "        7.0]", "s.toml:13: incident.mu_i[1]: expected a cosine in [0, 1], got 7.0"),
        (
            'list = ["single", "multiple", "albedo"]',
            'list = ["single", "multiples"]',
            "s.toml:20: effects.list[1]: unknown effect 'multiples'",
        ),
        ("seed = 3\n", "seed = 3\ncolour = 1\n", "s.toml:3: scene.colour: unknown field"),
        ("mu_o = 4\n", "", "effect 'single' needs mu_o bins"),
        ("target_se = 2e-3\n", "", "s.toml:22: precision.target_se: missing"),
        ("target_se = 2e-3\n", "target_se = {albedo = 1e-3}\n", "precision.target_se: no target for effect 'multiple'"),
        ('phase = "three_term"', 'phase = "three_term"\nsampler = "approx"', "s.toml:4: scene.sampler: eq. 6"),
        ("c = 0.5\n", "c = 0.5\nkd = 0.4\n", "s.toml:5: material[0]: give exactly one of c"),
        ("fourier = [0, 1, 2]", "fourier = [0, -1]", "s.toml:17: outgoing.fourier: expected a list of Fourier orders"),
        ("mu_o = 4", "mu_o = [0.0, 0.6, 0.5]", "s.toml:16: outgoing.mu_o: bin edges must increase strictly"),
        ("batch = 10_000", "batch = 1.5", "s.toml:25: precision.batch: expected an integer"),
    ],
)
def test_errors_name_line_and_field(old, new, expected):
    assert old in GOOD
    assert expected in _error(GOOD.replace(old, new, 1))


def test_all_errors_reported_together_in_line_order():
    text = GOOD.replace("c = 0.9\n", "c = -1\n").replace("seed = 3", "seed = -3").replace("mu_o = 4", "mu_o = 0")
    msg = _error(text).splitlines()
    assert [m.split(":")[1] for m in msg] == ["2", "8", "16"], msg


def test_json_errors_name_line_and_field():
    text = _as_json(GOOD.replace("        0.7]", "        7.0]"))
    msg = _error(text, "s.json")
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "7.0" in s)
    assert f"s.json:{line}: incident.mu_i[1]" in msg
    bad = text.replace('"seed": 3,', '"seed": 3,,')
    assert _error(bad, "s.json").startswith("s.json:3: not valid JSON")


def test_toml_syntax_error_names_the_line():
    assert _error(GOOD.replace("seed = 3", "seed = = 3")).startswith("s.toml:2: not valid TOML")
    # an unclosed array: tomllib reports the line where it gave up (the next key)
    assert _error(GOOD.replace("mu_o = 4", "mu_o = [0.0, 0.5")).startswith("s.toml:17: not valid TOML")


def test_file_errors(tmp_path):
    with pytest.raises(SceneError, match="a scene is a .toml or .json file"):
        load_scene(tmp_path / "scene.yaml")
    with pytest.raises(SceneError, match="cannot read"):
        load_scene(tmp_path / "missing.toml")


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_binary_garbage_is_refused_in_one_line(tmp_path, suffix):
    """A file that is not UTF-8 text is a SceneError naming the file and the first bad byte (not a raw
    UnicodeDecodeError: exit 1 with no file name)."""
    p = tmp_path / f"garbage{suffix}"
    p.write_bytes(b"[scene]\n\xfc\xff\x00\x81 binary")
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    assert str(exc.value) == f"{p}:1: (file): not a UTF-8 text file (byte 0xfc at offset 8)"


def test_kd_material_is_converted_through_the_exact_spherical_albedo():
    from fitlab.families.lambert_sphere.exact import spherical_albedo

    s = parse_scene(GOOD.replace("c = 0.5\n", "kd = 0.3\n"), "s.toml")
    m = s.materials[0]
    assert m.kd == 0.3 and m.label == "kd=0.3"
    assert float(spherical_albedo(m.c, "three_term")) == pytest.approx(0.3, abs=1e-11)


def test_every_effect_is_documented():
    """Every effect is named in the scene file's documentation (docs/montecarlo.md, the scene module's section)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "montecarlo.md").read_text()
    section = page.split(f"### `{scene_mod.__name__}`", 1)[1]
    for e in EFFECTS:
        assert e in section, e


def test_bad_scene_does_no_work(tmp_path, monkeypatch):
    """A malformed scene fails before any simulation and writes nothing."""
    import fitlab.families.lambert_sphere.mc.simulate as sim

    def boom(*a, **k):
        raise AssertionError("simulated a malformed scene")

    monkeypatch.setattr(sim, "start_round", boom)
    monkeypatch.setattr(sim, "compile_walk", boom)
    p = tmp_path / "bad.toml"
    p.write_text(GOOD.replace("c = 0.9\n", "c = 2\n"))
    with pytest.raises(SceneError, match="bad.toml:8: material"):
        sim.simulate_file(p, out_dir=tmp_path / "out", progress=False)
    assert not (tmp_path / "out").exists()


def _json_error(text):
    with pytest.raises(SceneError) as exc:
        parse_scene(text, "s.json")
    return str(exc.value)


def test_non_finite_numbers_are_refused_with_their_line():
    """JSON NaN/Infinity (Python's json accepts them) and 1e400 (read as inf), TOML nan/inf:
    one line each, naming file:line and the field."""
    text = _as_json(GOOD)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if '"c": 0.9' in s)
    for bad in ("NaN", "Infinity", "-Infinity", "1e400"):
        msg = _json_error(text.replace('"c": 0.9', f'"c": {bad}'))
        assert msg.startswith(f"s.json:{line}: material[1].c: ") and "not a finite number" in msg, msg
        assert len(msg.splitlines()) == 1
    for bad in ("nan", "inf", "-inf"):
        msg = _error(GOOD.replace("target_se = 2e-3", f"target_se = {bad}"))
        assert msg == f"s.toml:23: precision.target_se: {float(bad)!r} is not a finite number", msg
    assert "not a finite number" in _error(GOOD.replace("0.7]", "nan]"))


def test_batch_is_bounded():
    assert (
        _error(GOOD.replace("batch = 10_000", "batch = 2147483648"))
        == "s.toml:25: precision.batch: 2147483648 is outside [100, 10000000]"
    )
    assert parse_scene(GOOD.replace("batch = 10_000", "batch = 10_000_000"), "s.toml").batch == 10**7


@pytest.mark.parametrize("name", ["..", ".", "a.b", "../x", "a/b", "", "x" * 101, "é"])
def test_names_are_plain_file_name_stems(name):
    msg = _error(GOOD.replace("seed = 3", f"name = {json.dumps(name)}\nseed = 3"))
    assert msg.startswith("s.toml:2: scene.name: expected a plain file-name stem"), msg
    # the default name is the file stem, under the same rule
    assert "(the file stem: set scene.name)" in _error(GOOD, "my.scene.toml")
    assert parse_scene(GOOD.replace("seed = 3", 'name = "ok_Name-2"\nseed = 3'), "s.toml").name == "ok_Name-2"


def test_seed_has_one_rule_for_the_scene_and_the_command_line():
    """The scene's seed and --seed are checked by the same rule (scene.LIMITS["seed"])."""
    from fitlab.families.lambert_sphere.mc.scene import LIMITS, check_option, with_overrides

    lo, hi = LIMITS["seed"]
    assert (lo, hi) == (0, 2**63 - 1)
    for bad in (-1, 2**63, 2**64):
        assert f"is outside [{lo}, {hi}]" in _error(GOOD.replace("seed = 3", f"seed = {bad}"))
        for v in (bad, str(bad)):
            with pytest.raises(SceneError, match=rf"^--seed: expected an integer in \[{lo}, {hi}\]"):
                check_option("seed", v)
    for bad in ("abc", "1.5", True, 1.0):
        with pytest.raises(SceneError, match="^--seed: "):
            check_option("seed", bad)
    assert check_option("seed", str(hi)) == hi
    assert parse_scene(GOOD.replace("seed = 3", f"seed = {hi}"), "s.toml").seed == hi
    scene = parse_scene(GOOD, "s.toml")
    with pytest.raises(SceneError) as exc:  # every bad override, one line each
        with_overrides(scene, target_se="inf", max_paths="5", seed="-1")
    assert [m.split(":")[0] for m in str(exc.value).splitlines()] == ["--target-se", "--max-paths", "--seed"]
    s = with_overrides(scene, target_se="1e-3", max_paths="5000", seed="7")
    assert (s.seed, s.max_paths, s.target_se) == (7, 5000, dict.fromkeys(scene.effects, 1e-3))


def test_c_where_the_estimator_has_infinite_variance_is_refused():
    """Three-term walk: c > 1/N (kd = 1 too) refused with the reason; 1/N itself and the true phase
    function at c = 1 are accepted; the phase_difference walk has its own, lower limit."""
    from fitlab.families.lambert_sphere.mc.phase_sampling import C_LIMIT

    msg = _error(GOOD.replace("c = 0.9\n", "c = 1.0\n"))
    assert msg.startswith("s.toml:8: material[1].c: c = 1 > 1/N = 0.999473: ") and len(msg.splitlines()) == 1
    assert "infinite mean and variance" in msg
    msg = _error(GOOD.replace("c = 0.9\n", "kd = 1.0\n"))
    assert msg.startswith("s.toml:8: material[1].kd: kd = 1 needs c = 1 > 1/N"), msg
    ok = parse_scene(GOOD.replace("c = 0.9\n", f"c = {C_LIMIT['three_term']!r}\n"), "s.toml")
    assert ok.materials[1].c == C_LIMIT["three_term"]
    true = parse_scene(
        GOOD.replace('phase = "three_term"', 'phase = "true"').replace("c = 0.9\n", "c = 1.0\n"), "s.toml"
    )
    assert true.materials[1].c == 1.0
    diff = GOOD.replace('list = ["single", "multiple", "albedo"]', 'list = ["phase_difference"]')
    diff = diff.replace("target_se = 2e-3", "target_se = {phase_difference = 1e-3}")
    assert "variance is infinite" in _error(diff.replace("c = 0.9\n", "c = 0.999\n"))
    assert parse_scene(diff.replace("c = 0.9\n", "c = 0.998\n"), "s.toml").materials[1].c == 0.998


def test_kd_material_of_a_true_scene_is_converted_through_the_true_half_space():
    """In a scene with the true phase function kd is the spherical albedo of the true half space (the physics the
    scene walks and its references are), not of the mixed reference."""
    from fitlab.families.lambert_sphere.exact import spherical_albedo

    s = parse_scene(GOOD.replace('phase = "three_term"', 'phase = "true"').replace("c = 0.5\n", "kd = 0.3\n"), "s.toml")
    m = s.materials[0]
    assert m.kd == 0.3
    assert float(spherical_albedo(m.c, phase="true")) == pytest.approx(0.3, abs=1e-11)
    assert abs(float(spherical_albedo(m.c, phase="mixed")) - 0.3) > 1e-7  # the two inverses differ


def test_the_walk_precision_is_a_scene_choice():
    """``[precision] float`` picks the walk's arithmetic for every job of the scene (default float32); any other
    value is refused with its line."""
    from fitlab.families.lambert_sphere.mc.effects import plan

    assert {cfg.precision for cfg in plan(parse_scene(GOOD, "s.toml")).values()} == {"float32"}
    scene = parse_scene(GOOD.replace("batch = 10_000", 'batch = 10_000\nfloat = "float64"'), "s.toml")
    assert scene.walk_precision == "float64"
    assert {cfg.precision for cfg in plan(scene).values()} == {"float64"}
    msg = _error(GOOD.replace("batch = 10_000", 'batch = 10_000\nfloat = "float16"'))
    assert msg.startswith("s.toml:26: precision.float:") and "float16" in msg and len(msg.splitlines()) == 1
