"""Every ``:func:``, ``:mod:``, ``:data:`` ... reference in fitlab's docstrings names something that exists from where
it is written (relative ones from the module's package, as imports are): the rule of the site's API reference
(tools/site/crossrefs.py, whose strict build fails on the same), read statically by griffe, in the quick loop."""

from __future__ import annotations

import sys
from pathlib import Path

import griffe

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools" / "site"))

from crossrefs import unresolved  # noqa: E402


def test_every_docstring_reference_resolves():
    root = griffe.load("fitlab", search_paths=[str(ROOT)], resolve_aliases=False)
    bad = unresolved(root)
    assert not bad, "references that name nothing: " + "; ".join(f"{where}: {ref}" for where, ref in bad)
