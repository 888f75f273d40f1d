"""Slow studies are marked @pytest.mark.benchmark and skipped unless asked for
with ``-m benchmark`` (pyproject declares the marker).

BLAS is held to one thread: the suite's linear algebra is small, and on a
shared 2-core machine OpenBLAS's spinning worker threads made single tests take
minutes (test_reference_brdf_edges: 540 s, against 3 min for the whole suite
with one thread).  A pytest plugin (jaxtyping's) loads numpy before any
conftest, so the environment variable alone comes too late for numpy's own
OpenBLAS: threadpoolctl limits the libraries already loaded, and the variable
covers subprocesses and libraries loaded later."""

import os
import tempfile

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# the tests read the tables packaged with fitlab, never a user's data folder (fitlab.resources): this one
# does not exist
os.environ["FITLAB_DATA"] = os.path.join(tempfile.gettempdir(), f"fitlab-tests-no-data-{os.getpid()}")

import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

_BLAS_LIMIT = threadpool_limits(limits=1, user_api="blas")


def pytest_collection_modifyitems(config, items):
    if "benchmark" in (config.getoption("-m") or ""):
        return  # -m benchmark (or an expression naming it) decides by itself
    skip = pytest.mark.skip(reason="slow study: run with pytest -m benchmark")
    for item in items:
        if item.get_closest_marker("benchmark") is not None:
            item.add_marker(skip)
