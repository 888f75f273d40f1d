"""The microsurface random walk (Heitz et al. 2016) against independent references and identities.

Small budgets: each compiled walk configuration costs a few seconds; the configurations are shared
through module fixtures.  Every comparison is between two independent computations (the walk against
deterministic quadratures of the analytic single scattering or the exact engine's E), or an identity
that holds path by path.

Lobe bins are judged by the binomial p-value of their count (``simulate.count_p_value``, as the dielectric
tests do), against Sidak's threshold for the number of bins a test judges, so that all of a test's bins pass
with probability 1 - FAMILY_P under a right reference; z with a sample standard error misleads in bins few
paths reach (8.2 expected, 2 held: z = -4.4 for p = 0.024).  Totals, which hold many paths, keep z.  Each
bin test also asserts its power: the same criterion rejects a deliberately wrong reference."""

from __future__ import annotations

import math
from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from fitlab.core import float64
from fitlab.families.microfacet_energy.exact import directional_albedo, fresnel_conductor, fresnel_schlick, ggx_brdf
from fitlab.families.microfacet_energy.mc import parse_scene, simulate
from fitlab.families.microfacet_energy.mc.microsurface import sample_vndf, smith_lambda
from fitlab.families.microfacet_energy.mc.reference import bin_average_single, ndf, single_scattering_brdf
from fitlab.families.microfacet_energy.mc.simulate import count_p_value, job_config
from fitlab.families.microfacet_energy.mc.walk import MaterialParams, job_key, run_round
from fitlab.families.microfacet_energy.mc.walk_fresnel import fresnel_factor

Z_MAX = 4.0


def _scene(materials: str, mu_i="[0.5]", max_paths=200_000, target=1e-9, mu_o=4, phi=4, orders=3) -> str:
    return f"""
[scene]
name = "t"
seed = 7
{materials}
[incident]
mu_i = {mu_i}
[outgoing]
mu_o = {mu_o}
phi = {phi}
orders = {orders}
[precision]
target_se = {target}
max_paths = {max_paths}
batch = {max_paths}
"""


WHITE_GGX = """
[[material]]
label = "white"
kind = "conductor"
distribution = "ggx"
alpha = 0.6
[[material]]
label = "aniso"
kind = "conductor"
distribution = "ggx"
alpha_x = 0.3
alpha_y = 0.8
"""


@pytest.fixture(scope="module")
def white_ggx():
    return simulate(parse_scene(_scene(WHITE_GGX, mu_i="[0.3, 0.8]")))


#: the chance that some bin of a test fails although the walk and its reference are right: that of the dielectric
#: tests' per-bin threshold 6.3e-5 (a two-sided 4-sigma deviation) over their 64 bins
FAMILY_P = 4e-3


def p_min(bins: int) -> float:
    """Sidak's per-bin threshold: with ``bins`` independent bins each at least this likely under a right reference
    with probability 1 - p, all of them are with probability 1 - FAMILY_P."""
    return -math.expm1(math.log1p(-FAMILY_P) / bins)


def _lobe_bins(rows):
    return [r for r in rows if "_s1" in r]


def _failing_bins(rows, reference=None) -> list:
    """The lobe bins of ``rows`` whose count is less likely than p_min(number of bins) under their reference
    (``simulate.count_p_value``: the binomial tail of the bin's count, calibrated where few paths land, empty bins
    included), or under ``reference(row)`` when given."""
    lobes = _lobe_bins(rows)
    threshold = p_min(len(lobes))
    out = []
    for r in lobes:
        p = count_p_value(r if reference is None else dict(r, reference=reference(r)))
        if not p >= threshold:
            out.append((p, r))
    return out


def _assert_agrees(rows):
    """Every lobe bin's count at least p_min(bins) likely under its reference (:func:`_failing_bins`); every
    other row (totals, which hold many paths: z is normal there) within Z_MAX standard errors."""
    for r in rows:
        assert math.isfinite(r["reference"]), r
    assert not _failing_bins(rows), _failing_bins(rows)[:3]
    totals = [r for r in rows if "_s1" not in r]
    for r in totals:
        assert r["se"] > 0.0 and abs(r["z_ref"]) < Z_MAX, r


def _rejects(rows, reference, material) -> bool:
    """Whether the bins of ``material`` fail (:func:`_failing_bins`, over all of ``rows``' bins) when its
    reference is ``reference(row)`` and the other materials keep theirs."""
    swapped = lambda r: reference(r) if r["material"] == material else r["reference"]  # noqa: E731
    return any(r["material"] == material for _, r in _failing_bins(rows, swapped))


def _bin_of(scene, row) -> tuple:
    return (int(np.searchsorted(scene.mu_edges, row["mu_lo"])), int(np.searchsorted(scene.phi_edges, row["phi_lo"])))


def _wrong_alpha(result, factor=1.05):
    """The reference of every order-1 lobe bin with the material's alpha (both axes) scaled by ``factor``."""
    scene = result.scene
    cache = {}

    def reference(row):
        key = (row["material"], row["mu_i"])
        if key not in cache:
            mat = next(m for m in scene.materials if m.label == row["material"])
            wrong = replace(mat, alpha_x=mat.alpha_x * factor, alpha_y=mat.alpha_y * factor)
            cache[key] = bin_average_single(scene.mu_edges, scene.phi_edges, row["mu_i"], wrong)
        return cache[key][_bin_of(scene, row)]

    return reference


def _separable_g2(result, nodes=24):
    """The reference of every order-1 lobe bin of an isotropic GGX material with F = 1 and the separable G2 =
    G1(mu_i) G1(mu_o) (the exact engine's ggx_brdf) in place of the height-correlated one: tensor Gauss-Legendre
    over each bin (a smooth integrand for the alphas used here; with the correlated G2 it gives the reference's
    bin averages to 1e-6)."""
    scene = result.scene
    x, w = np.polynomial.legendre.leggauss(nodes)
    cache = {}

    def reference(row):
        key = (row["material"], row["mu_i"])
        if key not in cache:
            alpha = next(m for m in scene.materials if m.label == row["material"]).alpha_x
            mu_e, phi_e = np.asarray(scene.mu_edges), np.asarray(scene.phi_edges)
            out = np.zeros((mu_e.size - 1, phi_e.size - 1))
            for i in range(out.shape[0]):
                mu = (mu_e[i] + mu_e[i + 1]) / 2 + (mu_e[i + 1] - mu_e[i]) / 2 * x
                for j in range(out.shape[1]):
                    ph = (phi_e[j] + phi_e[j + 1]) / 2 + (phi_e[j + 1] - phi_e[j]) / 2 * x
                    m, p = np.meshgrid(mu, ph, indexing="ij")
                    f = ggx_brdf(m, row["mu_i"], p, alpha, smith="separable") * m
                    out[i, j] = np.einsum("i,j,ij->", w, w, f) / 4  # the mean over the bin: weights sum to 4
            cache[key] = out
        return cache[key][_bin_of(scene, row)]

    return reference


def _rows(result, quantity, material=None, order=None):
    return [
        r
        for r in result.rows
        if r["quantity"] == quantity
        and (material is None or r["material"] == material)
        and (order is None or r["order"] == order)
    ]


def test_order_one_lobe_is_height_correlated_single_scattering(white_ggx):
    """Order 1 bin by bin (64 bins: isotropic and anisotropic GGX, mu_i 0.3 and 0.8) against the single-scattering
    BRDF with height-correlated G2, each bin's count judged by its binomial p-value against Sidak's threshold
    for 64 bins.  Power, asserted: the same criterion rejects the reference with alpha 5 % too large (and too
    small), and, for the isotropic material, the one with the separable G2."""
    rows = _rows(white_ggx, "lobe", order="1")
    assert len(rows) == 2 * 2 * 16
    _assert_agrees(rows)
    for factor in (1.05, 1 / 1.05):
        for material in ("white", "aniso"):
            assert _rejects(rows, _wrong_alpha(white_ggx, factor), material), (factor, material)
    assert _rejects(rows, _separable_g2(white_ggx), "white")


def test_white_conductor_conserves_energy_path_by_path(white_ggx):
    for t in white_ggx.tallies.values():
        # F = 1: every path carries weight 1 and ends exactly once, escaped (some order) or capped
        assert np.sum(t["albedo"]) + t["capped"] == t["paths"]
        assert np.sum(t["lobe"]) == np.sum(t["albedo"])  # the bins cover the hemisphere
        assert np.sum(t["transmission"]) == 0.0
    for r in _rows(white_ggx, "albedo_total"):
        assert r["estimate"] == 1.0 and abs(r["z_ref"]) < Z_MAX or r["se"] == 0.0


def test_multiple_scattering_albedo_is_one_minus_e(white_ggx):
    for r in _rows(white_ggx, "albedo", material="white", order="1"):
        e = float(directional_albedo(r["mu_i"], 0.6, "ggx_correlated"))
        assert abs(r["estimate"] - e) < Z_MAX * r["se"]
    for r in _rows(white_ggx, "albedo_multiple", material="white"):
        e = float(directional_albedo(r["mu_i"], 0.6, "ggx_correlated"))
        assert abs(r["estimate"] - (1.0 - e)) < Z_MAX * r["se"]
        assert r["estimate"] > 10 * r["se"]  # a real multiple-scattering signal, not noise


def test_anisotropic_order_one_albedo_against_quadrature(white_ggx):
    for r in _rows(white_ggx, "albedo", material="aniso", order="1"):
        assert r["reference_method"] == "bin_quadrature" and abs(r["z_ref"]) < Z_MAX


def test_reproducible_and_independent_of_batch_split(white_ggx):
    cfg = job_config(white_ggx.scene, white_ggx.scene.materials[0])  # compiled already
    key, params = job_key(3, 0, 0), MaterialParams(0.6, 0.6)
    whole = run_round(cfg, key, params, 0.5, 0, 30_000)
    again = run_round(cfg, key, params, 0.5, 0, 30_000)
    parts = [run_round(cfg, key, params, 0.5, lo, 10_000) for lo in (0, 10_000, 20_000)]
    for name in whole:
        assert np.array_equal(whole[name], again[name])
        # F = 1: the tallies are counts, exact in float64 whatever the order of summation
        assert np.array_equal(whole[name], sum(p[name] for p in parts)), name
    other = run_round(cfg, job_key(4, 0, 0), params, 0.5, 0, 30_000)
    assert not np.array_equal(whole["lobe"], other["lobe"])


DIFFUSE = """
[[material]]
label = "diffuse"
kind = "diffuse"
distribution = "ggx"
alpha = 0.6
"""


def test_diffuse_facets_conserve_energy_and_weigh_albedo_per_order():
    scene = parse_scene(_scene(DIFFUSE, max_paths=20_000))
    cfg = job_config(scene, scene.materials[0])  # one compilation for both parts of the test
    key = job_key(5, 0, 0)
    white = run_round(cfg, key, MaterialParams(0.6, 0.6, albedo=1.0), 0.5, 0, 50_000)
    grey = run_round(cfg, key, MaterialParams(0.6, 0.6, albedo=0.5), 0.5, 0, 50_000)
    assert np.sum(white["albedo"]) + white["capped"] == white["paths"]
    assert white["albedo"][1] > 0.1 * white["paths"]
    # the path does not depend on the weight: order n carries albedo^n exactly
    for k in range(3):
        np.testing.assert_allclose(grey["albedo"][k], 0.5 ** (k + 1) * white["albedo"][k], rtol=1e-12)
    res = simulate(scene)
    total = _rows(res, "albedo_total")[0]
    assert total["estimate"] == 1.0 and total["reference"] == 1.0


FRESNEL_AND_BECKMANN = """
[[material]]
label = "gold"
kind = "conductor"
distribution = "ggx"
alpha = 0.5
fresnel = "conductor"
eta = 0.2
k = 3.0
[[material]]
label = "beckmann"
kind = "conductor"
distribution = "beckmann"
alpha = 0.5
"""


def test_fresnel_conductor_and_beckmann_order_one():
    """Order 1 of a gold-like GGX conductor (a Fresnel weight per path: count_p_value takes the bin's count as
    S1 / w with the weight w = S2 / S1, exact for constant weights) and of an F = 1 Beckmann conductor, bin by bin
    (32 bins, mu_i = 0.5, Sidak's threshold for 32) and in total (z).  Power, asserted: the same criterion rejects
    each material's reference with alpha 5 % too large or too small.  The gold's with the separable G2 is beyond
    this budget (1e5 paths; its worst bin has p = 8e-4, |z| = 3.3, which z < 4 did not reject either)."""
    res = simulate(parse_scene(_scene(FRESNEL_AND_BECKMANN, max_paths=100_000)))
    lobes = _rows(res, "lobe", order="1")
    assert len(lobes) == 2 * 16
    _assert_agrees(
        lobes + _rows(res, "albedo", material="gold", order="1") + _rows(res, "albedo", material="beckmann", order="1")
    )
    for factor in (1.05, 1 / 1.05):
        for material in ("gold", "beckmann"):
            assert _rejects(lobes, _wrong_alpha(res, factor), material), (factor, material)
    gold = _rows(res, "albedo_total", material="gold")[0]
    assert 0.0 < gold["estimate"] < 1.0 and math.isnan(gold["reference"])


@float64
def test_fresnel_functions_agree_with_the_exact_engine():
    """The walk's Fresnel factors are fitlab.physics.fresnel's in JAX: the exact engine's numpy values."""
    c = np.linspace(0.0, 1.0, 101)
    for eta, k in ((0.2, 3.0), (1.5, 0.0), (2.5, 1.2)):
        walk = np.asarray(fresnel_factor("conductor", jnp.asarray(c), 0.0, eta, k))
        np.testing.assert_allclose(walk, fresnel_conductor(c, eta, k), rtol=1e-14, atol=1e-16)
    walk = np.asarray(fresnel_factor("schlick", jnp.asarray(c), 0.3, 1.0, 0.0))
    np.testing.assert_allclose(walk, fresnel_schlick(c, 0.3), rtol=1e-14)


def test_reference_brdf_agrees_with_exact_ggx():
    mu_o, phi = np.meshgrid(np.linspace(0.05, 1.0, 9), np.linspace(0.0, math.pi, 7))
    for mu_i, alpha in ((0.3, 0.2), (0.8, 0.9)):
        ours = single_scattering_brdf(mu_o, phi, mu_i, alpha, alpha, "ggx")
        np.testing.assert_allclose(ours, ggx_brdf(mu_o, mu_i, phi, alpha, smith="correlated"), rtol=1e-12)


def _sphere_rule(n=400):
    """Gauss-Legendre nodes on the upper hemisphere of normals (m_z = cos theta in (0, 1), azimuth)."""
    x, w = np.polynomial.legendre.leggauss(n)
    mz, wz = (x + 1) / 2, w / 2
    ph, wp = np.pi * (x + 1), np.pi * w
    MZ, PH = np.meshgrid(mz, ph, indexing="ij")
    s = np.sqrt(1 - MZ * MZ)
    return s * np.cos(PH), s * np.sin(PH), MZ, np.outer(wz, wp)


@pytest.mark.parametrize("distribution", ["ggx", "beckmann"])
@float64
def test_visible_normals_of_a_rising_ray(distribution):
    """wi below the horizon (the walk's -w for a rising ray): the projected area int max(0, wi.m) D dm
    equals wi_z (1 + Lambda(wi)) with Lambda(wi) = -1 - Lambda(-wi), and the sampled m have the
    quadrature's mean of D_wi."""
    ax, ay = 0.5, 0.7
    wi = np.array([0.8, 0.3, -0.3])
    wi /= np.linalg.norm(wi)
    mx, my, mz, w = _sphere_rule()
    dens = np.maximum(0.0, wi[0] * mx + wi[1] * my + wi[2] * mz) * ndf(mx, my, mz, ax, ay, distribution)
    area = np.sum(dens * w)
    lam = float(smith_lambda(jnp.float64(wi[0]), jnp.float64(wi[1]), jnp.float64(wi[2]), ax, ay, distribution))
    assert lam < -1.0
    # the rule is not split along the kink of max(0, wi.m): 1e-4 is its accuracy, far below a wrong Lambda's
    assert area == pytest.approx(wi[2] * (1.0 + lam), rel=1e-4)
    mean = [np.sum(dens * c * w) / area for c in (mx, my, mz)]
    n = 200_000
    u = jax.random.uniform(jax.random.key(11), (2, n), dtype=jnp.float64)
    sample = jax.jit(lambda a, b: sample_vndf(wi[0], wi[1], wi[2], a, b, ax, ay, distribution))(u[0], u[1])
    for k in range(3):
        s = np.asarray(sample[k])
        assert abs(s.mean() - mean[k]) < Z_MAX * s.std() / math.sqrt(n), (k, s.mean(), mean[k])
    dots = wi[0] * np.asarray(sample[0]) + wi[1] * np.asarray(sample[1]) + wi[2] * np.asarray(sample[2])
    assert np.all(dots >= -1e-12)


@pytest.mark.benchmark
def test_throughput_report():
    """Bounces and paths per second of every walk on this machine, the blog's job extrapolated, and the walk
    on every CPU core as forced host devices (``fitlab bench mc --family microfacet_energy``; a report, not
    a timed assertion)."""
    from fitlab.families.microfacet_energy.mc.bench import CASES, bench_mc

    r = bench_mc(quick=False)
    for case in CASES:
        assert r[case]["bounces_per_second"] > 0 and r[case]["bounces_per_path"] > 1.0
    assert r["sharding"]["identical_tallies"]


@pytest.mark.parametrize("distribution, kind", [("ggx", "conductor"), ("ggx", "dielectric"), ("beckmann", "diffuse")])
def test_float32_walk_is_the_float64_walk_to_its_rounding(distribution, kind):
    """The float32 walk (the default) against the float64 one on one job key: the same paths but for the last
    8 of 32 bits of their uniforms, so a discrete decision (escape, reflect or refract, the order) flips only
    where a uniform falls within 2^-24 of its threshold.  In 20000 paths none did for these kinds (and for GGX
    diffuse, Beckmann conductor and dielectric); at most 2 paths may differ, each by its order or side."""
    from fitlab.families.microfacet_energy.mc.walk import MaterialParams, WalkConfig, job_key, run_round

    key, n = job_key(5, 0, 0), 20_000
    runs = {
        p: run_round(
            WalkConfig(distribution=distribution, kind=kind, precision=p),
            key,
            MaterialParams(0.6, 0.6, eta=1.5),
            0.5,
            0,
            n,
        )
        for p in ("float32", "float64")
    }
    f32, f64 = runs["float32"], runs["float64"]
    moved = sum(np.abs(f32[t] - f64[t]).sum() for t in ("albedo", "transmission", "capped"))
    assert moved <= 2 * 2  # a path that changes order or side leaves one count and adds one
    assert np.abs(f32["lobe"] - f64["lobe"]).sum() <= 2 * 2
    assert f32["albedo"].dtype == np.float64
    # energy, path by path, in both precisions (every weight is 1)
    for r in (f32, f64):
        assert r["albedo"].sum() + r["transmission"].sum() + r["capped"] == n


def test_a_round_in_chunks_of_any_size_gives_the_same_tallies():
    """start_round's round run in chunks of 1, 3 and 2 loop steps (fitlab simulate sizes them by time, so that
    Ctrl-C is answered between two) gives run_round's tallies, bit for bit."""
    from fitlab.families.microfacet_energy.mc.walk import WalkConfig, start_round

    cfg, key, params = (
        WalkConfig(distribution="ggx", kind="dielectric"),
        job_key(5, 0, 0),
        MaterialParams(0.6, 0.6, eta=1.5),
    )
    whole = run_round(cfg, key, params, 0.5, 100, 20_000)
    rnd = start_round(cfg, key, params, 0.5, 100, 20_000)
    sizes, chunks = [1, 3, 2], 0
    while not rnd.advance(sizes[chunks % 3]):
        chunks += 1
    chunked = rnd.tallies()
    assert chunks > 5 and rnd.finished == 20_000
    assert set(chunked) == set(whole) and all(np.array_equal(chunked[k], whole[k]) for k in whole)


@pytest.mark.parametrize("path_id, order", [(5194115, 4), (16879934, 5)])
def test_float32_walk_at_normal_incidence_escapes_where_float64_does(path_id, order):
    """The two of 2e7 paths of a white GGX conductor (alpha 1) at normal incidence, seed 1, that the float32 walk
    capped after 1000 bounces, found by bisecting the capped ones: the first drew the word 0xFFFFFFxx at its
    third event, which float32's (word >> 8 + 1/2) 2^-24 rounded to U = 1 (h = -1, then NaN); the second drew
    1 - U of 5e-4 and 1e-5 at its first two events and fell below C1 = 2^-25, where a float32 h rounds
    2 C1 - 1 to -1.  Both now escape, at the order the float64 walk gives them, and nothing is capped or
    failed."""
    from fitlab.families.microfacet_energy.mc.walk import WalkConfig

    key, params = job_key(1, 0, 0), MaterialParams(1.0, 1.0)
    for precision in ("float32", "float64"):
        r = run_round(
            WalkConfig(distribution="ggx", kind="conductor", precision=precision), key, params, 1.0, path_id, 1
        )
        assert r["albedo"].tolist() == [1.0 if k == order - 1 else 0.0 for k in range(5)], precision
        assert r["capped"] == 0 and r["failed"] == 0 and r["bounces"] == order


def test_a_non_finite_state_is_a_failed_path_apart_from_capped_ones(white_ggx):
    """A path whose weight, height or direction is not finite is ended and counted as failed, never tallied as
    light nor as capped (NaN albedo of diffuse facets: every path that scatters once fails at its next event);
    paths add up: reflected + transmitted + capped + failed = paths; simulate's rows and summary carry it and
    fitlab.scenes.failures names the job."""
    import copy

    from fitlab.families.microfacet_energy.mc.walk import WalkConfig
    from fitlab.scenes import failures

    n = 2000
    r = run_round(
        WalkConfig(distribution="beckmann", kind="diffuse"),
        job_key(5, 0, 0),
        MaterialParams(0.6, 0.6, albedo=math.nan),
        0.5,
        0,
        n,
    )
    assert r["failed"] == n and r["capped"] == 0 and r["albedo"].sum() == 0 and np.all(np.isfinite(r["lobe"]))
    assert r["albedo"].sum() + r["transmission"].sum() + r["capped"] + r["failed"] == n
    assert failures(white_ggx) == [] and all(t["failed"] == 0 for t in white_ggx.tallies.values())
    result = copy.copy(white_ggx)
    result.tallies = {k: dict(t) for k, t in white_ggx.tallies.items()}
    result.tallies[(0, 1)]["failed"] = np.int64(7)  # as if 7 of its paths had failed
    walk, scene = result.walk, result.scene
    rows, summary = walk.finish(scene, list(walk.jobs(scene)), result.tallies, result.jobs)
    failed = [(x["mu_i"], x["estimate"]) for x in rows if x["quantity"] == "failed" and x["material"] == "white"]
    assert failed == [(0.3, 0.0), (0.8, 7 / result.jobs[(0, 1)].paths)]
    assert [s["failed"] for s in summary] == [0, 7, 0, 0]
    (line,) = failures(result)
    assert line.startswith(result.jobs[(0, 1)].name) and "7 of" in line and "non-finite" in line
