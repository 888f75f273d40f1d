"""``fitlab refit`` keeps the better fit: a refit worse on the validation set than the fit already in
``--out`` (measured again there), or fitted over another domain, replaces it only with ``--force``; it says
so in one line and exits 1."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from fitlab.cli import main

FITS = Path(__file__).resolve().parents[1] / "fitlab" / "fits"
NAME = "m.quadratic.json"  # what `fitlab refit --target m` writes: the form the default model prints


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


def test_a_worse_refit_keeps_the_better_fit_unless_forced(tmp_path, capsys):
    out = tmp_path / "fits"
    out.mkdir()
    shutil.copy(FITS / NAME, out / NAME)  # the committed minimax fit
    committed = (out / NAME).read_bytes()
    # least squares only: better than its start and the presets, worse in max error than the minimax fit
    assert main(["refit", "--target", "m", "--no-minimax", "--out", str(out), "--quiet", "--json"]) == 1
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    assert f"worse than the fit in {out / NAME}" in line and "--force" in line and "nothing written" in line
    summary = json.loads(captured.out)
    assert summary["written"] is False and "worse than the fit in" in summary["fits"][0]["failure"]
    assert (out / NAME).read_bytes() == committed
    assert sorted(p.name for p in out.iterdir()) == [NAME]  # no temporary left

    assert main(["refit", "--target", "m", "--no-minimax", "--out", str(out), "--quiet", "--force"]) == 0
    assert capsys.readouterr().err == ""
    forced = json.loads((out / NAME).read_text())
    assert forced["validation"]["max_rel"] > json.loads(committed)["validation"]["max_rel"]

    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 0  # better: replaces it
    assert capsys.readouterr().err == ""
    assert json.loads((out / NAME).read_text())["validation"]["max_rel"] < forced["validation"]["max_rel"]


def _stub_refit(monkeypatch):
    """The 'refit' of m is its committed fit (no solve)."""
    import fitlab.cli.refit
    from fitlab.fit.refit import RefitResult
    from fitlab.store import read_fit

    monkeypatch.setattr(
        fitlab.cli.refit,
        "timed_refit",
        lambda target, form, **kwargs: (RefitResult(read_fit(FITS / NAME), fit=None), 0.01),
    )


def test_a_fit_over_another_domain_is_kept_unless_forced(tmp_path, monkeypatch, capsys):
    _stub_refit(monkeypatch)
    out = tmp_path / "fits"
    out.mkdir()
    record = json.loads((FITS / NAME).read_text())
    record["domain"] = {"c": [0.5, 1.0]}
    (out / NAME).write_text(json.dumps(record))
    old = (out / NAME).read_bytes()
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert "over c=0.5:1" in line and "over c=0:1" in line and "not comparable" in line and "--force" in line
    assert (out / NAME).read_bytes() == old
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet", "--force"]) == 0
    assert json.loads((out / NAME).read_text())["domain"] == {"c": [0.0, 1.0]}


def test_an_equal_fit_or_a_file_that_is_not_a_fit_is_replaced(tmp_path, monkeypatch, capsys):
    _stub_refit(monkeypatch)
    out = tmp_path / "fits"
    out.mkdir()
    shutil.copy(FITS / NAME, out / NAME)
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 0  # the same fit: not worse
    (out / NAME).write_text("not a fit")
    assert main(["refit", "--target", "m", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert f"wrote {out / NAME} (replacing a file that was not a readable fit of m/quadratic" in captured.out
    assert json.loads((out / NAME).read_text())["params"] == json.loads((FITS / NAME).read_text())["params"]
