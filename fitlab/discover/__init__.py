"""Symbolic regression with pysindy: new forms for fitlab's targets (issue 6)."""
