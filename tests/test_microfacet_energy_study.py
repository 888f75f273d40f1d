"""The energy-compensation study (studies.microfacet_energy.energy_compensation): its texture read
and its furnace are checked on identities, at sizes small enough for the suite."""

from __future__ import annotations

import numpy as np
import pytest

from fitlab.families.microfacet_energy.exact import directional_albedo
from studies.microfacet_energy import energy_compensation as S


def test_bilinear_read_is_exact_at_texel_centres_and_clamps_at_the_edges():
    rng = np.random.default_rng(1)
    table = rng.random((5, 7))
    v, u = np.meshgrid((np.arange(5) + 0.5) / 5, (np.arange(7) + 0.5) / 7, indexing="ij")
    assert np.array_equal(S.bilinear(table, u.ravel(), v.ravel()), table.ravel())
    assert S.bilinear(table, np.array([0.0]), np.array([0.0]))[0] == table[0, 0]  # clamp-to-edge
    assert S.bilinear(table, np.array([1.0]), np.array([1.0]))[0] == table[-1, -1]
    line = rng.random(4)
    assert S.bilinear(line, np.array([0.5]))[0] == pytest.approx(0.5 * (line[1] + line[2]), rel=1e-15)


def test_a_bilinear_read_of_a_bilinear_function_is_exact():
    """Linear in each coordinate between the centres: the read reproduces it everywhere inside them."""
    n = 6
    c = (np.arange(n) + 0.5) / n
    a, m = np.meshgrid(c, c, indexing="ij")
    f = lambda mu, alpha: 0.3 + 0.2 * mu - 0.1 * alpha + 0.05 * mu * alpha  # noqa: E731
    rng = np.random.default_rng(2)
    mu, alpha = rng.uniform(c[0], c[-1], 50), rng.uniform(c[0], c[-1], 50)
    assert np.allclose(S.bilinear(f(m, a), mu, alpha), f(mu, alpha), rtol=0, atol=1e-15)


@pytest.mark.parametrize("model", ["ggx_correlated", "oren_nayar"])
def test_furnace_with_the_exact_albedo_is_one(model):
    """With E_hat = E and E_avg_hat = E_avg the furnace is 1 (to the midpoint rule of the lobe's integral)."""
    mu, alpha = np.array([0.0, 0.3, 1.0, 0.7]), np.array([0.2, 0.2, 0.6, 1.0])
    a = S.furnace(S.exact_method(model), model, mu, alpha, directional_albedo(mu, alpha, model))
    assert np.allclose(a, 1.0, atol=2e-5)


def test_no_compensation_loses_one_minus_E():
    mu, alpha = np.array([0.5]), np.array([1.0])
    E = directional_albedo(mu, alpha, "ggx_separable")
    assert S.furnace(S.no_compensation(), "ggx_separable", mu, alpha, E)[0] == E[0]


def test_node_addressing_reads_the_nodes():
    n = 5
    nodes = np.arange(n) / (n - 1.0)
    table = np.add.outer(nodes, 2.0 * nodes)  # [alpha, mu]
    to = lambda u: (u * (n - 1) + 0.5) / n  # noqa: E731
    a, m = np.meshgrid(nodes, nodes, indexing="ij")
    assert np.allclose(S.bilinear(table, to(m.ravel()), to(a.ravel())), table.ravel(), atol=1e-15)


def test_validation_set_holds_the_edges_and_no_texel_centre():
    v = S.validation_set(8)
    assert {0.0, 1.0} <= set(v["mu"]) and {S.ALPHA_MIN, 1.0} <= set(v["alpha"])
    for n in S.TABLE_SIZES:
        centres = (np.arange(n) + 0.5) / n
        assert not np.any(np.isclose(v["mu"][:, None], centres[None, :], rtol=0, atol=1e-12))


def test_generated_kulla_conti_furnace_float_is_double_and_the_search_finds_the_worst_point():
    from fitlab.codegen.native import compiler

    if compiler() is None:
        pytest.skip("no C compiler on PATH")
    native = S._kc_native()
    rows = {(r["alpha"], r["precision"]): r for r in S.kulla_conti_furnace(native, alphas=(1e-4, 0.5))}
    for alpha in (1e-4, 0.5):
        d, f = rows[(alpha, "double")], rows[(alpha, "float")]
        # float keeps double's digits (1 - E and 1 - E_avg are never formed by subtraction)
        assert abs(f["max_furnace"] - d["max_furnace"]) < 1e-5, (alpha, d, f)
        # the reported worst point is no better than any point of a finer scan of mu_o
        mu_i, w = S._graded_nodes(alpha)
        for mu_o in np.linspace(0.0, 1.0, 11).tolist() + np.minimum(alpha * np.geomspace(0.1, 100, 7), 1.0).tolist():
            lobe = native("ms_kulla_conti", mu_i, np.full(mu_i.shape, mu_o), np.full(mu_i.shape, alpha))
            a = float(directional_albedo(mu_o, alpha, "ggx_correlated")) + 2 * np.pi * float(np.sum(w * mu_i * lobe))
            assert abs(a - 1.0) <= d["max_furnace"] + 1e-12, (alpha, mu_o, a)


def test_coloured_compensation_takes_the_exact_f_avg_of_each_metal_and_bounds_hold():
    """The coloured table's F_avg is the fresnel family's exact average (checked by its second quadrature route),
    Schlick's is (20 F0 + 1)/21, each f_add lies in [0, F_avg^2] and grows with F_avg, so the Schlick-derived
    lobe is the brighter exactly where Schlick's F_avg is; gold's red (F > 1) has none."""
    from fitlab.families.fresnel.exact import average_reflectance
    from studies.microfacet_energy.energy_compensation import coloured_compensation

    rows = coloured_compensation(alphas=(0.5, 1.0))
    assert {r["material"] for r in rows} == {"ag", "al", "au", "cr", "cu", "ni", "w", "mo"}
    for r in rows:
        c = "rgb".index(r["channel"])
        assert abs(r["F_avg"] - average_reflectance(r["material"], route="theta")[c]) < 1e-10
        assert r["F_avg_schlick"] == (20 * r["F0"] + 1) / 21
        if r["f_add"] is None:
            assert (r["material"], r["channel"]) == ("au", "r")
            continue
        for e_avg, exact, schlick in zip(r["E_avg"], r["f_add"], r["f_add_schlick"], strict=True):
            f = r["F_avg"]
            assert abs(exact - f * f * e_avg / (1 - f * (1 - e_avg))) < 1e-15
            assert 0 <= exact <= f * f
            assert (schlick > exact) == (r["F_avg_schlick"] > r["F_avg"])
