"""The accuracy-vs-cost report (issue 7)."""
