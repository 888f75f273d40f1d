"""fitlab simulate end to end: stopping rules, only the needed jobs, CSV and PNG outputs, CLI."""

import csv
import sys
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
    assert all(r["se"] == 0 for r in single)


def test_single_scattering_rows_are_the_exact_closed_form(tiny):
    """The 'single' rows (eq. 10 by quadrature in mc.effects) against an independent computation:
    the exact engine's closed-form three-term Fourier orders (single_scattering_modes), averaged over
    each mu_o bin; a |phi| bin is the series f0 + f1 <cos phi> + f2 <cos 2 phi> (orders > 2 vanish)."""
    import math

    import numpy as np

    from fitlab.families.lambert_sphere.exact import single_scattering_modes

    result, _ = tiny
    rows = result.rows["single"]
    assert len(rows) == 2 * (3 + 2)  # 2 mu_o bins x (3 orders + 2 phi bins)
    x, w = np.polynomial.legendre.leggauss(64)
    for r in rows:
        a, b = r["mu_lo"], r["mu_hi"]
        mu = a + (b - a) * (x + 1) / 2
        wmu = w * (b - a) / 2 * mu
        modes = np.array(single_scattering_modes(np.full_like(mu, r["mu_i"]), mu, r["c"])) @ wmu / wmu.sum()
        if r["m"] != "":
            exact = modes[r["m"]]
        else:
            p, q = r["phi_lo"], r["phi_hi"]
            exact = modes[0] + sum(modes[m] * (math.sin(m * q) - math.sin(m * p)) / (m * (q - p)) for m in (1, 2))
        assert r["estimate"] == pytest.approx(exact, rel=1e-10, abs=1e-13), r


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


@pytest.mark.e2e
def test_cli(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(SCENE.replace("c = 0.5", "c = 8"))
    assert main(["simulate", str(bad), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:5: material[0].c: 8 is outside [0.0, 1.0]" in err
    good = tmp_path / "one.toml"
    good.write_text(
        SCENE.replace(
            'list = ["single", "multiple", "collisions", "phase_difference", "albedo", "spherical_albedo"]',
            'list = ["albedo"]',
        ).replace("collision_orders = 4\n", "")
    )
    assert (
        main(["simulate", str(good), "--quiet", "--no-plots", "--out", str(tmp_path / "o"), "--target-se", "0.01"]) == 0
    )
    out = capsys.readouterr().out
    assert "albedo" in out and (tmp_path / "o" / "tiny.csv").exists()
    assert not (tmp_path / "o" / "tiny_albedo.png").exists()
    assert main(["simulate", str(good), "--quiet", "--target-se", "-1"]) == 2


def _albedo_scene(tmp_path, material="c = 0.5"):
    p = tmp_path / "alb.toml"
    p.write_text(
        SCENE.replace(
            'list = ["single", "multiple", "collisions", "phase_difference", "albedo", "spherical_albedo"]',
            'list = ["albedo"]',
        )
        .replace("collision_orders = 4\n", "")
        .replace("c = 0.5", material)
    )
    return p


def test_cli_exits_1_when_a_job_misses_its_target(tmp_path, capsys):
    p = _albedo_scene(tmp_path)
    args = ["simulate", str(p), "--quiet", "--no-plots", "--max-paths", "1000", "--target-se", "1e-6"]
    assert main(args + ["--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err
    assert "not converged: fixed job, material c=0.5 (c = 0.5), mu_i = 0.6:" in err and "after 1000 paths" in err
    rows = list(csv.DictReader((tmp_path / "a" / "tiny.csv").open()))
    assert rows and all(r["converged"] == "False" for r in rows)
    assert main(args + ["--out", str(tmp_path / "b"), "--allow-unconverged"]) == 0
    assert "not converged" in capsys.readouterr().err


@pytest.mark.parametrize(
    "material, expected",
    [
        ("c = 1.0", "material[0].c: c = 1 > 1/N = 0.999473: "),
        ("kd = 1.0", "material[0].kd: kd = 1 needs c = 1 > 1/N = 0.999473: "),
    ],
)
def test_cli_refuses_the_c1_three_term_scene_before_any_work(tmp_path, capsys, monkeypatch, material, expected):
    """The unbounded scene (c = 1 or kd = 1, three-term phase function: its estimate has an infinite
    variance) is refused with one line naming the reason, exit 2, before any simulation."""
    import fitlab.families.lambert_sphere.mc.simulate as sim

    def boom(*a, **k):
        raise AssertionError("simulated a refused scene")

    monkeypatch.setattr(sim, "start_round", boom)
    monkeypatch.setattr(sim, "compile_walk", boom)
    p = _albedo_scene(tmp_path, material)
    assert main(["simulate", str(p), "--quiet", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and expected in err[0] and "infinite mean and variance" in err[0], err
    assert not (tmp_path / "o").exists()
    # a scene made in code (no parse_scene) is refused by simulate() itself
    scene = parse_scene(SCENE, "tiny.toml")
    bad = replace(scene, materials=(replace(scene.materials[0], c=1.0),), effects=("albedo",))
    with pytest.raises(ValueError, match="infinite mean and variance"):
        simulate(bad, progress=False)


@pytest.mark.parametrize(
    "extra, expected",
    [
        (["--seed", "18446744073709551616"], "--seed: expected an integer in [0, 9223372036854775807]"),
        (["--seed", "-1"], "--seed: expected an integer in [0, 9223372036854775807], got '-1'"),
        (["--max-paths", "10"], "--max-paths: expected an integer in [1000, 4294967296]"),
        (["--max-paths", str(2**32 + 1)], "--max-paths: expected an integer in [1000, 4294967296]"),
        (["--target-se", "inf"], "--target-se: expected a positive finite number, got 'inf'"),
        (["--out", "/proc/fitlab-x"], "--out: cannot write in /proc/fitlab-x"),
        (["--out", "FILE"], "exists and is not a folder"),
    ],
)
def test_cli_bad_options_one_line_exit_2_before_any_work(tmp_path, capsys, monkeypatch, extra, expected):
    import fitlab.families.lambert_sphere.mc.simulate as sim

    def boom(*a, **k):
        raise AssertionError("simulated with a bad option")

    monkeypatch.setattr(sim, "start_round", boom)
    monkeypatch.setattr(sim, "compile_walk", boom)
    p = _albedo_scene(tmp_path)
    extra = [str(p) if a == "FILE" else a for a in extra]
    assert main(["simulate", str(p), "--quiet"] + extra) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and expected in err[0], err


@pytest.mark.parametrize(
    "name, family", [("garbage.toml", None), ("garbage.json", None), ("garbage.toml", "microfacet_energy")]
)
def test_cli_refuses_binary_garbage_in_one_line_exit_2(tmp_path, capsys, name, family):
    """``fitlab simulate`` on a file that is not UTF-8 text: one line naming the file, exit 2 (it was a raw
    UnicodeDecodeError with exit 1)."""
    p = tmp_path / name
    p.write_bytes(bytes(range(256)) * 4)
    argv = ["simulate", str(p), "--quiet", "--out", str(tmp_path / "o")] + (["--family", family] if family else [])
    assert main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [f"fitlab simulate: error: {p}:1: (file): not a UTF-8 text file (byte 0x80 at offset 128)"], err
    assert not (tmp_path / "o").exists()


def test_one_path_budget_limit_for_every_family_and_the_command_line(tmp_path, capsys):
    """One limit, 2^32 paths per job (fitlab._montecarlo.MAX_PATHS): both families' scene rules and the help
    of --max-paths say it (one rule for both families)."""
    from fitlab._montecarlo import MAX_PATHS
    from fitlab.families.lambert_sphere.mc.scene import LIMITS as SPHERE
    from fitlab.families.microfacet_energy.mc.scene import LIMITS as MICROSURFACE
    from fitlab.families.microfacet_energy.mc.scene import parse_scene as parse_microsurface

    assert MAX_PATHS == 2**32 and SPHERE["max_paths"] == MICROSURFACE["max_paths"] == (1000, MAX_PATHS)
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    assert "(integer in [1000, 2^32])" in " ".join(capsys.readouterr().out.split())
    for limit, ok in ((MAX_PATHS, True), (MAX_PATHS + 1, False)):
        sphere = SCENE.replace("max_paths = 60_000", f"max_paths = {limit}")
        micro = (
            '[[material]]\nkind = "conductor"\ndistribution = "ggx"\nalpha = 0.5\n[incident]\nmu_i = [0.5]\n'
            f"[precision]\ntarget_se = 0.01\nmax_paths = {limit}\n"
        )
        for parse, text in ((parse_scene, sphere), (parse_microsurface, micro)):
            if ok:
                assert parse(text, "s.toml").max_paths == limit
            else:
                with pytest.raises(ValueError, match=r"max_paths: 4294967297 is outside \[1000(\.0)?, 4294967296"):
                    parse(text, "s.toml")


def test_slow_job_projection():
    """The projection behind the warning: the standard error falls as 1/sqrt(N), the job stops at its target or
    its budget, the rest of the paths at the measured rate; None within the bound or without an estimate."""
    from fitlab._montecarlo import SLOW_JOB_SECONDS, slow_job_warning

    assert SLOW_JOB_SECONDS == 3600
    # a target out of reach, the largest budget, 1e6 paths/s: 2^32 paths take 1.2 h
    w = slow_job_warning(20_000, 0.02, 1000.0, 2**32)
    assert w == (
        "standard error 1e+03 x its target after 20000 paths; the target needs about 2e+10 paths, more "
        "than max_paths = 4294967296: the job will stop above its target after 1.2 h more at 1e+06 paths/s "
        "(over the 1 h bound; lower --max-paths or raise --target-se)"
    )
    # reachable, but 1.8e9 paths at 1e5 paths/s: 5 h
    assert slow_job_warning(20_000, 0.2, 300.0, 2**32).endswith(
        "about 1.8e+09 paths: 5 h more at 1e+05 paths/s (over the 1 h bound)"
    )
    assert slow_job_warning(20_000, 0.2, 30.0, 2**32) is None  # 1.8e7 paths: 3 min
    assert slow_job_warning(20_000, 0.02, 1000.0, 10**9) is None  # the budget ends it in 17 min
    # an empty bin above its target has no error estimate: only the budget bounds the job
    assert slow_job_warning(20_000, 0.02, float("inf"), 2**32) == (
        "after 20000 paths a bin is still empty (no error estimate): the job may run to max_paths = 4294967296, "
        "1.2 h more at 1e+06 paths/s (over the 1 h bound)"
    )
    assert slow_job_warning(20_000, 0.02, float("inf"), 10**9) is None
    assert slow_job_warning(20_000, 0.02, float("nan"), 2**32) is None


@pytest.mark.parametrize("family", ["lambert_sphere", "microfacet_energy"])
def test_cli_warns_once_per_job_projected_past_the_bound(tmp_path, capsys, monkeypatch, family):
    """The warning's wiring in the shared runner (fitlab.scenes) with both families' walks, with the bound at
    0 s (every job that has not stopped after its first round is past it): one line per job on stderr, after
    the first round, naming the job."""
    import functools

    import fitlab._montecarlo as mc

    monkeypatch.setattr(mc, "slow_job_warning", functools.partial(mc.slow_job_warning, bound=0.0))
    if family == "lambert_sphere":
        p = _albedo_scene(tmp_path)
        job = "fixed job, material c=0.5 (c = 0.5), mu_i = 0.6"
        budget, batch = "60000", 20_000
    else:
        p = tmp_path / "m.toml"
        p.write_text(
            '[[material]]\nlabel = "white"\nkind = "conductor"\ndistribution = "ggx"\nalpha = 0.5\n'
            "[incident]\nmu_i = [0.5]\n[outgoing]\nmu_o = 2\nphi = 2\n[precision]\ntarget_se = 0.01\n"
            "batch = 1000\nslots = 64\n"
        )
        job = "material white, mu_i = 0.5"
        budget, batch = "3000", 1000
    argv = [
        "simulate",
        str(p),
        "--quiet",
        "--no-plots",
        "--out",
        str(tmp_path / "o"),
        "--max-paths",
        budget,
        "--target-se",
        "1e-9",
        "--allow-unconverged",
    ]
    assert main(argv) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(warnings) == 1, warnings
    assert warnings[0].startswith(f"fitlab simulate: warning: {job}: ")
    assert f"after {batch} paths" in warnings[0] and f"max_paths = {budget}" in warnings[0]


TRUE_SCENE = """\
[scene]
name = "tiny_true"
seed = 9
phase = "true"
[[material]]
c = 0.7
[incident]
mu_i = [0.2]
[outgoing]
mu_o = [0.0, 0.1, 1.0]
fourier = [0, 1, 3]
phi = [0.0, 2.0, 3.141592653589793]
[effects]
list = ["multiple", "phase_difference", "albedo"]
[precision]
target_se = {multiple = 4e-3, phase_difference = 1e-3, albedo = 3e-3}
max_paths = 40_000
batch = 20_000
"""


def _bin_average(f, mu_i, lo, hi, kind, arg):
    """mu_o-weighted bin average of f(mu_i, mu_o, phi): of its Fourier order ``arg`` (kind "m") or over the |phi|
    bin ``arg`` (kind "phi"), by Gauss-Legendre of other orders than the simulation's (40 in mu_o, 96 in phi)."""
    import numpy as np

    x, w = np.polynomial.legendre.leggauss(40)
    mu = lo + (hi - lo) * (x + 1) / 2
    wmu = w * (hi - lo) / 2 * mu
    p_lo, p_hi = (0.0, np.pi) if kind == "m" else arg
    y, v = np.polynomial.legendre.leggauss(96)
    phi = p_lo + (p_hi - p_lo) * (y + 1) / 2
    vphi = v * (p_hi - p_lo) / 2
    vals = f(np.full((mu.size, phi.size), mu_i), mu[:, None] + 0 * phi[None, :], phi[None, :] + 0 * mu[:, None])
    if kind == "m":
        per_mu = (2.0 if arg else 1.0) / np.pi * (vals * (np.cos(arg * phi) * vphi)[None, :]).sum(1)
    else:
        per_mu = (vals * vphi[None, :]).sum(1) / (p_hi - p_lo)
    return float((per_mu * wmu).sum() / wmu.sum())


def test_true_scene_references_are_the_true_half_space(tmp_path):
    """In a scene with the true phase function the references are the true-phase engine's: each BRDF row's ref
    (total and multiple scattering alone) is the bin average of exact.brdf(phase="true") (less its closed-form
    single scattering for the latter; here through the whole BRDF and another quadrature, not the Fourier
    orders the simulation averages), its alt the mixed reference's, the phase_difference rows' ref the true minus
    the three-term half space; the albedos' refs are exact.albedo's; and the MC agrees."""
    import numpy as np

    from fitlab.families.lambert_sphere import exact

    p = tmp_path / "tiny_true.toml"
    p.write_text(TRUE_SCENE)
    result, _ = simulate_file(p, out_dir=tmp_path / "res", progress=False)
    c, mu_i = 0.7, 0.2

    def single(phase):
        p_u = exact.phase_function if phase in ("true", "mixed") else exact.three_term_phase_function

        def f(a, b, ph):
            return c * p_u(-(a * b + np.sqrt((1 - a * a) * (1 - b * b)) * np.cos(ph))) / (a + b)

        return f

    totals = {}  # exact.brdf on one grid, once: the rows' bins share their grids, and ref and scale their values

    def brdf(phase, multiple_only):
        def f(a, b, ph):
            key = (phase, a.tobytes(), b.tobytes(), ph.tobytes())
            if key not in totals:
                totals[key] = exact.brdf(a, b, ph, c, phase=phase)
            total = totals[key]
            return total - single(phase)(a, b, ph) if multiple_only else total

        return f

    # both sides are Gauss rules in mu_o, and the odd orders go like sqrt(1 - mu_o^2) at mu_o = 1, where a Gauss
    # rule converges algebraically: the simulation's 64 nodes and these 40 agree to about 3e-6 of f
    tol = 2e-5
    rows = [
        r
        for e in ("multiple", "phase_difference")
        for r in result.rows[e]
        if r["quantity"] in ("f", "f_ms", "d_f", "d_f_ms")
    ]
    assert len(rows) == 4 * (2 * 3 + 2 * 2)
    gaps = []
    for r in rows:
        kind, arg = ("m", int(r["m"])) if r["m"] != "" else ("phi", (r["phi_lo"], r["phi_hi"]))
        ms = r["quantity"].endswith("_ms")

        def average(phase, r=r, kind=kind, arg=arg, ms=ms):
            return _bin_average(brdf(phase, ms), mu_i, r["mu_lo"], r["mu_hi"], kind, arg)

        true = average("true")
        scale = abs(_bin_average(brdf("true", False), mu_i, r["mu_lo"], r["mu_hi"], kind, arg))
        if r["effect"] == "multiple":
            mixed = average("mixed")
            assert r["ref"] == pytest.approx(true, abs=tol * scale), r
            assert r["alt"] == pytest.approx(mixed, abs=tol * scale), r
            gaps.append(abs(true - mixed) / scale)
        else:
            assert r["ref"] == pytest.approx(true - average("three_term"), abs=tol * scale), r
    assert max(gaps) > 5 * tol  # the check tells the true half space from the mixed reference
    albedos = {
        (r["effect"], r["quantity"]): r
        for e in ("albedo", "phase_difference")
        for r in result.rows[e]
        if r["quantity"] in ("a", "a_ms", "d_a", "d_a_ms")
    }
    a = {ph: float(exact.albedo(mu_i, c, phase=ph)) for ph in ("true", "mixed", "three_term")}
    a1 = {ph: c * float(exact.single_scattering_albedo(mu_i, ph)) for ph in ("true", "three_term")}
    assert albedos["albedo", "a"]["ref"] == pytest.approx(a["true"], rel=1e-12)
    assert albedos["albedo", "a"]["alt"] == pytest.approx(a["mixed"], rel=1e-12)
    assert albedos["albedo", "a_ms"]["ref"] == pytest.approx(a["true"] - a1["true"], rel=1e-9)
    assert albedos["phase_difference", "d_a"]["ref"] == pytest.approx(a["true"] - a["three_term"], rel=1e-9)
    assert albedos["phase_difference", "d_a_ms"]["ref"] == pytest.approx(
        a["true"] - a1["true"] - a["three_term"] + a1["three_term"], rel=1e-9, abs=1e-14
    )
    zs = [r["z_ref"] for e in result.rows.values() for r in e if r["se"] > 0 and np.isfinite(r["z_ref"])]
    assert len(zs) > 20 and max(abs(z) for z in zs) < 4


def test_every_core_becomes_a_jax_device_before_jax_starts(monkeypatch):
    """``use_every_core`` adds the host device count to XLA_FLAGS only while JAX is not imported, keeps the
    user's other flags and the user's own count, and does nothing on one core."""
    from fitlab._montecarlo import HOST_DEVICES_FLAG, use_every_core

    env = {"XLA_FLAGS": "--xla_cpu_enable_fast_math=false"}
    assert not use_every_core(env, cores=4)  # JAX is imported in this process: its devices are fixed
    assert env == {"XLA_FLAGS": "--xla_cpu_enable_fast_math=false"}
    monkeypatch.delitem(sys.modules, "jax")
    assert use_every_core(env, cores=4)
    assert env["XLA_FLAGS"] == f"--xla_cpu_enable_fast_math=false {HOST_DEVICES_FLAG}=4"
    assert not use_every_core(env, cores=8)  # a count already set is the user's
    assert env["XLA_FLAGS"].endswith("=4")
    empty = {}
    assert not use_every_core(empty, cores=1) and empty == {}
    assert use_every_core(empty, cores=2) and empty == {"XLA_FLAGS": f"{HOST_DEVICES_FLAG}=2"}


LARGE_SCENE = """
[scene]
family = "lambert_sphere"
name = "large"
seed = 1
phase = "three_term"
[[material]]
c = 0.999
[incident]
mu_i = [0.7]
[outgoing]
mu_o = 4
fourier = [0]
[effects]
list = ["multiple"]
[precision]
target_se = 1e-6
max_paths = 4294967296
batch = 10_000_000
max_collisions = 100_000_000
"""


@pytest.mark.e2e
def test_ctrl_c_stops_a_large_scene_and_its_cost_is_said_first(tmp_path):
    """A scene within every limit (c = 0.999, batch 1e7, max_collisions 1e8; minutes a round on a CPU): before
    its first round, one line with the pilot's estimate; Ctrl-C then ends it with exit status 130 and one
    line, nothing written (before: no word after 300 s, and Ctrl-C at 25 s was ignored for 125 s).  The
    bound on the exit is a hang check, far above the 0.25 s chunks."""
    import os
    import select
    import signal
    import subprocess
    import time

    scene = tmp_path / "large.toml"
    scene.write_text(LARGE_SCENE)
    proc = subprocess.Popen(
        [sys.executable, "-m", "fitlab", "simulate", str(scene), "--out", str(tmp_path / "out")],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=dict(os.environ),
    )
    seen, deadline = b"", time.monotonic() + 240
    while b"a pilot estimates" not in seen and time.monotonic() < deadline and proc.poll() is None:
        if select.select([proc.stderr], [], [], 1.0)[0]:
            seen += os.read(proc.stderr.fileno(), 65536)
    assert b"a pilot estimates" in seen, seen[-2000:]
    time.sleep(1.0)  # within the first round
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    waited = time.monotonic() - sent
    lines = [x for x in (seen + err).decode().replace("\r", "\n").splitlines() if x.startswith("fitlab")]
    assert proc.returncode == 130 and waited < 60, (proc.returncode, waited, lines)
    assert len(lines) == 2 and "Ctrl-C stops it" in lines[0] and lines[1] == "fitlab simulate: interrupted", lines
    assert out == b"" and not (tmp_path / "out").exists()
