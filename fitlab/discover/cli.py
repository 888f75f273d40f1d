"""``fitlab discover``: the command-line face of :mod:`fitlab.discover`."""

from __future__ import annotations

__all__ = ["add_arguments", "run_discover"]


def add_arguments(p) -> None:
    p.add_argument("--target", required=True, help="what to discover forms for")


def run_discover(args) -> int:
    raise SystemExit("fitlab discover: not yet implemented")
