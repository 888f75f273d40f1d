"""The notebooks in notebooks/: each runs top to bottom without an error (small
grids: FITLAB_NOTEBOOK_SMALL=1), the committed files carry no outputs and match
their source notebooks/_build.py, and notebooks/README.md describes each one."""

import importlib.util
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parents[1]
NB_DIR = ROOT / "notebooks"
NOTEBOOKS = sorted(NB_DIR.glob("*.ipynb"))
CELL_TIMEOUT = 240  # seconds per cell; with small grids the slowest cell takes a few


def _build_module():
    spec = importlib.util.spec_from_file_location("notebooks_build", NB_DIR / "_build.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_notebooks_are_the_ones_build_writes():
    build = _build_module()
    assert [p.name for p in NOTEBOOKS] == sorted(build.NOTEBOOKS)
    assert build.main(["--check"]) == 0, "a notebook differs from notebooks/_build.py: run python notebooks/_build.py"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_committed_notebook_has_no_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: commit notebooks without outputs"


def test_readme_describes_every_notebook():
    text = (NB_DIR / "README.md").read_text()
    missing = [p.name for p in NOTEBOOKS if p.name not in text]
    assert not missing, f"notebooks/README.md does not mention {missing}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_top_to_bottom(path, monkeypatch):
    monkeypatch.setenv("FITLAB_NOTEBOOK_SMALL", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    # the exact engine's small linear solves: a second BLAS thread gains nothing, and on a
    # busy 2-core machine OpenBLAS's spinning threads made them 10x slower (measured)
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    before = sorted(NB_DIR.iterdir())
    nb = nbformat.read(path, as_version=4)  # executed in memory: the committed file is never written
    client = NotebookClient(nb, timeout=CELL_TIMEOUT, kernel_name="python3", resources={"metadata": {"path": str(NB_DIR)}})
    client.execute()  # raises CellExecutionError at the first cell that fails
    ran = [c for c in nb.cells if c.cell_type == "code"]
    assert ran and all(c.execution_count is not None for c in ran)
    assert sorted(NB_DIR.iterdir()) == before, "a notebook wrote into notebooks/; write to a temporary folder"
