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
import shutil
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# the tests read the tables packaged with fitlab, never a user's data folder (fitlab.resources): this one
# does not exist
os.environ["FITLAB_DATA"] = os.path.join(tempfile.gettempdir(), f"fitlab-tests-no-data-{os.getpid()}")

import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

_BLAS_LIMIT = threadpool_limits(limits=1, user_api="blas")


def pytest_addoption(parser):
    parser.addoption(
        "--no-exact-seed",
        action="store_true",
        help="start the run's cache of exact values without tests/data/exact_values (the seed's maker, "
        "tools/seed_test_cache.py, runs the tests of tests/exact_cache.py so)",
    )


def pytest_configure(config):
    """One set of caches for the whole run, shared by the xdist workers and the subprocesses the tests start
    (the environment carries them):

    * compiled C (``$FITLAB_NATIVE_CACHE``, :func:`fitlab.codegen.native._compile`): a folder made for this
      run (by the controller, before the workers start; removed at its end), so a program that several
      test modules build compiles once, keyed by the sha256 of its sources and command;
    * exact values and JAX's compiled programs (``$FITLAB_CACHE_DIR``, :mod:`fitlab.cache`): the user's cache
      (``$FITLAB_CACHE_DIR`` where set, else the default folder), pinned for the run, and JAX's persistent
      compilation cache enabled in the test processes too.  Entries are keyed by the bytes of the code that
      computes them, so a warm cache is never stale; the tests of the cache itself set their own folder.
      Before the workers start, the entries of tests/data/exact_values (tools/seed_test_cache.py: the exact
      values that cost the suite most, about 270 CPU-seconds) are copied in where the cache lacks them, so a
      first run starts with them warm (unless ``--no-exact-seed``); tests/test_exact_value_seed.py checks them
      against the engine."""
    if not hasattr(config, "workerinput"):  # the controller (or a run without xdist)
        folder = tempfile.mkdtemp(prefix="fitlab-tests-native-")
        config._fitlab_native_cache = folder
        os.environ["FITLAB_NATIVE_CACHE"] = folder
        # the notebooks tests/test_notebooks.py ran, for the site's build (tests/test_site.py); a folder given in
        # the environment is used as it is (the build takes a copy only where its cells are the committed ones)
        if not os.environ.get("FITLAB_EXECUTED_NOTEBOOKS"):
            config._fitlab_notebooks = tempfile.mkdtemp(prefix="fitlab-tests-notebooks-")
            os.environ["FITLAB_EXECUTED_NOTEBOOKS"] = config._fitlab_notebooks
        from fitlab.cache import cache_dir, enabled

        os.environ["FITLAB_CACHE_DIR"] = str(cache_dir())
        if enabled() and not config.getoption("--no-exact-seed"):
            _seed_exact_values(cache_dir())
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        # the processes that run tests; an xdist controller runs none, and JAX's import would only delay the workers
        from fitlab.cache import enable_compilation_cache

        enable_compilation_cache()


#: the seed of the run's cache of exact values (tools/seed_test_cache.py)
SEED = Path(__file__).resolve().parent / "data" / "exact_values"


def _seed_exact_values(cache: Path) -> None:
    """Copy the seed's entries that ``cache`` lacks into it (each as a temporary file, then renamed: a reader sees
    a whole entry or none).  A cache that cannot be written only costs time, as in :mod:`fitlab.cache`."""
    try:
        cache.mkdir(parents=True, exist_ok=True)
        for entry in sorted(SEED.glob("*.npz")):
            if not (cache / entry.name).exists():
                part = cache / f"{entry.name}.{os.getpid()}.tmp"
                shutil.copyfile(entry, part)
                os.replace(part, cache / entry.name)
    except OSError:
        pass


def pytest_unconfigure(config):
    for name in ("_fitlab_native_cache", "_fitlab_notebooks"):
        folder = getattr(config, name, None)
        if folder:
            shutil.rmtree(folder, ignore_errors=True)


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which reads the groups
def pytest_collection_modifyitems(config, items):
    _group_module_fixtures(items)
    _skip_benchmarks(config, items)


def _group_module_fixtures(items):
    """A test that uses a module- or class-scoped fixture runs on the worker that runs the rest of its module
    (xdist_group, honoured by --dist loadgroup), so that the fixture is computed once, not on each worker; a test
    that names its group keeps it."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        if info is None or item.get_closest_marker("xdist_group") is not None:  # a group of its own stands
            continue
        scopes = {d.scope for defs in info.name2fixturedefs.values() for d in defs}
        if scopes & {"module", "class", "package"}:
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))


def _skip_benchmarks(config, items):
    if "benchmark" in (config.getoption("-m") or ""):
        return  # -m benchmark (or an expression naming it) decides by itself
    skip = pytest.mark.skip(reason="slow study: run with pytest -m benchmark")
    for item in items:
        if item.get_closest_marker("benchmark") is not None:
            item.add_marker(skip)
