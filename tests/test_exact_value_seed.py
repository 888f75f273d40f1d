"""tests/data/exact_values, the seed of the run's cache of exact values (tools/seed_test_cache.py; copied in by
tests/conftest.py): what the suite starts warm with is what the engine computes now.

* The code that computed the seed (the exact engine and the modules that assemble the sets) is the code now:
  after an edit of the engine the seed's keys are never read (each set is then computed in the run, as on a
  machine without the seed), and after an edit of the assembling code the seed would no longer show what that
  code computes; the test names the files and says to run the tool again.
* Every entry the manifest names is in the run's cache.
* Each dataset the cache serves is, at a sample (one albedo, every point of it, plus c = 1 where the set has
  it), what the engine computes in this test: the values are the engine's, not copies of something else.
  Another machine's BLAS may round differently, so the comparison is to 1e-12 relative, far below every
  tolerance the suite's figures are held to.
"""

import inspect
import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

from fitlab.cache import INPUT_PREFIX, cache_dir, enabled
from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.program.runtime import accuracy_points, accuracy_reference
from fitlab.families.lambert_sphere.targets import datasets as d

ROOT = Path(__file__).resolve().parents[1]
RTOL = 1e-12
#: the rounding allowed near a zero, in ulps of the largest value compared (:func:`_close`)
ZERO_ULPS = 64

# the sample's solves are shared by the tests below: one worker runs them all
pytestmark = pytest.mark.xdist_group("tests/test_exact_value_seed.py")


def _tool():
    """tools/seed_test_cache.py, the seed's maker: the owner of its folder, its manifest and its fingerprint."""
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        import seed_test_cache
    finally:
        sys.path.pop(0)
    return seed_test_cache


SEED = _tool().OUT
#: the seed fitlab ships (fitlab.resources.packaged_exact_values), made by the same tool
PACKAGED = _tool().PACKAGED


def _manifest(folder: Path = SEED) -> dict:
    return json.loads((folder / _tool().MANIFEST).read_text())


@pytest.mark.parametrize("folder", [SEED, PACKAGED], ids=["tests", "packaged"])
def test_the_seed_was_made_by_this_code(folder):
    made, now = _manifest(folder)["fingerprint"], _tool().fingerprint()
    changed = sorted(f for f in made.keys() | now.keys() if made.get(f) != now.get(f))
    assert not changed, (
        f"{folder.relative_to(ROOT)} was made by other code ({', '.join(changed)} changed since): "
        "run python tools/seed_test_cache.py"
    )


def test_the_manifests_name_every_seeded_set_and_file():
    manifests = {folder: _manifest(folder) for folder in (SEED, PACKAGED)}
    assert set(manifests[PACKAGED]["datasets"]) == set(_tool().SHIPPED)
    assert {n for m in manifests.values() for n in m["datasets"]} == set(CHECKS)
    for folder, manifest in manifests.items():
        named = {f for files in manifest["datasets"].values() for f in files}
        assert named == {p.name for p in folder.glob("*.npz")}, folder


def test_the_packaged_seed_is_what_the_package_finds():
    from fitlab.resources import packaged_exact_values

    assert packaged_exact_values().resolve() == PACKAGED.resolve()


def test_a_fresh_install_measures_its_first_codegen_without_computing_exact_values(tmp_path, monkeypatch):
    """In an empty cache, the measurements of the default program's first ``fitlab codegen`` (each fit on its
    target's validation set, the model against the true BRDF) find every exact value they need in the packaged
    seed: what they compute themselves is only the model's own figures (its energy scale and accuracy)."""
    from fitlab.codegen import program_spec
    from fitlab.core import get_target
    from fitlab.fit.verify import verify_fit
    from fitlab.store import fit_source, load

    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path))
    spec = program_spec("lambert_sphere")
    model = spec.model()
    forms = {t: model.forms.get(t, get_target(t).default_form) for t in spec.fits}
    fits = {t: load(fit_source(None, t, forms[t], model.folder)) for t in spec.fits}
    for fit in fits.values():
        verify_fit(fit)
    assert spec.claim is not None
    spec.claim(fits, spec.terms)
    made = {p.name for p in tmp_path.glob("*.npz")}
    computed = made - {p.name for p in PACKAGED.glob("*.npz")}
    assert all(n.startswith(("lambert_sphere-energy-scale-", "lambert_sphere-model-accuracy-")) for n in computed), (
        f"computed, not in the packaged seed: {sorted(computed)}: run python tools/seed_test_cache.py"
    )


@pytest.mark.skipif(not enabled(), reason="the cache is off (FITLAB_NO_CACHE)")
def test_the_run_cache_holds_every_seeded_entry():
    if not os.access(cache_dir(), os.W_OK):
        pytest.skip(f"the run's cache {cache_dir()} cannot be written: the seed could not be copied (only costs time)")
    missing = [p.name for p in SEED.glob("*.npz") if not (cache_dir() / p.name).exists()]
    assert not missing, f"not copied into the run's cache {cache_dir()}: {missing}"


def _close(got, want, label):
    """got = want to RTOL relative, or to ZERO_ULPS ulps of the largest of ``want`` where a value is near a zero
    of the quantity (there its last bits are rounding, which another numpy or BLAS build does differently)."""
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, label
    both_inf = np.isinf(got) & np.isinf(want) & (np.sign(got) == np.sign(want))
    finite = np.abs(want[np.isfinite(want)])
    rounding = ZERO_ULPS * np.finfo(float).eps * (finite.max() if finite.size else 0.0)
    scale = np.maximum(np.abs(want), np.finfo(float).tiny)
    with np.errstate(invalid="ignore"):  # inf - inf where both are the same infinity
        diff = np.where(both_inf, 0.0, np.abs(got - want))
    err = np.where(diff <= rounding, 0.0, diff / scale)
    assert np.all(err <= RTOL), f"{label}: {np.nanmax(err):.2e} relative"


def _sample(values):
    """c = 1 (its solution is shared by every check: the engine keeps about two albedos) and the middle albedo."""
    distinct = np.unique(values)
    assert distinct[-1] == 1.0
    return 1.0, float(distinct[distinct.size // 2])


def _kd_of_c_validation():
    ds = d.kd_of_c_validation()
    c = ds.inputs["c"]
    for cv in _sample(c):
        k = np.flatnonzero(c == cv)
        _close(ds.y[k], exact.spherical_albedo(c[k], phase="true"), f"kd_true at c = {cv}")


def _constant_validation():
    sample = np.array(_sample(d.constant_validation("l").inputs["c"]))
    want = exact.constants(sample)
    for name in want:
        got = d.constant_validation(name)
        k = [int(np.flatnonzero(got.inputs["c"] == cv)[0]) for cv in sample]
        _close(got.y[k], want[name], f"constant {name}")


def _brdf_validation_true():
    ds = d.brdf_validation("true")
    x = ds.inputs
    for cv in _sample(x["c"]):
        sel = x["c"] == cv
        _close(ds.y[sel], exact.brdf(x["mu_i"][sel], x["mu_o"][sel], x["phi"][sel], cv, phase="true"), f"f at c = {cv}")
        _close(x["kd"][sel], np.full(sel.sum(), exact.spherical_albedo(cv, phase="true")), f"kd at c = {cv}")
        modes = exact.multiple_scattering_modes(x["mu_i"][sel], x["mu_o"][sel], cv, phase="true")
        for m in range(3):
            _close(ds.aux[f"fm{m}"][sel], modes[m], f"fm{m} at c = {cv}")


def _true_orders_training():
    ds = d.true_orders_training()
    x = ds.inputs
    phi = np.linspace(0.0, np.pi, 33)
    for cv in _sample(x["c"]):
        sel = x["c"] == cv
        mi, mo = x["mu_i"][sel], x["mu_o"][sel]
        modes = exact.multiple_scattering_modes(mi, mo, cv, phase="true")
        for m in range(3):
            _close(ds.aux[f"fm{m}"][sel], modes[m], f"fm{m} at c = {cv}")
        f = exact.brdf(mi[None, :], mo[None, :], phi[:, None], cv, phase="true")
        _close(ds.aux["scale"][sel], f.min(axis=0), f"scale at c = {cv}")


def _brdf_true_independent():
    ds = d.brdf_true_independent()
    x = ds.inputs
    for cv in _sample(x["c"]):
        sel = x["c"] == cv
        _close(ds.y[sel], exact.brdf(x["mu_i"][sel], x["mu_o"][sel], x["phi"][sel], cv, phase="true"), f"f at c = {cv}")


def _accuracy_reference_true():
    ref = accuracy_reference(phase="true")
    pts = accuracy_points()
    for cv in _sample(pts["main"]["c"]):
        for name, p in pts.items():
            sel = p["c"] == cv
            want = exact.brdf(p["mu_i"][sel], p["mu_o"][sel], p["phi"][sel], cv, phase="true")
            _close(ref[name][sel], want, f"{name} at c = {cv}")
    albedo_c = inspect.signature(accuracy_reference).parameters["albedo_c"].default
    mu = np.concatenate(([1e-3], np.arange(1, 21) / 20))  # the default albedo cosines (accuracy's docstring)
    k = len(albedo_c) // 2
    _close(ref["albedo"][k], exact.albedo(mu, albedo_c[k], phase="true"), f"albedo at c = {albedo_c[k]}")


def _seeded_entry(file: str) -> dict:
    """The arrays of the seed's entry ``file``."""
    with np.load(SEED / file, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _tabulate_check():
    """The references of `fitlab tabulate --check` (each entry holds the rows it is the reference of): at c = 1
    and the middle albedo for H, the constants and kd, the first rows of the three-term orders and of the
    sampler's finer rule."""
    from fitlab.families.lambert_sphere.exact.sampling import relative_variance
    from fitlab.families.lambert_sphere.targets.table_files import TRUE_ORDERS

    files = _manifest()["datasets"]["lambert_sphere.tabulate_check"]
    seen = set()
    for file in files:
        e = _seeded_entry(file)
        what = file.split("-")[2]  # lambert_sphere-check-WHAT-...
        seen.add(what)
        if what in ("h0", "h1", "h2"):
            for cv in _sample(e["in_c"]):
                sel = e["in_c"] == cv
                want = exact.h_function(int(what[1]), e["in_mu"][sel], e["in_c"][sel], method="fock")
                _close(e["h"][sel], want, f"{what} at c = {cv}")
        elif what == "constants":
            c = np.array(_sample(e["in_c"]))
            want = exact.constants(c)
            k = [int(np.flatnonzero(e["in_c"] == cv)[0]) for cv in c]
            for name in exact.CONSTANT_NAMES:
                _close(e[name][k], want[name], f"check's {name}")
        elif what == "kd":
            c = np.array(_sample(e["in_c"]))
            k = [int(np.flatnonzero(e["in_c"] == cv)[0]) for cv in c]
            for phase in ("three_term", "mixed", "true"):
                _close(e[phase][k], exact.spherical_albedo(c, phase=phase), f"check's kd_{phase}")
        elif what == "true":  # lambert_sphere-check-true-orders-...
            c, mi, mo = float(e["in_c"][0]), e["in_mu_i"][:3], e["in_mu_o"][:3]
            orders = exact.multiple_scattering_orders(mi, mo, c, phase="three_term", orders=TRUE_ORDERS)
            for m in range(TRUE_ORDERS):
                _close(e[f"fm{m}_three_term"][:3], orders[m], f"check's fm{m}_three_term at c = {c}")
        elif what == "sampling":
            c, args = float(e["in_c"][0]), (e["in_mu_i"][:1], e["in_weight"][:1], e["in_exponent"][:1])
            _close(e["fine"][:1], relative_variance(args[0], c, args[1], args[2], nodes=(64, 12)), f"{file} fine")
        else:
            raise AssertionError(f"{file}: no check for a reference of kind {what}")
    assert seen == {"h0", "h1", "h2", "constants", "kd", "true", "sampling"}, seen


def _report_quick():
    """The quick report's validation, grazing and independent sets (fitlab.report.validation): the first 64
    points of each at its middle albedo (the first two share theirs)."""
    from fitlab.report import QUICK
    from fitlab.report.validation import fresh_set, validation_sets

    valid, grazing = validation_sets(QUICK)
    fresh = fresh_set(QUICK)
    for label, ds in (("validation", valid), ("grazing", grazing), ("independent", fresh)):
        x = ds.inputs
        distinct = np.unique(x["c"])
        cv = float(distinct[distinct.size // 2])
        sel = np.flatnonzero(x["c"] == cv)[:64]
        want = exact.brdf(x["mu_i"][sel], x["mu_o"][sel], x["phi"][sel], cv, phase="true")
        _close(ds.y[sel], want, f"report {label} set at c = {cv}")
        _close(x["kd"][sel[:1]], [exact.spherical_albedo(cv, phase="true")], f"report {label} kd at c = {cv}")


def _tests_exact_brdf():
    """The exact values tests compute for themselves (tests/exact_cache.py; each entry holds its inputs), at a
    sample of two albedos (a solve each): up to 20 rows of every entry at c = 1 and at the first albedo other
    than 1 of the first entry."""
    import exact_cache

    files = _manifest()["datasets"]["tests.exact_brdf"]
    assert files
    entries = {file: {k: v.ravel() for k, v in _seeded_entry(file).items()} for file in files}
    other = next(float(v) for e in entries.values() for v in e["in_c"] if v != 1.0)
    checked = 0
    for file, e in sorted(entries.items()):
        phase = file[len(exact_cache.NAME) + 1 :].rsplit("-", 1)[0]  # NAME-PHASE-KEY.npz
        for cv in (1.0, other):
            sel = np.flatnonzero(e["in_c"] == cv)[:20]
            if sel.size:
                x = {k: e[INPUT_PREFIX + k][sel] for k in exact_cache.INPUTS}
                _close(e["f"][sel], exact.brdf(x["mu_i"], x["mu_o"], x["phi"], cv, phase=phase), f"{file} at c = {cv}")
                checked += sel.size
    assert checked


def _h_validation():
    """H0, H1, H2 on their validation sets at c = 1 and the middle albedo."""
    for m in range(3):
        ds = d.h_validation(m)
        x = ds.inputs
        for cv in _sample(x["c"]):
            sel = x["c"] == cv
            _close(ds.y[sel], exact.h_function(m, x["mu"][sel], cv), f"H{m} at c = {cv}")


#: the check of each seeded dataset, by its name in the manifest
CHECKS = {
    "lambert_sphere.h_validation": _h_validation,
    "lambert_sphere.kd_of_c_validation": _kd_of_c_validation,
    "lambert_sphere.constant_validation": _constant_validation,
    "lambert_sphere.brdf_validation(true)": _brdf_validation_true,
    "lambert_sphere.true_orders_training": _true_orders_training,
    "lambert_sphere.brdf_true_independent": _brdf_true_independent,
    "lambert_sphere.accuracy_reference(true)": _accuracy_reference_true,
    "lambert_sphere.tabulate_check": _tabulate_check,
    "report.quick": _report_quick,
    "tests.exact_brdf": _tests_exact_brdf,
}


@pytest.mark.parametrize("name", sorted(CHECKS))
def test_each_seeded_set_is_what_the_engine_computes(name):
    CHECKS[name]()
