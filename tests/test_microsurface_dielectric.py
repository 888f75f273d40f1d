"""Dielectric and diffuse facets in the microsurface random walk (Heitz et al. 2016), against references
computed independently: order 1 bin by bin against the single-scattering BRDF and BTDF (Walter et al.
2007 with height-correlated G2_t = B(1 + Lambda_i, 1 + Lambda_o)) and the diffuse facets' order 1; the
references against each other (bins of f against integrals over the facet normals), against the exact
engine, their limits and the BTDF's generalised reciprocity; energy conserved path by path; the walk
sharded over several host devices gives the paths of one device.

Small budgets (a compiled walk configuration costs a few seconds and is shared through fixtures);
the large budgets are ``python -m studies.microfacet_energy.microsurface_validation``
(tests/test_microsurface_dielectric.py::test_validation_study, a benchmark)."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitlab.core import float64
from fitlab.families.microfacet_energy.exact import dielectric_factor, directional_albedo, fresnel_dielectric
from fitlab.families.microfacet_energy.mc import SceneError, parse_scene, simulate
from fitlab.families.microfacet_energy.mc.microsurface import refract
from fitlab.families.microfacet_energy.mc.reference import (
    albedo_single,
    bin_average_diffuse,
    bin_average_single,
    bin_average_transmission,
    btdf,
    diffuse_single_brdf,
    normal_rule,
    order_one_by_normals,
    transmission_g2,
)
from fitlab.families.microfacet_energy.mc.scene import Material
from fitlab.families.microfacet_energy.mc.simulate import count_p_value, job_config
from fitlab.families.microfacet_energy.mc.walk import MaterialParams, WalkConfig, job_key, run_round
from fitlab.families.microfacet_energy.mc.walk_fresnel import dielectric

ROOT = Path(__file__).resolve().parents[1]
Z_MAX = 4.0


def _scene(materials: str, mu_i="[0.3, 0.8]", max_paths=150_000, max_bounces=1000) -> str:
    return f"""
[scene]
name = "t"
seed = 11
{materials}
[incident]
mu_i = {mu_i}
[outgoing]
mu_o = 4
phi = 4
orders = 3
[precision]
target_se = 1e-9
max_paths = {max_paths}
batch = {max_paths}
max_bounces = {max_bounces}
"""


GLASS = """
[[material]]
label = "glass"
kind = "dielectric"
distribution = "ggx"
alpha = 0.6
eta = 1.5
[[material]]
label = "aniso_from_inside"
kind = "dielectric"
distribution = "ggx"
alpha_x = 0.3
alpha_y = 0.8
eta = 0.6666666666666666
[[material]]
label = "beckmann"
kind = "dielectric"
distribution = "beckmann"
alpha = 0.5
eta = 1.5
"""


@pytest.fixture(scope="module")
def glass():
    return simulate(parse_scene(_scene(GLASS)))


def _rows(result, quantity, material=None, order=None):
    return [
        r
        for r in result.rows
        if r["quantity"] == quantity
        and (material is None or r["material"] == material)
        and (order is None or r["order"] == order)
    ]


#: two-sided p-value of a 4-sigma normal deviation: a bin's count must be at least this likely under its reference
P_MIN = 6.3e-5


def _assert_agrees(rows):
    """Each lobe bin's count at least P_MIN likely under its reference (``count_p_value``: binomial, exact for
    these constant weights, calibrated where few paths land, empty bins included); each total within Z_MAX
    standard errors of its reference."""
    worst, checked = 0.0, 0
    for r in rows:
        assert math.isfinite(r["reference"]), r
        if "_s1" in r:
            assert count_p_value(r) >= P_MIN, (count_p_value(r), r)
            continue
        assert r["se"] > 0.0, r
        worst, checked = max(worst, abs(r["z_ref"])), checked + 1
    assert worst < Z_MAX, worst
    return worst


def test_count_p_value_is_the_binomial_tail():
    """A bin of Omega = 0.1 over N = 1e6 paths of weight 1 whose reference expects 8 paths: holding 2 is a
    two-sided p of 2 P(n <= 2) (z from the sample would say -4.2); an empty bin 2 P(n = 0) = 2 (1 - q)^N; paths
    of weight 0.5 count as S1 / 0.5."""
    from scipy.stats import binom

    n, omega = 1_000_000, 0.1
    ref = 8.0 / (n * omega)
    row = dict(reference=ref, _n=n, _norm=omega, _s1=2.0, _s2=2.0)
    assert count_p_value(row) == pytest.approx(2.0 * binom.cdf(2, n, 8.0 / n), rel=1e-12)
    assert 0.01 < count_p_value(row) < 0.05
    assert count_p_value(dict(row, _s1=0.0, _s2=0.0)) == pytest.approx(2.0 * (1.0 - 8.0 / n) ** n, rel=1e-9)
    assert count_p_value(dict(row, _s1=1.0, _s2=0.5)) == pytest.approx(2.0 * binom.cdf(2, n, 16.0 / n), rel=1e-12)
    assert count_p_value(dict(row, _s1=8.0, _s2=8.0)) == 1.0
    assert math.isnan(count_p_value(dict(row, reference=math.nan)))


@pytest.mark.parametrize("material", ["glass", "aniso_from_inside", "beckmann"])
def test_order_one_reflection_and_transmission_per_bin(glass, material):
    """Order 1: the reflected lobe is the microfacet BRDF with the dielectric F and G2, the transmitted one
    Walter's BTDF with G2_t; their totals too (the reflection's from the exact engine for isotropic GGX with
    eta > 1, the transmission's by the integral over the normals)."""
    lobes = _rows(glass, "lobe", material, "1") + _rows(glass, "lobe_transmission", material, "1")
    assert len(lobes) == 2 * 2 * 16
    _assert_agrees(lobes)
    totals = _rows(glass, "albedo", material, "1") + _rows(glass, "transmission", material, "1")
    _assert_agrees(totals)
    method = {r["reference_method"] for r in _rows(glass, "albedo", material, "1")}
    assert method == ({"exact_directional_albedo"} if material == "glass" else {"bin_quadrature"})
    for r in _rows(glass, "transmission", material, "1"):
        assert r["estimate"] > 50 * r["se"]  # a real signal: order 1 transmits most of the light


def test_energy_is_conserved_path_by_path(glass):
    for t in glass.tallies.values():
        # weight 1 everywhere: each path ends exactly once, reflected, transmitted or capped
        assert np.sum(t["albedo"]) + np.sum(t["transmission"]) + t["capped"] == t["paths"]
        assert np.sum(t["lobe"]) == np.sum(t["albedo"]) and np.sum(t["lobe_transmission"]) == np.sum(t["transmission"])
        assert np.sum(t["transmission"][1:]) > 0.01 * t["paths"]  # multiple scattering is there
    for r in _rows(glass, "energy_total"):
        assert r["estimate"] == 1.0 and r["reference"] == 1.0
    for r in _rows(glass, "albedo_total"):
        assert 0.0 < r["estimate"] < 1.0 and math.isnan(r["reference"])


def test_capped_paths_keep_their_weight(glass):
    """With a cap of 2 events the cut tail is tallied, and the sums still hold exactly."""
    cfg = job_config(glass.scene, glass.scene.materials[0])  # compiled already
    r = run_round(cfg, job_key(1, 0, 0), MaterialParams(0.6, 0.6, eta=1.5), 0.3, 0, 20_000, max_bounces=2)
    assert r["capped"] > 0 and np.sum(r["albedo"][2:]) == np.sum(r["transmission"][2:]) == 0.0
    assert np.sum(r["albedo"]) + np.sum(r["transmission"]) + r["capped"] == r["paths"]


def test_index_matched_interface_passes_straight_through(glass):
    """eta = 1 (no interface; refused by scenes): F = 0 and the refraction keeps the direction, so every path
    leaves through the bottom along -w_i, after an odd number of crossings."""
    cfg = job_config(glass.scene, glass.scene.materials[0])
    mu_i = 0.8
    r = run_round(cfg, job_key(2, 0, 0), MaterialParams(0.6, 0.6, eta=1.0), mu_i, 0, 20_000)
    assert np.sum(r["albedo"]) == 0.0 and r["capped"] == 0.0 and np.sum(r["transmission"]) == 20_000
    assert r["transmission"][1] == 0.0  # an even number of crossings leaves the ray above, going down
    lobe = r["lobe_transmission"].sum(axis=0)
    mu_bin = np.searchsorted(cfg.mu_edges, mu_i, side="right") - 1
    # straight through: |mu_o| = mu_i (up to rounding, which can put it just below the bin edge 0.75), phi = pi
    assert lobe[:, -1].sum() == 20_000 and lobe[mu_bin - 1 : mu_bin + 1, -1].sum() == 20_000


def test_walk_does_not_depend_on_the_batch_split(glass):
    cfg = job_config(glass.scene, glass.scene.materials[0])
    key, params = job_key(3, 0, 0), MaterialParams(0.6, 0.6, eta=1.5)
    whole = run_round(cfg, key, params, 0.5, 0, 12_000)
    parts = [run_round(cfg, key, params, 0.5, lo, 4_000) for lo in (0, 4_000, 8_000)]
    for name in whole:
        assert np.array_equal(whole[name], sum(p[name] for p in parts)), name  # counts: exact in float64


@float64
def test_dielectric_fresnel_agrees_with_the_exact_engine():
    c = np.concatenate([np.linspace(0.0, 1.0, 201), [0.74535599, 0.74535600]])  # around eta = 2/3's critical angle
    for eta in (1.5, 2.0 / 3.0, 1.0, 1e-3, 100.0):
        np.testing.assert_allclose(
            np.asarray(dielectric(jnp.asarray(c), eta)), fresnel_dielectric(c, eta), rtol=1e-13, atol=1e-15
        )
    assert float(dielectric(jnp.float64(1.0), 1.5)) == pytest.approx(0.04, rel=1e-14)  # ((eta - 1)/(eta + 1))^2


@float64
@settings(max_examples=60, deadline=None)
@given(
    st.floats(0.02, 1.0),
    st.floats(0.0, 2 * math.pi),
    st.floats(0.0, 1.0),
    st.floats(0.0, 2 * math.pi),
    st.sampled_from([1.5, 2.0 / 3.0, 1.01, 4.0]),
)
def test_refraction_obeys_snell_and_reverses(theta_m, phi_m, cos_w, phi_w, eta):
    """t = refract(w, m, eta) is a unit vector behind the facet with eta sin_t = sin_i in the plane of w and
    m; light sent back along t through the facet seen from its side (-m, 1 / eta) returns along w."""
    m = np.array([math.sin(theta_m) * math.cos(phi_m), math.sin(theta_m) * math.sin(phi_m), math.cos(theta_m)])
    a = np.array([math.cos(phi_w), math.sin(phi_w), 0.0])
    a -= a.dot(m) * m
    if np.linalg.norm(a) < 1e-6:
        return
    a /= np.linalg.norm(a)
    w = cos_w * m + math.sqrt(1.0 - cos_w**2) * a  # w.m = cos_w >= 0
    if 1.0 - (1.0 - cos_w**2) / eta**2 <= 1e-9:
        return  # total internal reflection: the walk never refracts there
    t = np.array([float(v) for v in refract(*map(jnp.float64, w), *map(jnp.float64, m), eta)])
    assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-14)
    assert -t.dot(m) > 0.0
    # sines as |v x m| (well conditioned near normal incidence, unlike sqrt(1 - cos^2))
    assert eta * np.linalg.norm(np.cross(t, m)) == pytest.approx(np.linalg.norm(np.cross(w, m)), abs=1e-12)
    assert abs(np.cross(w, m).dot(t)) < 1e-12  # coplanar
    back = np.array([float(v) for v in refract(*map(jnp.float64, t), *map(jnp.float64, -m), 1.0 / eta)])
    # near grazing w the way back is ill-conditioned: cos_w = sqrt(cos_w^2 + O(eps)) is off by eps / cos_w, and
    # the O(eps) of 1 - (eta sin_t)^2 is several roundings (1.9e-15 seen at cos_w = 1.2e-7, eta = 4)
    np.testing.assert_allclose(back, w, atol=1e-12 + min(1e-14 / max(cos_w, 1e-30), 1e-7))


def _direction(theta, phi, sign=1.0):
    return (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), sign * math.cos(theta))


@settings(max_examples=80, deadline=None)
@given(
    st.floats(0.01, 1.55),
    st.floats(0.0, 2 * math.pi),
    st.floats(0.01, 1.55),
    st.floats(0.0, 2 * math.pi),
    st.sampled_from(["ggx", "beckmann"]),
    st.sampled_from([(0.6, 0.6), (0.2, 0.9)]),
    st.sampled_from([1.5, 1.0 / 1.5, 3.0]),
)
def test_btdf_generalised_reciprocity(ti, pi_, to, po, dist, alphas, eta):
    """f_t(w_i, w_o; eta) / eta^2 = f_t(-w_o, -w_i; 1 / eta): the light path reversed (from inside, which the
    walk's flip maps to light from outside with 1 / eta), in Veach's radiance form, to the rounding of the
    inputs: the bound is 1e-12 relative plus 8 times the change of f_t when every direction component moves
    by 4 ulp (in D's far tail, Beckmann's exp(-tan^2 / alpha^2) down to 1e-255, that change is 1e-11 and
    more).  With 1 - F from Snell's cos_t, rather than both cosines of the half vector, the reversed path
    (eta < 1, near the critical angle) was off by up to 1.2e-4 relative, 2e5 times this bound."""
    wi, wo = _direction(ti, pi_), _direction(to, po, -1.0)
    forward = float(btdf(wi, wo, *alphas, dist, eta))
    backward = float(btdf(tuple(-x for x in wo), tuple(-x for x in wi), *alphas, dist, 1.0 / eta))
    ulps = 4.0 * np.finfo(float).eps
    signs = ((1.0, -1.0, 1.0), (-1.0, 1.0, -1.0))
    spread = max(
        abs(
            float(
                btdf(
                    tuple(c * (1 + ulps * s) for c, s in zip(wi, si)),
                    tuple(c * (1 + ulps * s) for c, s in zip(wo, so)),
                    *alphas,
                    dist,
                    eta,
                )
            )
            - forward
        )
        for si in signs
        for so in signs
    )
    assert abs(forward / eta**2 - backward) <= 8.0 * spread / eta**2 + 1e-12 * abs(backward) + 1e-300


def test_transmission_g2_limits():
    """B(1 + L_i, 1 + L_o): 1 at L = 0 both, 1 / (1 + L_i) at L_o = 0 (the G1 of the incident side alone),
    symmetric, and below the reflection's 1 / (1 + L_i + L_o) (both sides' masking at opposite heights)."""
    lam = np.array([0.0, 0.1, 1.0, 7.0])
    np.testing.assert_allclose(transmission_g2(lam, 0.0), 1.0 / (1.0 + lam), rtol=1e-14)
    li, lo = np.meshgrid(lam, lam)
    np.testing.assert_allclose(transmission_g2(li, lo), transmission_g2(lo, li), rtol=1e-14)
    assert np.all(transmission_g2(li, lo) <= 1.0 / (1.0 + li + lo) + 1e-15)


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
@pytest.mark.parametrize("eta", [1.5, 1.0 / 1.5])
def test_order_one_totals_by_bins_and_by_normals(dist, eta):
    """R_1 and T_1 as sums of the bin averages of f_1 and f_t (integrals over w_o, with Walter's Jacobian)
    and as integrals over the facet normals (no change of variables): two independent routes.  Their
    tolerances are the rules' accuracy, measured by refining them: the kinks (w_i.m = 0; for eta < 1 the
    square-root edge of total internal reflection, along curves neither rule follows) leave ~1e-5 on R_1
    with eta > 1, and with eta < 1 ~1e-4 on the bins' R_1 and ~1e-5 on the normals' T_1."""
    mat = Material(label="g", kind="dielectric", distribution=dist, alpha_x=0.6, alpha_y=0.4, eta=eta)
    mu_e, phi_e = np.linspace(0.0, 1.0, 9), np.linspace(0.0, math.pi, 7)
    omega = 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))
    tol_r, tol_t = (2e-5, 1e-6) if eta > 1.0 else (3e-4, 1e-4)
    for mu_i in (0.2, 0.7):
        r1, t1 = order_one_by_normals(mu_i, mat)
        assert np.sum(bin_average_single(mu_e, phi_e, mu_i, mat) * omega) == pytest.approx(r1, rel=tol_r)
        assert np.sum(bin_average_transmission(mu_e, phi_e, mu_i, mat) * omega) == pytest.approx(
            t1, rel=tol_t, abs=1e-7
        )
        assert 0.0 < r1 + t1 < 1.0


@pytest.mark.parametrize(
    "dist, alpha, mu_i", [("ggx", 1e-3, 0.5), ("beckmann", 1e-3, 0.9), ("ggx", 0.01, 0.9), ("beckmann", 0.01, 0.2)]
)
def test_bin_references_resolve_the_peak_down_to_the_smallest_alpha(dist, alpha, mu_i):
    """The scenes' alpha goes down to 1e-3, where the whole lobe lies within 1e-3 of the mirror and refracted
    directions: the bin averages (panels graded towards the peak) still sum to the integrals over the
    normals (whose rule follows D at any alpha)."""
    glass = Material(label="g", kind="dielectric", distribution=dist, alpha_x=alpha, alpha_y=alpha, eta=1.5)
    mu_e, phi_e = np.linspace(0.0, 1.0, 9), np.linspace(0.0, math.pi, 7)
    omega = 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))
    r1, t1 = order_one_by_normals(mu_i, glass)
    assert np.sum(bin_average_single(mu_e, phi_e, mu_i, glass, use_exact_ggx=False) * omega) == pytest.approx(
        r1, rel=1e-5
    )
    assert np.sum(bin_average_transmission(mu_e, phi_e, mu_i, glass) * omega) == pytest.approx(t1, rel=1e-6)


def test_references_cover_alpha_up_to_two():
    """Scenes take alpha up to 2, the exact engine's GGX up to 1: an isotropic GGX beyond it is integrated
    by the bin rule (which agrees with the normals), for conductors and dielectrics."""
    mu_e, phi_e = np.linspace(0.0, 1.0, 5), np.linspace(0.0, math.pi, 5)
    omega = 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))
    glass = Material(label="g", kind="dielectric", distribution="ggx", alpha_x=2.0, alpha_y=2.0, eta=1.5)
    r1, t1 = order_one_by_normals(0.3, glass)
    assert np.sum(bin_average_single(mu_e, phi_e, 0.3, glass) * omega) == pytest.approx(r1, rel=2e-5)
    assert np.sum(bin_average_transmission(mu_e, phi_e, 0.3, glass) * omega) == pytest.approx(t1, rel=1e-6)
    white = Material(label="w", kind="conductor", distribution="ggx", alpha_x=2.0, alpha_y=2.0)
    a1, method = albedo_single(0.3, white)
    assert method == "bin_quadrature" and 0.0 < a1 < 1.0


def test_reflection_reference_against_the_exact_engine():
    """Isotropic GGX: the normals' R_1 equals the exact engine's E with the F inside (to the normal rule's
    accuracy, ~1e-5: the kink where w_i.m = 0 is not a line of the rule); eta > 1 (a smooth F) and eta < 1, where
    the engine follows the critical angle (given as a FresnelFactor, which albedo_single passes it) and the
    normal rule does not (3e-5 absolute at mu_i = 1, 0.6 % of R_1 there; 4x the nodes: 7e-6)."""
    for eta, rel, tol in ((1.5, 2e-5, 0.0), (1 / 1.5, 0.0, 5e-5)):
        mat = Material(label="g", kind="dielectric", distribution="ggx", alpha_x=0.5, alpha_y=0.5, eta=eta)
        for mu_i in (0.1, 0.5, 1.0):
            e = float(directional_albedo(mu_i, 0.5, "ggx_correlated", fresnel=dielectric_factor(eta)))
            assert order_one_by_normals(mu_i, mat)[0] == pytest.approx(e, rel=rel, abs=tol)
            assert albedo_single(mu_i, mat) == (e, "exact_directional_albedo")


DIFFUSE = """
[[material]]
label = "white"
kind = "diffuse"
distribution = "ggx"
alpha = 0.6
[[material]]
label = "grey_aniso"
kind = "diffuse"
distribution = "ggx"
alpha_x = 0.2
alpha_y = 0.9
albedo = 0.7
"""


def test_diffuse_facets_order_one_per_bin_and_multiple_scattering():
    res = simulate(parse_scene(_scene(DIFFUSE, max_paths=100_000)))
    for mat in ("white", "grey_aniso"):
        rows = _rows(res, "lobe", mat, "1") + _rows(res, "albedo", mat, "1")
        assert len(rows) == 2 * 17
        _assert_agrees(rows)
    # white facets lose nothing: orders >= 2 carry 1 - A_1 of the order-1 reference
    for r in _rows(res, "albedo_multiple", "white"):
        assert r["reference_method"] == "1 - bin_quadrature" and abs(r["z_ref"]) < Z_MAX
        assert r["estimate"] > 10 * r["se"]


def test_diffuse_reference_limits_and_convergence():
    """alpha -> 0: the facets are the macro surface, f_1 -> rho / pi; GGX alpha = 1 (D = 1 / pi) at normal
    incidence and exit: int m_z^2 dm / pi = 2/3, so f_1 = 2 rho / (3 pi); the normal rule against its own
    refinement."""
    wo = (np.array([0.0, 0.8]), np.array([0.6, 0.0]), np.array([0.8, 0.6]))
    for dist in ("ggx", "beckmann"):
        flat = Material(label="d", kind="diffuse", distribution=dist, alpha_x=1e-3, alpha_y=1e-3, albedo=0.5)
        np.testing.assert_allclose(diffuse_single_brdf((0.6, 0.0, 0.8), wo, flat), 0.5 / math.pi, rtol=2e-5)
    one = Material(label="d", kind="diffuse", distribution="ggx", alpha_x=1.0, alpha_y=1.0, albedo=0.5)
    z = (np.array(0.0), np.array(0.0), np.array(1.0))
    assert float(diffuse_single_brdf((0.0, 0.0, 1.0), z, one)) == pytest.approx(1.0 / (3.0 * math.pi), rel=1e-10)
    mat = Material(label="d", kind="diffuse", distribution="beckmann", alpha_x=0.4, alpha_y=0.7)
    coarse = diffuse_single_brdf((0.6, 0.0, 0.8), wo, mat)
    fine = diffuse_single_brdf((0.6, 0.0, 0.8), wo, mat, normal_rule(0.4, 0.7, "beckmann", 384, 768))
    np.testing.assert_allclose(coarse, fine, rtol=1e-5)
    # the hemisphere sum of the bins is the order-1 albedo, below 1
    a1 = albedo_single(0.5, mat)[0]
    mu_e, phi_e = np.linspace(0.0, 1.0, 3), np.linspace(0.0, math.pi, 3)
    bins = bin_average_diffuse(mu_e, phi_e, 0.5, mat)
    assert np.sum(bins * 2.0 * np.outer(np.diff(mu_e), np.diff(phi_e))) == pytest.approx(a1, rel=1e-5)
    assert 0.5 < a1 < 1.0


def test_dielectric_scene_rules():
    base = _scene(GLASS.split("[[material]]")[0] + "[[material]]" + GLASS.split("[[material]]")[1])
    assert parse_scene(base).materials[0].eta == 1.5
    for change, message in (
        ("eta = 1.5", "material[0].eta: missing"),
        ("eta = 1.0", "eta = 1 is no interface"),
        ("eta = -2.0", "material[0].eta: -2.0 is outside"),
        ('eta = 1.5\nfresnel = "one"', "a dielectric's Fresnel factor"),
        ("eta = 1.5\nalbedo = 0.5", "material[0].albedo: not used"),
    ):
        text = base.replace("eta = 1.5", change) if change != "eta = 1.5" else base.replace("eta = 1.5\n", "")
        with pytest.raises(SceneError, match=re.escape(message)):
            parse_scene(text)
    with pytest.raises(SceneError, match="transmission_lobe: expected true or false"):
        parse_scene(base.replace("orders = 3", "orders = 3\ntransmission_lobe = 1"))
    assert not parse_scene(base.replace("orders = 3", "orders = 3\ntransmission_lobe = false")).transmission_lobe
    with pytest.raises(ValueError, match="only a dielectric transmits"):
        WalkConfig(kind="conductor", transmission_lobe=True)
    # slots = 0: the lanes per device are the platform's default (default_slots)
    assert parse_scene(base.replace("max_bounces = 1000", "max_bounces = 1000\nslots = 0")).slots == 0
    with pytest.raises(SceneError, match=re.escape("precision.slots: expected an integer")):
        parse_scene(base.replace("max_bounces = 1000", "max_bounces = 1000\nslots = 0.0"))


_SHARD_SCRIPT = """
import json, numpy as np, jax
from fitlab.families.microfacet_energy.mc.walk import MaterialParams, WalkConfig, job_key, run_round
cfg = WalkConfig(kind="dielectric", orders=2, mu_edges=(0.0, 0.5, 1.0), phi_edges=(0.0, 2.0, 3.14159265),
                 slots=64, transmission_lobe=True)
r = run_round(cfg, job_key(5, 1, 2), MaterialParams(0.5, 0.7, eta=1.5), 0.6, 1_000, 5_001)
print(json.dumps({"devices": jax.device_count(), **{k: np.asarray(v).tolist() for k, v in r.items()}}))
"""


@pytest.mark.e2e
def test_sharded_over_four_host_devices_gives_the_same_paths():
    """A mesh of 4 host devices (XLA_FLAGS, in a fresh process): each device walks a quarter of the ids, and
    the tallies equal this process's one-device run exactly (every weight is 1: the sums are counts)."""
    env = dict(
        os.environ,
        XLA_FLAGS="--xla_force_host_platform_device_count=4",
        JAX_PLATFORMS="cpu",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    out = subprocess.run(
        [sys.executable, "-c", _SHARD_SCRIPT], env=env, capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert out.returncode == 0, out.stderr[-2000:]
    four = json.loads(out.stdout.strip().splitlines()[-1])
    assert four.pop("devices") == 4
    cfg = WalkConfig(
        kind="dielectric",
        orders=2,
        mu_edges=(0.0, 0.5, 1.0),
        phi_edges=(0.0, 2.0, 3.14159265),
        slots=64,
        transmission_lobe=True,
    )
    one = run_round(cfg, job_key(5, 1, 2), MaterialParams(0.5, 0.7, eta=1.5), 0.6, 1_000, 5_001)
    assert set(one) == set(four)
    for k, v in one.items():
        np.testing.assert_array_equal(np.asarray(four[k]), v, err_msg=k)
    assert one["paths"] == 5_001


@pytest.mark.benchmark
def test_validation_study():
    """Order 1 against the references at large budgets, every case (max |z|, RMS z); prints the table."""
    from studies.microfacet_energy.microsurface_validation import format_table, run_validation

    rows = run_validation(paths=2_000_000, progress=True)
    print(format_table(rows))
    for r in rows:
        assert r["bins_below_p"] == 0 and r["max_abs_z"] < 4.5, r
        assert r["z_bins"] < 50 or 0.7 < r["rms_z"] < 1.3, r  # an RMS over few bins says little
        assert math.isnan(r["energy_defect"]) or r["energy_defect"] == 0.0  # NaN: the facets absorb
        assert r["failed"] == 0
