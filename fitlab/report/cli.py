"""``fitlab report``: the command-line face of :mod:`fitlab.report`."""

from __future__ import annotations

__all__ = ["add_arguments", "run_report"]


def add_arguments(p) -> None:
    p.add_argument("--out", default="docs", help="folder for report.md, accuracy_vs_cost.png and report.csv")


def run_report(args) -> int:
    raise SystemExit("fitlab report: not yet implemented")
