"""The notebooks in notebooks/: each runs top to bottom without an error (small
grids: FITLAB_NOTEBOOK_SMALL=1) and every number and fact its text states holds
(the claims of notebooks/_build.py, checked in the notebook's kernel by a cell
appended to the in-memory copy); the committed files carry no outputs and match
their source notebooks/_build.py, and notebooks/README.md describes each one."""

import importlib.util
import os
import re
from pathlib import Path

import nbformat
import pytest

pytestmark = pytest.mark.e2e  # the whole module runs commands end to end

ROOT = Path(__file__).resolve().parents[1]
NB_DIR = ROOT / "notebooks"
NOTEBOOKS = sorted(NB_DIR.glob("*.ipynb"))
CELL_TIMEOUT = 240  # seconds per cell; with small grids the slowest cell takes a few


def _build_module():
    spec = importlib.util.spec_from_file_location("notebooks_build", NB_DIR / "_build.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


BUILD = _build_module()


def test_the_notebooks_are_the_ones_build_writes():
    assert [p.name for p in NOTEBOOKS] == sorted(BUILD.NOTEBOOKS)
    assert BUILD.main(["--check"]) == 0, "a notebook differs from notebooks/_build.py: run python notebooks/_build.py"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_committed_notebook_has_no_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: commit notebooks without outputs"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_notebook_opens_with_its_question_in_two_sentences(path):
    first = nbformat.read(path, as_version=4).cells[0]
    title, _, rest = first.source.partition("\n")
    question = BUILD.QUESTIONS[path.name]
    assert first.cell_type == "markdown" and title.startswith("# ")
    assert rest.lstrip().startswith(f"*{question}*"), f"{path.name}: the question is not the first text"
    assert len(re.findall(r"[.?!](?=\s|$)", question)) == 2 and "?" in question, question


def test_readme_describes_every_notebook():
    text = (NB_DIR / "README.md").read_text()
    missing = [p.name for p in NOTEBOOKS if p.name not in text]
    assert not missing, f"notebooks/README.md does not mention {missing}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_every_claim_is_stated_in_the_committed_text(path):
    claims = BUILD.CLAIMS.get(path.name, [])
    assert claims, f"{path.name} states no claim that the test checks"
    text = "\n".join(c.source for c in nbformat.read(path, as_version=4).cells if c.cell_type == "markdown")
    assert not BUILD.MARKER.search(text), f"{path.name}: a claim's marker left in the text"
    for claim in claims:
        assert claim.sentence() in text, f"{path.name}: claim {claim.key} is not in the text"


def _check(claims, namespace):
    exec(BUILD.check_source(claims), namespace)


def test_the_check_cell_refuses_a_false_claim():
    Claim = BUILD.Claim
    ns = {"x": 2.0, "xs": [0.6, 0.9], "flag": True, "np": None}
    _check(
        [
            Claim("a", "x below {bound}", "x", "<", 3.0),
            Claim("b", "{lo} to {hi}", "xs", "between", (0.5, 1.0), "g"),
            Claim("c", "x is {bound}", "x", "prints as", 2.001, ".2f"),
            Claim("d", "a fact", "flag", "true"),
            Claim("e", "skipped", "undefined_name", "<", 1.0, when="False"),
        ],
        dict(ns),
    )
    for wrong in (
        Claim("a", "x below {bound}", "x", "<", 1.0),
        Claim("b", "", "xs", "between", (0.7, 1.0)),
        Claim("c", "", "x", "prints as", 2.01, ".2f"),
        Claim("d", "", "not flag", "true"),
        Claim("e", "", "[]", "<", 1.0),
    ):
        with pytest.raises(AssertionError, match=wrong.key):
            _check([wrong], dict(ns))


def test_the_build_refuses_an_unstated_claim_and_an_unknown_marker(monkeypatch):
    Claim = BUILD.Claim
    monkeypatch.setitem(
        BUILD.CLAIMS,
        "x.ipynb",
        [Claim("stated", "it holds", "True", "true"), Claim("unstated", "it also holds", "True", "true")],
    )
    with pytest.raises(ValueError, match="unstated"):
        BUILD.build_notebook([BUILD.md("[[stated]]")], "x.ipynb")
    with pytest.raises(ValueError, match="unknown"):
        BUILD.build_notebook([BUILD.md("[[stated]] [[unstated]] [[unknown]]")], "x.ipynb")
    nb = BUILD.build_notebook([BUILD.md("[[stated]] [[unstated]]")], "x.ipynb")
    assert nb.cells[0].source == "it holds it also holds"


#: the notebooks and the site's build share a worker, the notebooks first: the build renders the executed copies
#: these tests leave in $FITLAB_EXECUTED_NOTEBOOKS (tests/conftest.py) instead of running every notebook again
SITE_GROUP = pytest.mark.xdist_group("notebooks-and-site")


@SITE_GROUP
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs_and_its_claims_hold(path):
    before = sorted(NB_DIR.iterdir())
    nb, found = BUILD.execute(path, small=True, timeout=CELL_TIMEOUT)  # raises at the first cell that fails
    assert nb.cells and all(c.execution_count is not None for c in nb.cells if c.cell_type == "code")
    assert [f["key"] for f in found] == [c.key for c in BUILD.CLAIMS[path.name]]
    assert all(f.get("ok") or "skipped" in f for f in found), found
    assert sorted(NB_DIR.iterdir()) == before, "a notebook wrote into notebooks/; write to a temporary folder"
    folder = os.environ.get("FITLAB_EXECUTED_NOTEBOOKS")
    if folder:  # for the site's build (tests/test_site.py)
        part = Path(folder) / f"{path.name}.{os.getpid()}.tmp"
        nbformat.write(nb, part)
        os.replace(part, Path(folder) / path.name)
