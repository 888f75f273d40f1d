"""Slow studies are marked @pytest.mark.benchmark and skipped unless asked for
with ``-m benchmark`` (pyproject declares the marker)."""

import pytest


def pytest_collection_modifyitems(config, items):
    if "benchmark" in (config.getoption("-m") or ""):
        return  # -m benchmark (or an expression naming it) decides by itself
    skip = pytest.mark.skip(reason="slow study: run with pytest -m benchmark")
    for item in items:
        if item.get_closest_marker("benchmark") is not None:
            item.add_marker(skip)
