"""The simulated multiple-scattering lobes (fitlab.families.microfacet_energy.lobes.tables) and their
per-lobe fits' tables: what the tables say of themselves, the rho^S identity of diffuse facets by
simulation, and the multiple-scattering albedo against 1 - E of the exact engine.  (``fitlab tabulate
--check``, run by tests/test_tabulate.py, re-simulates one job of each kind and refits one lobe.)"""

import numpy as np
import pytest

from fitlab.families.microfacet_energy.exact import directional_albedo
from fitlab.families.microfacet_energy.lobes import params as lp
from fitlab.families.microfacet_energy.lobes import tables as lt
from fitlab.resources import packaged_tables
from fitlab.store import TableError, read_table

DATA = packaged_tables("microfacet_energy")


@pytest.fixture(scope="module")
def lobes():
    return {(k, w): lt.read_lobes(DATA, k, w) for k in lt.KINDS for w in lt.SETS}


def test_headers_state_method_seed_and_budget():
    for kind in lt.KINDS:
        for which in lt.SETS:
            text = (DATA / lt.lobe_file(kind, which)).read_text().splitlines()[:4]
            assert f"seed {lt.SEED}" in text[1] and f"{lt.PATHS} paths per job" in text[1]
            assert "standard error" in text[2]
            assert "interleaved" in text[3] if which == "validation" else "alpha in" in text[3]


def test_grids_interleave_and_cover_the_domain():
    train, valid = np.array(lt.grid_points("training")), np.array(lt.grid_points("validation"))
    assert train[:, 0].min() == valid[:, 0].min() == lt.DOMAIN["alpha"][0]
    assert train[:, 1].max() == valid[:, 1].max() == lt.DOMAIN["mu_i"][1]
    # no validation job is a training job
    assert not set(map(tuple, valid)) & set(map(tuple, train))
    # every interior validation alpha lies strictly between two training alphas
    for a in lt.ALPHA_VALIDATION:
        assert min(lt.ALPHA_TRAINING) < a < max(lt.ALPHA_TRAINING) and a not in lt.ALPHA_TRAINING


def test_bins_add_up_to_the_albedo(lobes):
    omega = lt.solid_angles()
    for t in lobes.values():
        total = np.einsum("josp,sp->jo", t.value, omega)
        # rounding to 4 digits, and the tail's albedo holds the (zero) capped weight besides its bins
        np.testing.assert_allclose(total, t.albedo, rtol=2e-3, atol=2e-6)


def test_energy_is_conserved_by_every_job(lobes):
    # F = 1 and albedo 1: every path leaves with weight 1, so the orders add up to 1 exactly (up to rounding)
    for t in lobes.values():
        np.testing.assert_allclose(t.albedo.sum(axis=1), 1.0, atol=5e-4)


def test_multiple_scattering_albedo_is_one_minus_E_of_the_exact_engine(lobes):
    # conductors with F = 1: orders >= 2 carry exactly what order 1 (height-correlated GGX) lacks
    for which in lt.SETS:
        t = lobes[("conductor", which)]
        _, _, ms, ms_se = t.multiple()
        z = (ms - (1.0 - directional_albedo(t.mu_i, t.alpha, "ggx_correlated"))) / ms_se
        assert np.max(np.abs(z)) < 4.5, (which, np.max(np.abs(z)))


def test_summed_orders_standard_error_accounts_for_their_exclusion(lobes):
    t = lobes[("diffuse", "training")]
    value, se, albedo, albedo_se = t.multiple()
    np.testing.assert_allclose(value, t.value[:, 1:].sum(axis=1))
    # exclusive orders are anti-correlated: the summed se is below the root sum of squares
    assert np.all(se <= np.sqrt((t.se[:, 1:] ** 2).sum(axis=1)) * (1 + 1e-12))
    assert np.all(albedo_se <= np.sqrt((t.albedo_se[:, 1:] ** 2).sum(axis=1)) * (1 + 1e-12))


def test_rho_to_the_S_scaling_of_diffuse_facets_by_simulation():
    res = lt.albedo_identity(rho=0.6, paths=40_000)
    assert np.all(np.abs(res["z"]) < 4.5), res


def test_parameter_tables_match_their_lobe_tables(lobes):
    for (kind, which), t in lobes.items():
        p = lp.read_params(DATA, kind, which)
        assert p["alpha"].size == len(t) * len(lp.ORDERS)
        np.testing.assert_array_equal(p["order"], np.tile(lp.ORDERS, len(t)))
        assert np.all(p["blog_sigma"] > 0) and np.all(p["blog_sigma_n"] > 0)
        assert np.all(np.isfinite([p[c] for c in lp.VALUE_COLUMNS]))


def test_read_refuses_a_table_of_another_grid():
    _, data = read_table(DATA / lt.lobe_file("diffuse", "training"), lt.lobe_columns())
    with pytest.raises(TableError, match="rows, expected"):
        lt.lobes_from_rows(data[:-5], "diffuse", "training")
    shifted = data.copy()
    shifted[:, 0] += 0.5
    with pytest.raises(TableError, match="not the grid"):
        lt.lobes_from_rows(shifted, "diffuse", "training")
