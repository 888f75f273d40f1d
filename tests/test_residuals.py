"""fitlab.residuals: residual grids agree with the exact engine and with the fit
records, each target's own error measure is used, slicing and the worst points
are right, and every misuse fails with a clear error."""

import shutil
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from fitlab.core import (
    get_form,  # noqa: E402
    get_target,  # noqa: E402
)
from fitlab.families.lambert_sphere.exact import brdf, constants, h_function, spherical_albedo  # noqa: E402
from fitlab.residuals import approximations, brdf_residuals, grid_axes, heatmap, residuals  # noqa: E402
from fitlab.store import FitFileError, load  # noqa: E402

FITS = Path(__file__).resolve().parents[1] / "fitlab" / "fits"
MU = np.array([0.0, 0.25, 0.5, 1.0])
C = np.array([0.0, 0.5, 0.9, 1.0])


def test_h_grid_matches_the_exact_engine_and_the_preset():
    r = residuals("H0", ("hapke", "paper"), mu=MU, c=C)
    assert r.shape == (4, 4) and list(r.axes) == ["mu", "c"]
    mm, cc = np.meshgrid(MU, C, indexing="ij")
    exact = h_function(0, mm, cc)
    approx = get_form("H0", "hapke")("paper", mm, cc)
    np.testing.assert_array_equal(r.exact, exact)
    np.testing.assert_array_equal(r.approx, approx)
    np.testing.assert_allclose(r.error, np.abs(approx - exact) / exact, rtol=1e-15)
    assert r.label == "hapke / paper" and r.published
    assert not residuals("H0", load(FITS / "H0.json"), mu=MU, c=C).published


def test_exact_itself_has_zero_error_and_axes_keep_the_targets_order():
    r = residuals("H1", lambda mu, c: h_function(1, mu, c), c=C, mu=MU)  # keywords in another order
    assert list(r.axes) == ["mu", "c"] and r.shape == (4, 4)
    assert np.all(r.error == 0.0)


@pytest.mark.xdist_group("kd_true-validation")  # with test_audit.py's test of the same set: computed once
def test_validation_axes_reproduce_the_fit_record():
    """On the axes of the target's validation set the grid holds exactly its points: same max error."""
    ds = get_target("kd_of_c").validation()
    fit = load(FITS / "kd_of_c.json")
    r = residuals("kd_of_c", fit, c=np.unique(ds.inputs["c"]))
    assert r.exact.size == len(ds)
    s = r.summary()
    assert s["max_rel"] == pytest.approx(fit.record["validation"]["max_rel"], rel=1e-12)
    assert s["worst"]["c"] == pytest.approx(fit.record["validation"]["worst"]["c"])


def test_constants_are_measured_against_a():
    r = residuals("B", ("printed", "paper"), c=[0.0, 0.5])
    b = constants(0.5)["B"]
    approx = get_form("B", "printed")("paper", np.array(0.5))
    assert r.error[0] == np.inf  # the printed B misses B(0) = 0
    assert r.error[1] == pytest.approx(abs(approx - b) / (69 * 0.5 / 128), rel=1e-12)
    assert r.summary()["max_rel_nonzero"] == pytest.approx(r.error[1])


def test_derived_inputs_c_of_kd_and_fast_brdf():
    c = np.array([0.0, 0.5, 0.99])
    r = residuals("c_of_kd", load(FITS / "c_of_kd.json"), c=c)
    assert list(r.axes) == ["c"] and list(r.inputs) == ["kd"]
    np.testing.assert_allclose(r.inputs["kd"], spherical_albedo(c, phase="true"))
    np.testing.assert_array_equal(r.exact, c)
    # c = 1 is inside the map's domain: kd_true(1) = 1 (rounding above it clipped)
    r = residuals("c_of_kd", load(FITS / "c_of_kd.json"), c=[0.5, 1.0])
    assert r.inputs["kd"][1] == 1.0 and r.exact[1] == 1.0

    mu = np.array([0.1, 1.0])
    r = residuals("fast_brdf", ("paper", "paper"), mu_i=mu, mu_o=mu, phi=[0.0, 3.0], c=[0.9])
    assert r.shape == (2, 2, 2, 1)
    assert np.all(r.inputs["kd"] == spherical_albedo(0.9, phase="true"))
    np.testing.assert_allclose(r.exact[1, 0, 1, 0], brdf([1.0], [0.1], 3.0, 0.9)[0], rtol=1e-14)


def test_brdf_residuals_of_a_runtime_like_model():
    mu = np.array([0.05, 0.5, 1.0])
    r = brdf_residuals(brdf, mu_i=mu, mu_o=mu, phi=[0.0, np.pi], c=[0.3, 1.0], label="exact")
    assert r.shape == (3, 3, 2, 2) and np.all(r.error == 0.0) and r.label == "exact"
    bumped = brdf_residuals(lambda *a: 1.01 * brdf(*a), mu_i=mu, mu_o=mu, phi=[0.0], c=[0.5])
    np.testing.assert_allclose(bumped.error, 0.01, rtol=1e-12)


def test_worst_table_and_slices():
    r = residuals("H0", ("hapke", "paper"), mu=MU, c=C)
    worst = r.worst(3)
    errs = [w["error"] for w in worst]
    assert errs == sorted(errs, reverse=True) and errs[0] == r.error.max()
    assert set(worst[0]) == {"mu", "c", "exact", "approx", "error"}
    assert len(r.worst(100)) == r.exact.size
    text = r.table(2)
    assert "2 worst of 16 points" in text and len(text.splitlines()) == 4

    s = r.at(c=0.88)  # nearest grid value: 0.9
    assert list(s.axes) == ["mu"] and s.fixed == {"c": 0.9}
    np.testing.assert_array_equal(s.error, r.error[:, 2])
    assert "at c = 0.9" in s.table()
    point = r.at(c=1.0, mu=0.3)
    assert point.shape == () and point.fixed == {"c": 1.0, "mu": 0.25}
    with pytest.raises(KeyError, match="not an axis"):
        s.at(c=0.5)


def test_misuse_fails_clearly():
    with pytest.raises(ValueError, match="takes the axes mu, c"):
        residuals("H0", ("hapke", "paper"), mu=MU)
    with pytest.raises(ValueError, match="1-D"):
        residuals("H0", ("hapke", "paper"), mu=[[0.5]], c=C)
    with pytest.raises(KeyError, match="unknown target"):
        residuals("H7", ("hapke", "paper"), mu=MU, c=C)
    with pytest.raises(KeyError, match="no form"):
        residuals("H0", ("nope", "paper"), mu=MU, c=C)
    with pytest.raises(TypeError, match="callable"):
        residuals("H0", 3.0, mu=MU, c=C)
    with pytest.raises(ValueError, match="pole"):
        brdf_residuals(brdf, mu_i=[0.0, 1.0], mu_o=[0.0], phi=[0.0], c=[0.5])
    assert grid_axes("c_of_kd") == ("c",) and grid_axes("H0") == ("mu", "c")


def test_exact_values_are_cached_and_read_only():
    a = residuals("H0", ("hapke", "paper"), mu=MU, c=C)
    b = residuals("H0", load(FITS / "H0.json"), mu=MU, c=C)
    assert a.exact is b.exact
    with pytest.raises(ValueError):
        a.exact[0, 0] = 1.0


def test_heatmap_draws_two_axes_on_a_log_scale():
    r = residuals("B", ("printed", "paper"), c=[0.0, 0.5])
    with pytest.raises(ValueError, match="exactly the axes"):
        heatmap(r, "c", "mu")
    r = residuals("H0", ("hapke", "paper"), mu=MU, c=C)
    fig, (ax1, ax2) = plt.subplots(1, 2)
    try:
        mesh = heatmap(r, "mu", "c", ax=ax1)
        assert mesh.norm.vmin == 1e-6 and mesh.get_array().shape == (4, 4)
        # rows follow y (c): the row of c = 1 holds the errors at c = 1
        np.testing.assert_allclose(mesh.get_array()[3], np.maximum(r.error[:, 3], 1e-6))
        transposed = heatmap(r, "c", "mu", ax=ax2, colorbar=False)
        np.testing.assert_allclose(transposed.get_array(), mesh.get_array().T)
    finally:
        plt.close(fig)


def test_approximations_lists_presets_then_every_saved_fit(tmp_path):
    for name in ("H0.json", "H0.hapke_rational.json", "H1.json"):
        shutil.copy(FITS / name, tmp_path / name)
    shutil.copy(FITS / "H0.sr_7_6808f1.json", tmp_path / "H0.sr_7_6808f1.json")  # by fitlab discover
    found = approximations("H0", tmp_path)
    assert list(found) == ["hapke / paper", "hapke (H0.json)", "hapke_rational (H0.hapke_rational.json)",
                           "sr_7_6808f1 (H0.sr_7_6808f1.json)"]  # fmt: skip
    assert found["hapke / paper"] == ("hapke", "paper")
    r = residuals("H0", found["hapke_rational (H0.hapke_rational.json)"], mu=MU, c=C)
    assert r.label == "hapke_rational (H0.hapke_rational.json)"
    assert list(approximations("H1", tmp_path))[-1] == "separable (H1.json)"
    assert len(approximations("H1", tmp_path)) == 5  # four published readings and the fit

    shutil.copy(FITS / "H1.json", tmp_path / "H0.misnamed.json")
    with pytest.raises(FitFileError, match="holds a fit of H1"):
        approximations("H0", tmp_path)
