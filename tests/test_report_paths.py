"""The report names its fits folder as a person reads it (fitlab.report.write.as_shown): relative to the folder
it runs in when the fits lie there, as given otherwise; the rows it is handed are not edited."""

from __future__ import annotations

from fitlab.report.run import Report
from fitlab.report.write import as_shown, csv_text


def _report(folder) -> Report:
    row = {
        "section": "brdf",
        "method": f"default forms in {folder}",
        "source": f"{folder}/H0.log_exp.json",
        "max_rel": 1e-3,
    }
    return Report(
        settings=None,
        rows=[row],
        recommendations={"real-time": row, "offline": None},
        context={"fits_dir": str(folder)},
    )


def test_a_fits_folder_inside_the_current_folder_is_named_relative_to_it(tmp_path):
    folder = tmp_path / "fitlab" / "fits"
    report = _report(folder)
    shown = as_shown(report, cwd=tmp_path)
    assert shown.context["fits_dir"] == "fitlab/fits"
    assert shown.rows[0]["source"] == "fitlab/fits/H0.log_exp.json"
    assert shown.rows[0]["method"] == "default forms in fitlab/fits"
    assert shown.recommendations == {"real-time": shown.rows[0], "offline": None}
    assert str(tmp_path) not in csv_text(shown.rows)
    assert report.rows[0]["source"] == f"{folder}/H0.log_exp.json"  # the report handed in is unchanged
    assert report.context["fits_dir"] == str(folder)


def test_a_fits_folder_elsewhere_keeps_its_path(tmp_path):
    folder = tmp_path / "elsewhere" / "fits"
    report = _report(folder)
    assert as_shown(report, cwd=tmp_path / "work") is report
    assert as_shown(_report(""), cwd=tmp_path).context["fits_dir"] == ""
