"""Every packaged fit holds the accuracy its file states, measured again on its target's validation set.

codegen, the report and the runtime models refuse a fit whose re-measured max or RMS error is more than
fitlab.fit.verify.TOLERANCE worse than its record (`fitlab report` stopped on fast_brdf.sr_3_cbb318.json,
which stated 0.331 against 0.365 measured, after fast_brdf's validation set had changed).  Here every file in
fitlab/fits is measured, not only those the default programs print.
"""

from __future__ import annotations

import pytest

from fitlab.fit.verify import verify_fit
from fitlab.resources import packaged_fits
from fitlab.store import load

FILES = sorted(p.name for p in packaged_fits().glob("*.json"))


@pytest.mark.parametrize("name", FILES)
def test_a_packaged_fit_measures_what_its_file_states(name):
    fit = load(packaged_fits() / name)
    measured = verify_fit(fit)  # raises FitFileError past the tolerance, or where the fit is not finite
    recorded = fit.record["validation"]
    assert measured["points"] == recorded["points"], "the validation set changed since the fit was measured"
