"""Write the seeds of fitlab's cache of exact values (:mod:`fitlab.cache`): fitlab/data/exact_values, shipped in the
package (the sets of :data:`SHIPPED`: what a fresh install's first ``fitlab codegen`` measures against, read by
the cache where it lacks them), and tests/data/exact_values (the other sets that cost the test suite most), so
that a fresh install and a test run on a fresh machine start with them warm.

Run from the project root, one BLAS thread (about 300 CPU-seconds on the project's 2-core machine):

    python tools/seed_test_cache.py

Each dataset of :func:`_seeded` is computed into an empty cache folder (never read from the shipped seed); the
entries it writes are copied, compressed, into its seed folder (their file names are their cache keys: the fitlab
version, the set's grid and the bytes of the family's exact engine), with MANIFEST.json naming the entries of each
dataset and the fingerprint of the code that computed them (:func:`fingerprint`: the engine and the modules that
assemble the sets).  tests/conftest.py copies the tests' entries into the run's cache before the workers start (an
entry already there is left alone); an edit of the engine or of a set's grid changes the keys, so the copies are
then never read.  tests/test_exact_value_seed.py fails on the fingerprint after any edit of that code, naming the
files, until this script is run again (so that the seeds are what the code computes now), and recomputes a sample
of every dataset with the engine.

Beside fitlab's own sets, the tests' seed holds the exact values some tests compute for themselves on their own
points (tests/exact_cache.py: ``exact.brdf`` through the cache, keyed by its inputs): this script runs those tests,
in a cache folder of their own and without the seed (``--no-exact-seed``), and keeps the entries they write.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "tests" / "data" / "exact_values"
#: the seed fitlab ships (fitlab.resources.packaged_exact_values): the sets of :data:`SHIPPED`
PACKAGED = ROOT / "fitlab" / "data" / "exact_values"
MANIFEST = "MANIFEST.json"
#: the sets a fresh install's first ``fitlab codegen`` measures against (the validation sets of the program's fits and
#: the true BRDF its model is measured against, minutes of CPU): shipped in the package, not in the tests' seed
SHIPPED = (
    "lambert_sphere.h_validation",
    "lambert_sphere.constant_validation",
    "lambert_sphere.kd_of_c_validation",
    "lambert_sphere.brdf_validation(true)",
    "lambert_sphere.accuracy_reference(true)",
)


def _seeded():
    """{dataset name: the call that computes it through the cache}."""
    from fitlab.families.lambert_sphere.program.runtime import accuracy_reference
    from fitlab.families.lambert_sphere.targets import datasets as d
    from fitlab.families.lambert_sphere.targets.tabulate import check_tables
    from fitlab.report import QUICK
    from fitlab.report.validation import fresh_set, validation_sets
    from fitlab.resources import packaged_tables

    def tests_exact_brdf():
        """The calls of tests/exact_cache.py's brdf that its SEEDED_TESTS make: the tests run (in their own cache
        folder, without the seed), and the entries they write are copied into this one."""
        import subprocess

        sys.path.insert(0, str(ROOT / "tests"))
        try:
            import exact_cache
        finally:
            sys.path.pop(0)
        with tempfile.TemporaryDirectory(prefix="fitlab-seed-tests-") as own:
            env = {**os.environ, "FITLAB_CACHE_DIR": own}
            subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "0", "-p", "no:cacheprovider", "--no-exact-seed",
                            *exact_cache.SEEDED_TESTS], cwd=ROOT, env=env, check=True)  # fmt: skip
            for entry in Path(own).glob(f"{exact_cache.NAME}-*.npz"):
                shutil.copyfile(entry, Path(os.environ["FITLAB_CACHE_DIR"]) / entry.name)

    def tabulate_check():
        failures = check_tables(packaged_tables("lambert_sphere"), show_progress=False)
        if failures:
            raise SystemExit(f"the packaged tables fail their check: {failures}")

    return {
        "lambert_sphere.h_validation": lambda: [d.h_validation(m) for m in range(3)],
        "lambert_sphere.kd_of_c_validation": d.kd_of_c_validation,
        "lambert_sphere.constant_validation": lambda: d.constant_validation("H0_inf"),
        "lambert_sphere.brdf_validation(true)": lambda: d.brdf_validation("true"),
        "lambert_sphere.true_orders_training": d.true_orders_training,
        "lambert_sphere.brdf_true_independent": d.brdf_true_independent,
        "lambert_sphere.accuracy_reference(true)": lambda: accuracy_reference(phase="true"),
        "lambert_sphere.tabulate_check": tabulate_check,
        "report.quick": lambda: (validation_sets(QUICK), fresh_set(QUICK)),
        "tests.exact_brdf": tests_exact_brdf,
    }


#: the code that assembles the seeded sets from the engine's values: not part of their cache keys (an edit that
#: keeps a set's grid keeps its key), so the seed is tied to it here
ASSEMBLERS = (
    "fitlab/families/lambert_sphere/targets/datasets.py",
    "fitlab/families/lambert_sphere/program/runtime.py",
    "fitlab/families/lambert_sphere/program/report/materials.py",
    "fitlab/families/lambert_sphere/targets/tabulate.py",
    "fitlab/report/validation.py",
    "tests/exact_cache.py",
)


def fingerprint() -> dict:
    """{"fitlab": the version, file: sha256 (16 hex digits)} of the exact engine's sources and of
    :data:`ASSEMBLERS`: what the seeded values are computed by."""
    import hashlib

    import fitlab
    from fitlab.families.lambert_sphere import exact

    base = Path(fitlab.__file__).resolve().parents[1]  # the folder fitlab is imported from
    files = sorted({Path(p).resolve().relative_to(base).as_posix() for p in exact.SOURCES} | set(ASSEMBLERS))
    digests = {f: hashlib.sha256((base / f).read_bytes()).hexdigest()[:16] for f in files}
    return {"fitlab": fitlab.__version__, **digests}


def main() -> int:
    from tqdm import tqdm

    with tempfile.TemporaryDirectory(prefix="fitlab-seed-") as tmp:
        os.environ["FITLAB_CACHE_DIR"] = str(Path(tmp) / "cache")
        os.environ.pop("FITLAB_NO_CACHE", None)
        cache = Path(os.environ["FITLAB_CACHE_DIR"])
        import fitlab.cache

        fitlab.cache.packaged_exact_values = lambda: Path(tmp) / "none"  # computed afresh, not read from the old seed
        datasets = {}
        seeded = _seeded()
        for name, compute in tqdm(seeded.items(), desc="exact values", unit="set"):
            before = set(cache.glob("*.npz"))
            compute()
            datasets[name] = sorted(p.name for p in set(cache.glob("*.npz")) - before)
            if not datasets[name]:
                raise SystemExit(f"{name} wrote no cache entry")
        for out, names in ((PACKAGED, SHIPPED), (OUT, [n for n in datasets if n not in SHIPPED])):
            _write_seed(out, cache, {n: datasets[n] for n in names})
    return 0


def _write_seed(out: Path, cache: Path, datasets: dict) -> None:
    """The entries of ``datasets`` ({name: entry files}) from ``cache`` into the folder ``out``, compressed, with its
    manifest; staged beside the folder, then swapped in: an interrupted run leaves the old seed whole."""
    import numpy as np

    staging, old = out.parent / f".{out.name}.new", out.parent / f".{out.name}.old"
    for folder in (staging, old):
        shutil.rmtree(folder, ignore_errors=True)
    staging.mkdir(parents=True)
    for entry in sorted({f for files in datasets.values() for f in files}):
        with np.load(cache / entry, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        np.savez_compressed(staging / entry, **arrays)
    manifest = {"made_by": "tools/seed_test_cache.py", "fingerprint": fingerprint(), "datasets": datasets}
    (staging / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    if out.exists():
        out.rename(old)
    staging.rename(out)
    shutil.rmtree(old, ignore_errors=True)
    print(f"wrote {out.relative_to(ROOT)}: {sum(len(v) for v in datasets.values())} entries", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
