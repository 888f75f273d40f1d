"""The suite's two workers keep a module with module-scoped fixtures on one worker (tests/conftest.py tags its
tests with an xdist_group; ``--dist loadgroup`` sends a group to one worker), so that a costly fixture (the
quick reports, the runtime model's accuracy figures) is computed once.  pytest 9.2 with pytest-xdist 3.8 ignores
the groups without a word (pytest-dev/pytest-xdist#1386, pyproject pins pytest below 9.2): this runs the
suite's own conftest on a toy folder with two workers and counts the fixture's setups."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

TOY_MODULE = """
import os
import pytest

@pytest.fixture(scope="module")
def costly():
    with open(os.environ["SETUPS_FILE"], "a") as fh:
        fh.write(os.environ.get("PYTEST_XDIST_WORKER", "main") + "\\n")
    return 1

@pytest.mark.parametrize("i", range(12))
def test_uses_the_module_fixture(costly, i):
    assert costly == 1
"""

OTHER_MODULE = """
import pytest

@pytest.mark.parametrize("i", range(12))
def test_plain(i):
    assert i >= 0
"""


def test_a_module_fixture_is_set_up_once_with_two_workers(tmp_path):
    shutil.copy(Path(__file__).with_name("conftest.py"), tmp_path / "conftest.py")
    (tmp_path / "test_grouped.py").write_text(TOY_MODULE)
    (tmp_path / "test_other.py").write_text(OTHER_MODULE)
    setups = tmp_path / "setups.txt"
    env = {**os.environ, "SETUPS_FILE": str(setups)}
    args = ["-q", "-n", "2", "--dist", "loadgroup", "-p", "no:cacheprovider", "--rootdir", str(tmp_path), str(tmp_path)]
    run = subprocess.run([sys.executable, "-m", "pytest", *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=300)  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    assert "24 passed" in run.stdout
    workers = setups.read_text().split()
    assert len(workers) == 1, f"the module fixture was set up on {workers}: the xdist groups are ignored"
