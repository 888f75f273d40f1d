"""The Monte Carlo random walk against the exact engine, identities, and layout independence.

Small path counts, fixed seeds.  Agreement means |MC - exact| < 4 standard
errors per point, plus a chi-square over all points of a test.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import fitlab  # noqa: F401
from fitlab.families.lambert_sphere.exact import (
    albedo,
    brdf_modes,
    multiple_scattering_modes,
    single_scattering_albedo,
    spherical_albedo,
    three_term_phase_function,
)
from fitlab.families.lambert_sphere.mc.transport import WalkConfig, run_round

EDGES = (0.0, 0.25, 0.5, 0.75, 1.0)
FOURIER = WalkConfig(phase="three_term", mu_edges=EDGES, orders=(0, 1, 2))
ROOT = Path(__file__).resolve().parents[1]


def _mean_se(total, sq, n):
    m = total / n
    return m, np.sqrt(np.maximum(sq / n - m * m, 0) / (n - 1))


def _bin_average(fn, mu_i, c, a, b):
    """mu_o-weighted bin average of the three modes of fn (Gauss-Legendre, 64 nodes)."""
    x, w = np.polynomial.legendre.leggauss(64)
    mu = a + (b - a) * (x + 1) / 2
    wmu = w * (b - a) / 2 * mu
    return np.array(fn(np.full_like(mu, mu_i), mu, c)) @ wmu / wmu.sum()


def _ss_modes_eq10(mu_i, c, a, b):
    """Fourier orders of c p3(u)/(mu_i + mu_o), bin-averaged, by quadrature of eq. 10 itself."""
    x, w = np.polynomial.legendre.leggauss(64)
    mu = a + (b - a) * (x + 1) / 2
    wmu = w * (b - a) / 2 * mu
    y, v = np.polynomial.legendre.leggauss(64)
    phi = np.pi * (y + 1) / 2
    vphi = v * np.pi / 2
    s = np.sqrt((1 - mu_i**2) * (1 - mu**2))[:, None]
    f = c * three_term_phase_function(-(mu_i * mu[:, None] + s * np.cos(phi))) / (mu_i + mu[:, None])
    out = [
        ((2.0 if m else 1.0) / np.pi * (f * np.cos(m * phi) * vphi).sum(1) * wmu).sum() / wmu.sum() for m in range(3)
    ]
    return np.array(out)


# c values shared with the other MC tests: each new c costs the exact engine seconds
POINTS = [(0.5, 0.3, 60_000), (0.5, 0.85, 60_000), (0.99, 0.5, 40_000), (0.99, 0.15, 40_000)]


@pytest.fixture(scope="module")
def fourier_runs():
    return {(c, mu_i): run_round(FOURIER, 11, (k,), c, mu_i, n) for k, (c, mu_i, n) in enumerate(POINTS)}


def test_multiple_scattering_modes_agree_with_exact(fourier_runs):
    """MC f_ms^m (orders 0-2, 4 mu_o bins) vs multiple_scattering_modes, c = 0.5 and 0.99."""
    zs = []
    for (c, mu_i), r in fourier_runs.items():
        n = r["photons"]
        for b, (a, bb) in enumerate(zip(EDGES[:-1], EDGES[1:])):
            exact = _bin_average(multiple_scattering_modes, mu_i, c, a, bb)
            for m in range(3):
                norm = np.pi * (2 if m == 0 else 1) * (bb * bb - a * a) / 2
                est, se = _mean_se(r["fourier"][b, 0, m], r["fourier_sq"][b, 0, m], n)
                z = (est / norm - exact[m]) / (se / norm)
                zs.append(z)
                assert abs(z) < 4, (c, mu_i, b, m, est / norm, exact[m], se / norm)
    zs = np.array(zs)
    # 48 z-scores: their mean square is ~1 (chi-square 48 dof: < 1.7 with probability 0.998)
    assert np.mean(zs**2) < 1.7, np.mean(zs**2)


def test_total_modes_agree_with_brdf_modes(fourier_runs):
    """Eq. 10 (quadrature, three-term p) + MC multiple scattering vs brdf_modes; order 1 also
    against the printed normalisation (6 pi), which it must reject."""
    for (c, mu_i), r in fourier_runs.items():
        n = r["photons"]
        for b, (a, bb) in enumerate(zip(EDGES[:-1], EDGES[1:])):
            exact = _bin_average(brdf_modes, mu_i, c, a, bb)
            ss = _ss_modes_eq10(mu_i, c, a, bb)
            for m in range(3):
                norm = np.pi * (2 if m == 0 else 1) * (bb * bb - a * a) / 2
                est, se = _mean_se(r["fourier"][b, 0, m], r["fourier_sq"][b, 0, m], n)
                total = ss[m] + est / norm
                assert abs(total - exact[m]) < 4 * se / norm
                if m == 1 and b > 0:
                    assert abs(total - exact[m] / 2) > 8 * se / norm  # printed eq. 22 is rejected


def test_directional_albedo_agrees_with_exact(fourier_runs):
    for (c, mu_i), r in fourier_runs.items():
        est, se = _mean_se(r["escape"][0], r["escape_sq"][0], r["photons"])
        total = c * single_scattering_albedo(mu_i, "three_term") + est
        assert abs(total - float(albedo(mu_i, c, "three_term"))) < 4 * se
        assert r["n_capped"] == 0


def test_spherical_albedo_agrees_with_exact():
    from fitlab.families.lambert_sphere.mc.effects import single_spherical_albedo

    cfg = WalkConfig(phase="three_term", incidence="cosine")
    for k, c in enumerate((0.5,)):  # c = 0.99: in the pooled test below, at 250 000 photons
        r = run_round(cfg, 4, (k,), c, 0.0, 40_000)
        est, se = _mean_se(r["escape"][0], r["escape_sq"][0], r["photons"])
        assert abs(c * single_spherical_albedo("three_term") + est - float(spherical_albedo(c, "three_term"))) < 4 * se


def test_collision_orders_add_up_and_order_two_dominates():
    cfg = WalkConfig(phase="three_term", mu_edges=EDGES, collision_orders=5)
    r = run_round(cfg, 2, (0,), 0.7, 0.6, 20_000)
    np.testing.assert_allclose(r["coll"][:, 0].sum(), r["escape"][0], rtol=1e-12)
    # the mu_o bins cover [0, 1]: per order, the bins add up to the order's escapes
    np.testing.assert_allclose(r["coll_f0"][:, :, 0].sum(1), r["coll"][:, 0], rtol=1e-12)
    assert np.all(np.diff(r["coll"][:-1, 0]) < 0)  # fewer escapes after more collisions at c = 0.7


def test_energy_conservation_at_c1_with_the_cap_counted():
    """c = 1: nothing is absorbed, so escapes after >= 2 collisions + weight stopped by the
    cap = 1 - single-scattering albedo, for either phase function (p3 integrates to 1 too).
    A small cap cuts a large tail; the identity holds only because the tail is tallied."""
    for k, (phase, cap) in enumerate((("true", 20), ("true", 2000), ("both", 300))):
        cfg = WalkConfig(phase=phase, max_collisions=cap)
        # 'both' at c = 1 has an infinite variance (refused by default): only the cap bounds it
        r = run_round(cfg, 9, (k,), 1.0, 0.4, 10_000, unbounded_ok=phase == "both")
        n = r["photons"]
        tracks = [("true", 0)] if phase == "true" else [("true", 0), ("three_term", 1)]
        for model, t in tracks:
            # per photon the escape and the capped weight exclude each other: add sums and squares
            est, se = _mean_se(r["escape"][t] + r["capped"][t], r["escape_sq"][t] + r["capped_sq"][t], n)
            assert abs(est + single_scattering_albedo(0.4, model) - 1.0) < 4 * se, (phase, cap, model, est, se)
        if cap == 20:
            assert r["n_capped"] > 0.15 * n  # a quarter of the photons are stopped by the cap
        if phase == "both":
            # true - three-term on correlated paths: the same identity, with a tiny error
            est, se = _mean_se(r["escape"][2] + r["capped"][2], r["escape_sq"][2] + r["capped_sq"][2], n)
            ss = single_scattering_albedo(0.4, "true") - single_scattering_albedo(0.4, "three_term")
            assert abs(est + ss) < 4 * se
            assert se < 0.5 * _mean_se(r["escape"][0], r["escape_sq"][0], n)[1]  # 3.8x smaller at c = 1, cap 300


def test_both_mode_three_term_track_agrees_with_exact():
    cfg = WalkConfig(phase="both")
    r = run_round(cfg, 3, (0,), 0.99, 0.5, 20_000)
    assert r["n_capped"] == 0
    est, se = _mean_se(r["escape"][1], r["escape_sq"][1], r["photons"])
    assert (
        abs(0.99 * single_scattering_albedo(0.5, "three_term") + est - float(albedo(0.5, 0.99, "three_term"))) < 4 * se
    )
    # correlated paths: the difference has a far smaller error than either track (9x at c = 0.99)
    assert _mean_se(r["escape"][2], r["escape_sq"][2], r["photons"])[1] < 0.2 * se


def test_eq6_sampler_runs_and_agrees_within_errors():
    cfg_a = WalkConfig(phase="true", sampler="approx", max_collisions=300)
    cfg_e = WalkConfig(phase="true", max_collisions=300)
    ra = run_round(cfg_a, 5, (0,), 0.9, 0.5, 20_000)
    re = run_round(cfg_e, 5, (1,), 0.9, 0.5, 20_000)
    ma, sa = _mean_se(ra["escape"][0], ra["escape_sq"][0], ra["photons"])
    me, se = _mean_se(re["escape"][0], re["escape_sq"][0], re["photons"])
    assert abs(ma - me) < 4 * np.hypot(sa, se)


@pytest.mark.parametrize("c, mu_i", [(0.9, 0.5), (0.3, 0.05), (1.0, 1.0)])
def test_float32_walk_is_the_float64_walk_to_its_rounding(c, mu_i):
    """The float32 walk (the default) against the float64 one on the same key: the same photons, whose uniforms
    differ only in their last 9 of 32 bits, so the escaping weight agrees to 1e-6 relative (measured 1e-7 to
    1e-9), far below any standard error a round of photons reaches (1e-3 for 1e5 photons); a discrete
    decision (roulette, escape, the mu_o bin of an escape) flips rarely: at c = 1, mu_i = 1, where paths run
    to thousands of collisions, a few of 20000 photons (the m = 0 tallies' differences add up to 2.6 photon
    weights: two or three photons leave in a neighbouring mu_o bin), and the Fourier tallies agree to 1e-6
    per photon where none flips."""
    n = 20_000
    cfg = {p: WalkConfig(phase="true", mu_edges=EDGES, orders=(0, 1, 2), precision=p) for p in ("float32", "float64")}
    f32, f64 = (run_round(cfg[p], 3, (1,), c, mu_i, n) for p in ("float32", "float64"))
    assert abs(f32["escape"][0] / f64["escape"][0] - 1) < 1e-6
    if c < 1:
        assert f32["collisions"] == f64["collisions"]
        assert np.abs(f32["fourier"] - f64["fourier"]).max() / n < 1e-6
    else:
        assert abs(int(f32["collisions"]) - int(f64["collisions"])) < 1e-5 * int(f64["collisions"])
        moved = np.abs(f32["fourier"][..., 0] - f64["fourier"][..., 0]).sum() / 2  # weights of photons moved
        assert moved <= 5 and np.abs(f32["fourier"] - f64["fourier"]).max() <= 5  # a few photons (weights <= 1)
    assert f32["fourier"].dtype == np.float64  # tallies accumulate in float64 whatever the walk's precision


def test_a_round_in_chunks_of_any_size_gives_the_same_tallies(fourier_runs):
    """start_round's round run in chunks of 1, 7, 3, 50 and 2 loop steps (what fitlab simulate does, sized by
    time, so that Ctrl-C is answered between two) gives the tallies of the round run at once, bit for bit,
    through both slot levels (1024 slots per device, then 128 for the last photons)."""
    from fitlab.families.lambert_sphere.mc.transport import start_round

    rnd = start_round(FOURIER, 11, (2,), 0.99, 0.5, 40_000)
    sizes, chunks, levels = [1, 7, 3, 50, 2], 0, set()
    while not rnd.advance(sizes[chunks % 5]):
        chunks, levels = chunks + 1, levels | {rnd.level}
    levels.add(rnd.level)
    chunked, whole = rnd.tallies(), fourier_runs[(0.99, 0.5)]
    assert chunks > 100 and levels == {0, 1} and rnd.finished == 40_000
    assert set(chunked) == set(whole) and all(np.array_equal(chunked[k], whole[k]) for k in whole)


def test_walk_precision_is_checked():
    with pytest.raises(ValueError, match="precision"):
        WalkConfig(precision="float16")


def test_reproducible_and_independent_of_slots(fourier_runs):
    again = run_round(FOURIER, 11, (0,), 0.5, 0.3, 60_000)
    other = run_round(
        WalkConfig(phase="three_term", mu_edges=EDGES, orders=(0, 1, 2), slots=64), 11, (0,), 0.5, 0.3, 60_000
    )
    first = fourier_runs[(0.5, 0.3)]
    for k in ("fourier", "fourier_sq", "escape", "photons", "collisions"):
        np.testing.assert_array_equal(again[k], first[k])
        np.testing.assert_allclose(other[k], first[k], rtol=1e-12, atol=1e-12)
    diff = run_round(FOURIER, 12, (0,), 0.5, 0.3, 60_000)
    assert diff["collisions"] != first["collisions"]


_SHARD_SCRIPT = """
import json, sys, numpy as np, jax
import fitlab
from fitlab.families.lambert_sphere.mc.transport import WalkConfig, run_round
cfg = WalkConfig(phase="both", mu_edges=(0.0, 0.5, 1.0), orders=(0, 1), phi_edges=(0.0, 1.0, 3.14159),
                 collision_orders=4, slots=64)
r = run_round(cfg, 7, (3,), 0.95, 0.3, 5_001)
print(json.dumps({"devices": jax.device_count(), **{k: np.asarray(v).tolist() for k, v in r.items() if k != "steps"}}))
"""


def _run_sharded(ndev):
    env = dict(
        os.environ,
        XLA_FLAGS=f"--xla_force_host_platform_device_count={ndev}",
        JAX_PLATFORMS="cpu",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    out = subprocess.run(
        [sys.executable, "-c", _SHARD_SCRIPT], env=env, capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.e2e
def test_sharded_over_four_host_devices_gives_the_same_tallies():
    """A 1-D mesh over 4 host devices (XLA_FLAGS): each device runs its id range; the
    tallies equal the one-device run up to the order of summation."""
    one, four = _run_sharded(1), _run_sharded(4)
    assert one["devices"] == 1 and four["devices"] == 4
    for k in one:
        if k == "devices":
            continue
        np.testing.assert_allclose(np.array(four[k]), np.array(one[k]), rtol=1e-12, atol=1e-9, err_msg=k)
    assert four["photons"] == 5_001


# The pooled accuracy test: the multiple-scattering albedo at c = 0.99 (where a weight error per
# collision adds up over ~40 collisions) at two fixed mu_i and for cosine incidence, 250 000
# photons each.  Relative standard error per point ~0.13 %, pooled ~0.08 %: a 0.5 % bias is
# over 6 pooled standard errors and fails the 4-sigma bound with probability ~0.98.
POWER_POINTS = (0.15, 0.5, "cosine")
POWER_C, POWER_PATHS = 0.99, 250_000


def test_pooled_albedo_has_the_power_to_see_a_half_percent_bias():
    from fitlab.families.lambert_sphere.mc.effects import single_spherical_albedo

    rel, rel_se, zs = [], [], []
    for k, mu_i in enumerate(POWER_POINTS):
        if mu_i == "cosine":
            r = run_round(WalkConfig(phase="three_term", incidence="cosine"), 21, (k,), POWER_C, 0.0, POWER_PATHS)
            exact = float(spherical_albedo(POWER_C, "three_term")) - POWER_C * single_spherical_albedo("three_term")
        else:
            r = run_round(WalkConfig(phase="three_term"), 21, (k,), POWER_C, mu_i, POWER_PATHS)
            exact = float(albedo(mu_i, POWER_C, "three_term")) - POWER_C * single_scattering_albedo(mu_i, "three_term")
        assert r["n_capped"] == 0
        est, se = _mean_se(r["escape"][0], r["escape_sq"][0], r["photons"])
        rel.append(est / exact - 1.0)
        rel_se.append(se / exact)
        zs.append((est - exact) / se)
    rel, rel_se, zs = np.array(rel), np.array(rel_se), np.array(zs)
    wts = 1.0 / rel_se**2
    pooled, pooled_se = float(np.sum(wts * rel) / np.sum(wts)), float(np.sum(wts) ** -0.5)
    # the test keeps its power: a 0.5 % bias is at least 5 pooled standard errors
    assert pooled_se < 0.001, pooled_se
    assert abs(pooled) < 4 * pooled_se, (pooled, pooled_se, zs)
    # and no single point is off, in either direction (chi-square, 3 dof: P(> 21.1) = 1e-4)
    assert np.sum(zs**2) < 21.1, zs


def test_c_above_one_over_n_is_refused_for_the_three_term_walk():
    """The three-term walk's weights have modulus (c N)^n: bounded by 1 up to c = 1/N, with an
    infinite mean and variance beyond (the analysis in docs/montecarlo.md); just below 1/N the
    estimate is right, above it run_round refuses before any work."""
    from fitlab.families.lambert_sphere.mc.phase_sampling import C_LIMIT, THREE_TERM_NORM

    assert C_LIMIT["three_term"] == pytest.approx(1 / THREE_TERM_NORM, rel=1e-15)
    with pytest.raises(ValueError, match="infinite mean and variance"):
        run_round(WalkConfig(phase="three_term"), 1, (0,), 1.0, 0.5, 1000)
    with pytest.raises(ValueError, match="variance is infinite"):
        run_round(WalkConfig(phase="both"), 1, (0,), 0.999, 0.5, 1000)
    run_round(WalkConfig(phase="true", max_collisions=2000), 1, (0,), 1.0, 0.5, 100)  # weights c^n <= 1
    c = 0.9994  # < 1/N = 0.999473: c N = 0.99993, every weight <= 1
    r = run_round(WalkConfig(phase="three_term"), 23, (0,), c, 0.5, 4_000)
    n = r["photons"]
    est, se = _mean_se(r["escape"][0], r["escape_sq"][0], n)
    assert r["escape_sq"][0] <= n  # |weight| <= 1 per photon
    exact = float(albedo(0.5, c, "three_term")) - c * single_scattering_albedo(0.5, "three_term")
    assert abs(est - exact) < 4 * se, (est, exact, se)
