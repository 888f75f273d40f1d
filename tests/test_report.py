"""fitlab report: the reduced report end to end, determinism, the Pareto front, the rules, bad input.

The quick report runs once through the CLI and once through the API, both reading their validation sets from
the run's cache of exact values (seeded from tests/data/exact_values, as tests/conftest.py does for every
test); every column but the timings must agree.  Computing those sets, writing them to the cache and reading
them back is test_damaged_cache_file_is_a_miss's (and tests/test_exact_value_seed.py recomputes a sample of the
seeded ones).  The module fixture is still the suite's slowest single cost: the two reports build and time
everything else themselves; the full report is `fitlab report`.
"""

import csv
import json
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from fitlab._io import atomic_write_many, temporary_name
from fitlab.cli import main
from fitlab.families.lambert_sphere.program.report.materials import albedos
from fitlab.families.lambert_sphere.program.report.spline_tables import h_interpolant, table_brdf
from fitlab.report import COLUMNS, QUICK, TIMING_COLUMNS, build_report, pareto_front, recommend, write_outputs
from fitlab.report.methods import ReportError, brdf_methods, brdf_report, fit_inventory
from fitlab.report.settings import family_settings

# one worker runs the module: its tests share the quick reports and the programs they build (xdist_group)
pytestmark = pytest.mark.xdist_group("tests/test_report.py")

FITS = Path(__file__).resolve().parents[1] / "fitlab" / "fits"
DATA = Path(__file__).resolve().parents[1] / "fitlab" / "data" / "lambert_sphere"


def _read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """Two quick reports: (out dir of the CLI run, out dir of the API run)."""
    root = tmp_path_factory.mktemp("report")
    assert main(["report", "--quick", "--quiet", "--out", str(root / "a"), "--fits", str(FITS)]) == 0
    write_outputs(build_report(QUICK, FITS, progress=False), root / "b")
    return root / "a", root / "b"


@pytest.mark.e2e
def test_quick_report_writes_the_three_files(quick):
    a, _ = quick
    assert (a / "accuracy_vs_cost.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (a / "report.md").read_text()
    for heading in (
        "## Recommendations",
        "## The BRDF",
        "## The parts",
        "## The exact engine",
        "## Time to reach a given error",
        "## Monte Carlo",
        "## One-off cost of each refit",
    ):
        assert heading in md
    assert "![accuracy vs cost](accuracy_vs_cost.png)" in md
    # the exact engine timed on the points the family's quick settings name, as the text says
    points = family_settings(QUICK, brdf_report()).exact_cost_points
    assert re.search(rf"us per point \({points} points, c = ", md)
    assert not list(a.glob("*.tmp"))


@pytest.mark.e2e
def test_csv_columns_and_contents(quick):
    a, _ = quick
    with open(a / "report.csv", newline="") as fh:
        assert tuple(next(csv.reader(fh))) == COLUMNS
    rows = _read_csv(a / "report.csv")
    sections = {r["section"] for r in rows}
    assert {"brdf", "part", "exact_h", "time_to_error", "refit"} <= sections
    brdf = [r for r in rows if r["section"] == "brdf"]
    groups = {r["group"] for r in brdf}
    assert {"exact", "tables", "published", "refit", "refit, richer", "fast", "baseline", "monte carlo"} <= groups
    for r in brdf:
        if r["group"] not in ("exact",):  # the quick report skips the doubling cross-check
            assert float(r["max_rel"]) >= float(r["rms_rel"]) > 0.0
    # the refit is timed in C, the H0 part is measured by every method
    refit = next(r for r in brdf if r["method"] == "refit")
    assert float(refit["ns_c_double"]) > 0 and float(refit["jax_evals_per_s"]) > 0
    # the parts and refits measured are the family's choice for the quick settings (fitlab.report.QUICK names none)
    fam = family_settings(QUICK, brdf_report())
    assert QUICK.parts is None and QUICK.refits is None
    assert {r["target"] for r in rows if r["section"] == "part"} == set(fam.parts)
    assert {(r["target"], r["method"]) for r in rows if r["section"] == "refit"} == set(fam.refits)
    h0 = {r["method"] for r in rows if r["section"] == "part" and r["target"] == "H0"}
    assert {"exact (Fock/Krein)", "tables", "hapke / paper", "hapke", "hapke_rational"} <= h0
    # the three-order tables are far more accurate than the runtime model (which drops fm2); against the true BRDF
    # both carry the three-term multiple scattering's gap (1.1e-3 measured for the three orders on the quick set,
    # where against the mixed reference they were 2.7e-4: the splines in s = sqrt(1 - c) are coarsest at c = 1e-4)
    tab = {r["method"]: float(r["max_rel"]) for r in brdf if r["group"] == "tables"}
    assert tab["tables, three orders"] < 2.5e-3 and tab["tables, three orders"] < 0.5 * tab["tables, runtime model"]
    # c = 0, the independent set and the energy are measured for every BRDF method (Monte Carlo aside)
    assert float(refit["max_abs_c0"]) == 0.0 and float(refit["albedo_err"]) < 1e-2
    assert float(refit["max_rel_fresh"]) >= float(refit["rms_rel_fresh"]) > 0.0
    paper = next(r for r in brdf if r["method"] == "published: paper")
    assert float(paper["max_abs_c0"]) > 0.0  # the published presets are not 0 at c = 0
    # the grazing set reaches mu = 1e-6, where the separable H1's mu^0.49 makes the runtime model's
    # (H_i H_o - 1)/(mu_i + mu_o) grow like a power of 1/mu: far past the uniform points' max error
    grazing = {r["method"]: float(r["max_rel_grazing"]) for r in brdf if r["max_rel_grazing"]}
    assert grazing["tables, three orders"] < 0.05  # 2e-2 at c = 1e-4 (splines in s), 2e-4 from c = 0.05 up
    assert grazing["refit"] > 10 * float(refit["max_rel"])
    assert all(math.isfinite(g) for g in grazing.values())


@pytest.mark.e2e
def test_non_timing_columns_are_reproducible(quick):
    a, b = quick
    ra, rb = _read_csv(a / "report.csv"), _read_csv(b / "report.csv")
    assert len(ra) == len(rb)
    for x, y in zip(ra, rb):
        for col in COLUMNS:
            if col not in TIMING_COLUMNS:
                assert x[col] == y[col], (col, x, y)


def test_pareto_front_on_a_toy_set():
    costs = [1.0, 2.0, 2.0, 3.0, 4.0, 5.0, math.nan, 1.0, 6.0, 0.5]
    errors = [5.0, 3.0, 4.0, 3.0, 1.0, 0.5, 0.1, 5.0, math.inf, 9.0]
    # index 7 duplicates 0 (first kept), 2 and 3 are dominated by 1, 6 and 8 are not finite
    assert pareto_front(costs, errors) == [9, 0, 1, 4, 5]
    assert pareto_front([], []) == []


def test_pareto_front_matches_the_definition():
    rng = np.random.default_rng(1)
    for _ in range(20):
        c, e = rng.integers(1, 6, 25).astype(float), rng.integers(1, 6, 25).astype(float)
        front = set(pareto_front(list(c), list(e)))
        for i in range(25):
            dominated = any(c[j] <= c[i] and e[j] <= e[i] and (c[j] < c[i] or e[j] < e[i]) for j in range(25))
            duplicate_of_earlier = any(c[j] == c[i] and e[j] == e[i] for j in range(i))
            assert (i in front) == (not dominated and not duplicate_of_earlier)


def test_pareto_front_takes_pairs_and_counts_infinite_errors_on_request():
    """The one front of the report and of fitlab discover (which keeps a candidate of infinite error
    where nothing costs as little)."""
    pts = [(1, math.inf), (2, 0.5), (2, 0.5), (3, 0.1), (math.nan, 0.01)]
    assert pareto_front(pts) == pareto_front([p[0] for p in pts], [p[1] for p in pts]) == [1, 3]
    assert pareto_front(pts, infinite_errors=True) == [0, 1, 3]


def test_recommendations_follow_the_rules():
    def row(name, group, max_rel, rms, c=math.nan, py=math.nan, grazing=0.5, data=400.0):
        return {
            "method": name,
            "group": group,
            "max_rel": max_rel,
            "rms_rel": rms,
            "ns_c_double": c,
            "ns_python": py,
            "max_rel_grazing": grazing,
            "bytes": data,
        }

    rows = [
        row("lambert", "baseline", 1.0, 1e-3, c=1.0),  # never recommended
        row("fast", "fast", 0.5, 0.1, c=70.0),  # too inaccurate for real time
        row("model", "refit", 0.05, 5e-3, c=190.0),
        row("richer", "refit, richer", 0.02, 2e-3, c=200.0),  # within 10 % of the cheapest: more accurate wins
        row("tables", "tables", 1e-4, 1e-6, py=2000.0),
        row("exact", "exact", 1e-13, 1e-14, py=7e4),
    ]
    rec = recommend(rows)
    assert rec["real-time"]["method"] == rec["real-time, texture"]["method"] == "richer"
    assert rec["offline"]["method"] == "tables"
    assert rec["reference"]["method"] == "exact"
    # a texture cheaper and more accurate is the pick of engines that bind one, not of code that reads no table
    texture = row("texture", "tables", 1e-3, 1e-4, c=150.0, data=180e3)
    rec = recommend([*rows, texture])
    assert rec["real-time"]["method"] == "richer" and rec["real-time, texture"]["method"] == "texture"
    rows[3]["ns_c_double"] = 400.0
    assert recommend(rows)["real-time"]["method"] == "model"
    # at grazing angles a real-time model may not be off by more than its own size
    rows[2]["max_rel_grazing"] = 13.0
    assert recommend(rows)["real-time"]["method"] == "richer"
    rows[3]["max_rel_grazing"] = math.nan  # not measured there: not recommended
    assert recommend(rows)["real-time"] is None


def test_tables_interpolate_h_to_the_stated_accuracy():
    from fitlab.families.lambert_sphere.exact import h_function

    mu = np.linspace(0.0, 1.0, 97)
    for order in (0, 1, 2):
        for c in (0.37, 0.9991):
            exact = h_function(order, mu, c, method="fock")
            assert np.max(np.abs(h_interpolant(order, DATA)(mu, c) / exact - 1)) < 1e-5
    f = table_brdf(DATA, order2=True)
    assert np.isfinite(f(np.array([0.0, 0.5]), np.array([1e-3, 0.5]), np.array([0.0, 3.0]), np.array([1.0, 0.5]))).all()


def test_validation_albedos_avoid_the_table_grid():
    c = albedos(15, True)
    s = np.sqrt(1.0 - c[:-1])
    assert c[-1] == 1.0 and np.all(c[:-1] > 0.0)
    assert np.all(np.abs(s * 64 - np.round(s * 64)) > 0.01)


def test_every_fit_file_is_picked_up_and_discovered_forms_are_grouped(tmp_path):
    fits = tmp_path / "fits"
    fits.mkdir()
    for target in ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "kd_of_c", "c_of_kd", "fast_brdf"):  # default forms
        shutil.copy(FITS / f"{target}.json", fits)
    shutil.copy(FITS / "m.quadratic.json", fits)
    rec = json.loads((FITS / "l.cubic.json").read_text())
    rec.update(form="sr_test", origin={"method": "fitlab discover", "seconds": 12.5})
    (fits / "l.sr_test.json").write_text(json.dumps(rec))
    entries = fit_inventory(fits)
    assert len(entries) == 14  # the 12 default fits, m.quadratic and l.sr_test
    found = next(e for e in entries if e.form == "sr_test")
    assert found.kind == "discover" and not found.default
    groups = {m.name: (m.group, m.c.forms if m.c else None) for m in brdf_methods(fits, entries, DATA)}
    assert groups["refit + l sr_test"] == ("discovered", (("l", "sr_test"),))
    assert groups["refit, richer forms"] == ("refit, richer", (("m", "quadratic"),))
    # the best fit of every part, discovered included: l from the discovered file, m the richer refit
    assert groups["best fits (discovered included)"] == ("discovered", (("l", "sr_test"), ("m", "quadratic")))
    assert "refit + l sr_test" not in {m.name for m in brdf_methods(fits, entries, DATA, discovered=False)}


def test_missing_fits_folder_is_a_clear_error(tmp_path, capsys):
    rc = main(["report", "--quick", "--quiet", "--out", str(tmp_path / "out"), "--fits", str(tmp_path / "nope")])
    assert rc == 2
    assert "no such fits folder" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_corrupt_fit_file_is_named(tmp_path, capsys):
    fits = tmp_path / "fits"
    fits.mkdir()
    (fits / "H0.json").write_text("{not json")
    assert main(["report", "--quick", "--quiet", "--out", str(tmp_path / "out"), "--fits", str(fits)]) == 2
    err = capsys.readouterr().err
    assert "H0.json" in err and "corrupt JSON" in err
    with pytest.raises(ReportError, match="no fit files"):
        fit_inventory(tmp_path)


def test_missing_default_fit_fails_before_the_validation_sets(tmp_path, capsys, monkeypatch):
    fits = tmp_path / "fits"
    fits.mkdir()
    shutil.copy(FITS / "m.json", fits)
    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path / "cache"))
    assert main(["report", "--quick", "--quiet", "--out", str(tmp_path / "out"), "--fits", str(fits)]) == 2
    err = capsys.readouterr().err
    assert "no default fit of H0, H1, l, B, C, D, F" in err and "m," not in err
    assert not (tmp_path / "cache").exists() and not (tmp_path / "out").exists()


@pytest.mark.parametrize("damage", [b"", b"PK\x03\x04 not a zip archive"])
def test_damaged_cache_file_is_a_miss(tmp_path, monkeypatch, damage):
    from fitlab.report.validation import exact_values

    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path))
    points, c = np.array([[0.3, 0.6, 0.25]]), np.array([0.5])
    y, kd = exact_values({"test": points}, c, True, None)
    (cached,) = tmp_path.glob("report-test-*.npz")
    cached.write_bytes(damage)
    y2, kd2 = exact_values({"test": points}, c, True, None)  # recomputed, and the cache rewritten
    assert np.array_equal(y["test"], y2["test"]) and np.array_equal(kd, kd2)
    assert np.array_equal(np.load(cached)["y"], y["test"])


def test_unwritable_out_fails_before_any_work(tmp_path, capsys):
    out = tmp_path / "file"
    out.write_text("keep me")
    assert main(["report", "--quick", "--quiet", "--out", str(out)]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert out.read_text() == "keep me"


def test_outputs_are_all_or_nothing(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    temporary_name(tmp_path / "c.txt").mkdir()  # the temporary of c.txt (c.txt.PID.tmp) cannot be written
    with pytest.raises(OSError):
        atomic_write_many({tmp_path / "a.txt": b"new a", tmp_path / "c.txt": b"new c"})
    assert (tmp_path / "a.txt").read_text() == "old a"
    assert not temporary_name(tmp_path / "a.txt").exists() and not (tmp_path / "c.txt").exists()
    (tmp_path / "b.txt").mkdir()  # a folder where a file should go: refused before anything is written
    with pytest.raises(IsADirectoryError):
        atomic_write_many({tmp_path / "a.txt": b"new a", tmp_path / "b.txt": b"new b"})
    assert (tmp_path / "a.txt").read_text() == "old a"
