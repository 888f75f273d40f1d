"""The ``fitlab`` command: one module per command under fitlab/cli/, one dispatch, a light ``--help``."""

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

import fitlab.cli
from fitlab.cli import COMMANDS, build_parser, main
from fitlab.core import targets

ROOT = Path(__file__).resolve().parents[1]
NAMES = [
    "tabulate",
    "refit",
    "fit",
    "audit",
    "codegen",
    "render",
    "simulate",
    "discover",
    "report",
    "export",
    "bench",
    "cache",
]


def _python(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True,
                          timeout=300)  # fmt: skip


def test_help_imports_no_jax():
    """``fitlab --help`` (and a command's --help) loads neither JAX nor the other heavy dependencies."""
    code = """
import sys
from fitlab.cli import main
for argv in (["--help"], ["refit", "--help"], ["simulate", "--help"], ["discover", "--help"]):
    try:
        main(argv)
    except SystemExit as exc:
        assert exc.code == 0, (argv, exc.code)
heavy = [m for m in ("jax", "jaxlib", "optimistix", "equinox", "pysindy", "mitsuba") if m in sys.modules]
print("HEAVY", heavy)
"""
    out = _python(code)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "usage: fitlab" in out.stdout
    assert out.stdout.strip().splitlines()[-1] == "HEAVY []"


def test_top_level_help_and_version_import_no_family_and_no_sympy():
    """Only the module of the command being run is imported: ``fitlab --help`` needs none of them."""
    code = """
import sys
from fitlab.cli import main
for argv in (["--help"], ["--version"]):
    try:
        main(argv)
    except SystemExit as exc:
        assert exc.code == 0, (argv, exc.code)
loaded = sorted(m for m in sys.modules if m in ("sympy", "scipy", "numpy", "jax", "fitlab.core")
                or m.startswith("fitlab.families") or m.startswith("fitlab.cli."))
print("LOADED", loaded)
"""
    out = _python(code)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] in ("LOADED ['fitlab.cli._common']", "LOADED []")


def test_one_module_per_command():
    assert list(COMMANDS) == NAMES and all(COMMANDS[n] for n in NAMES)
    for name in NAMES:
        module = importlib.import_module(f"fitlab.cli.{name}")
        assert callable(module.add_arguments) and callable(module.run)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == NAMES
    assert fitlab.cli.main is main


def test_target_help_lists_the_registry(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["refit", "--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert f"what to fit: {', '.join(targets())}" in text


def test_a_command_is_required(capsys):
    with pytest.raises(SystemExit) as exc:
        main([])
    assert exc.value.code == 2
    assert "required: command" in capsys.readouterr().err


@pytest.mark.e2e
def test_python_dash_m_fitlab():
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, "-m", "fitlab", "refit", "--all", "--target", "m"], env=env, cwd=ROOT,
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    assert out.returncode == 2
    assert "fitlab refit: error: give --target NAME (see --list) or --all" in out.stderr


@pytest.mark.parametrize(
    "argv, module, extra",
    [
        (["render", "--out", "{tmp}"], "mitsuba", "render"),
        (["discover", "--target", "kd_of_c", "--out", "{tmp}"], "pysindy", "discover"),
    ],
)
def test_a_missing_extra_is_named_in_one_line(tmp_path, capsys, monkeypatch, argv, module, extra):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == module else real(name, *a))
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"fitlab-brdf[{extra}]" in err
