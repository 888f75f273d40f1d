"""Every command refuses a bad input or output location in one line, with exit status 2, before any work;
outputs of several files are all-or-nothing; a refit worse than its start is a failure that writes nothing.

The core function of each command is replaced by one that raises :class:`Started` (not an Exception, so
nothing in fitlab catches it): a refusal that reaches it would fail the test.  ``simulate`` belongs to its
own tests (tests/test_mc_simulate.py).
"""

from __future__ import annotations

import json
import math
import os
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fitlab.cli import main

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
GENERATED = FITS / "generated" / "lambert_sphere_drjit.py"
EXAMPLE_TABLE = ROOT / "fitlab" / "data" / "examples" / "renderer_E.csv"


class Started(BaseException):
    """A computation started although the request was refused."""


def _boom(*args, **kwargs):
    raise Started("computation started")


# command -> (argv without --out, [(module, attribute) of its core functions])
COMMANDS = {
    "tabulate": (
        ["tabulate", "--quiet"],
        [
            ("fitlab.families.lambert_sphere.targets.tabulate", "write_tables"),
            ("fitlab.families.lambert_sphere.targets.tabulate", "build_tables"),
        ],
    ),
    "refit": (
        ["refit", "--target", "l", "--quiet", "--fits", str(FITS)],
        [("fitlab.fit.refit", "refit"), ("fitlab.fit.refit", "timed_refit")],
    ),
    "refit --all": (
        ["refit", "--all", "--quiet"],
        [("fitlab.fit.refit", "refit"), ("fitlab.fit.refit", "timed_refit")],
    ),
    "fit": (
        ["fit", str(EXAMPLE_TABLE), "--target", "E", "--form", "a0 + a1*mu + a2*alpha", "--quiet"],
        [("fitlab.fit.user", "run_fit"), ("fitlab.fit.refit", "refit")],
    ),
    "audit": (["audit", "--fits", str(FITS)], [("fitlab.families.lambert_sphere.program.report.audit", "audit")]),
    "codegen": (["codegen", "--lang", "c", "--fits", str(FITS)], [("fitlab.codegen", "generate")]),
    "render": (
        ["render", "--generated", str(GENERATED), "--quiet"],
        [("fitlab.families.lambert_sphere.mitsuba.render", "render_comparison")],
    ),
    "discover": (
        ["discover", "--target", "H0", "--fits", str(FITS), "--quiet"],
        [("fitlab.discover.search", "discover")],
    ),
    "report": (["report", "--quick", "--quiet", "--fits", str(FITS)], [("fitlab.report", "build_report")]),
    "export": (
        ["export", "dfg_karis", "--size", "4", "--quiet"],
        [("fitlab.families.microfacet_energy.program.images", "dfg"), ("fitlab.export", "encode")],
    ),
}

#: the flag that names a command's output folder: --out, but tabulate writes into the data folder
OUT_FLAG = {"tabulate": "--data"}


@pytest.fixture
def guarded(monkeypatch):
    """Every command's core function raises Started, where it is defined and wherever a command module
    imported it by name (the command modules are imported first, so each binds the real function)."""
    import importlib

    from fitlab.cli import COMMANDS as NAMES
    from fitlab.cli import command_module

    commands = [command_module(n) for n in NAMES]
    for _, cores in COMMANDS.values():
        for module, name in cores:
            owner = importlib.import_module(module)
            real = getattr(owner, name)
            monkeypatch.setattr(owner, name, _boom)
            for command in commands:
                if getattr(command, name, None) is real:
                    monkeypatch.setattr(command, name, _boom)
    return monkeypatch


def _status(argv) -> int:
    """main's exit status, whether it returns it or argparse exits."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def _refused(argv, capsys, *words) -> str:
    t0 = time.perf_counter()
    status = _status(argv)
    elapsed = time.perf_counter() - t0
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert status == 2, (argv, status, err)
    assert err and "\n" not in err, err  # one line
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert elapsed < 5, (argv, elapsed)
    return err


# -- the output folder --------------------------------------------------------------
@pytest.mark.parametrize("command", list(COMMANDS))
def test_out_in_proc_is_refused_before_any_work(guarded, capsys, command):
    argv, _ = COMMANDS[command]
    flag = OUT_FLAG.get(command, "--out")
    _refused([*argv, flag, "/proc/x"], capsys, f"{flag} /proc/x")


@pytest.mark.parametrize("command", list(COMMANDS))
def test_out_naming_an_existing_file_is_refused(guarded, capsys, tmp_path, command):
    argv, _ = COMMANDS[command]
    flag = OUT_FLAG.get(command, "--out")
    a_file = tmp_path / "a_file"
    a_file.write_text("keep me")
    _refused([*argv, flag, str(a_file)], capsys, "not a folder")
    assert a_file.read_text() == "keep me"
    _refused([*argv, flag, str(a_file / "sub")], capsys, "not a folder")  # below a file
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file"]


@pytest.mark.parametrize("command", list(COMMANDS))
def test_out_without_write_permission_is_refused(guarded, capsys, tmp_path, command):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as root: a folder without write permission is still writable")
        argv, _ = COMMANDS[command]
        flag = OUT_FLAG.get(command, "--out")
        _refused([*argv, flag, str(locked / "new")], capsys, "not writable")
        _refused([*argv, flag, str(locked)], capsys, "not writable")
    finally:
        locked.chmod(stat.S_IRWXU)


def test_a_missing_out_folder_is_not_created_by_a_refusal(guarded, capsys, tmp_path):
    _refused(["refit", "--target", "l", "--domain", "c=0.5:2", "--out", str(tmp_path / "new")], capsys, "--domain")
    assert not (tmp_path / "new").exists()
    assert not list(tmp_path.iterdir())  # the write probe left nothing


# -- bad values ---------------------------------------------------------------------
BAD = [
    (["refit", "--target", "H3"], "unknown target"),
    (["refit", "--target", "l", "--domain", "c=abc:1"], "must be numbers"),
    (["refit", "--target", "l", "--domain", "c=0.5:0.2"], "LO < HI"),
    (["refit", "--target", "l", "--domain", "c=nan:1"], "LO < HI"),
    (["refit", "--target", "l", "--domain", "c=-inf:1"], "LO < HI"),
    (["refit", "--target", "l", "--domain", "c=0:1", "--domain", "c=0.5:1"], "given twice"),
    (["refit", "--target", "l", "--target", "m"], "--target: given twice (l, then m)"),
    (["refit", "--target", "l", "--form", "cubic", "--form", "quadratic"], "--form: given twice"),
    (["refit", "--target", "l", "--init", "a.json", "--init", "b.json"], "--init: given twice"),
    (["refit", "--target", "l", "--init", "/nonexistent/l.json"], "no such file"),
    (["refit", "--target", "l", "--init", "/proc"], "not a file"),
    (["refit", "--target", "l", "--form", "nope"], "has no form"),
    (["refit", "--all", "--target", "l"], "--target NAME"),
    (["refit", "--all", "--domain", "c=0:1"], "go with --target"),
    (["render", "--generated", str(GENERATED), "--kd", "1.5"], "--kd"),
    (["render", "--generated", str(GENERATED), "--kd", "nan"], "--kd"),
    (["render", "--generated", str(GENERATED), "--kd", "0"], "--kd"),
    (["render", "--generated", str(GENERATED), "--size", "2"], "--size"),
    (["render", "--generated", str(GENERATED), "--size", "1e9"], "--size"),
    (["render", "--generated", str(GENERATED), "--spp", "abc"], "--spp"),
    (["render", "--generated", str(GENERATED), "--lights", "9"], "--lights"),
    (["render", "--generated", "/nonexistent.py"], "fitlab codegen --lang drjit"),
    (["render", "--generated", str(GENERATED), "--variant", "cuda_ad_rgb"], "invalid choice"),
    (["discover", "--target", "H0", "--max-terms", "0"], "--max-terms"),
    (["discover", "--target", "H0", "--minimax-rounds", "-1"], "--minimax-rounds"),
    (["discover", "--target", "nope"], "no discovery library"),
    (["codegen", "--lang", "c", "--terms", "bogus"], "single, m0, m1"),
    (["codegen", "--lang", "fortran"], "invalid choice"),
    (["codegen", "--lang", "c", "--form", "H0"], "TARGET=FORM"),
    (["codegen", "--lang", "c", "--fits", "/proc/version"], "not a folder"),
    (["audit", "--fits", "/nonexistent"], "no such folder"),
    (["report", "--quick", "--fits", "/proc/version"], "not a folder"),
    (["tabulate", "--check", "--data", "/nonexistent"], "no such folder"),
    (["bench", "codegen", "--fits", "/nonexistent"], "no such folder"),
    (["bench", "nothing"], "invalid choice"),
    (["bench", "exact", "--family", "microfacet_energy"], "has no 'exact' benchmark"),
]


@pytest.mark.parametrize("argv, message", BAD, ids=[" ".join(a[:1] + a[-2:]) for a, _ in BAD])
def test_bad_values_are_refused_in_one_line(guarded, capsys, tmp_path, argv, message):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.json").write_text("keep me")
    flag = OUT_FLAG.get(argv[0], "--out")
    extra = [] if flag in argv or argv[0] == "bench" else [flag, str(out)]
    _refused([*argv, *extra], capsys, message)
    assert [p.name for p in out.iterdir()] == ["keep.json"] and (out / "keep.json").read_text() == "keep me"


def test_version_and_help(capsys):
    from fitlab import __version__

    assert _status(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"fitlab {__version__}"
    for command in (
        "tabulate",
        "refit",
        "fit",
        "audit",
        "codegen",
        "render",
        "discover",
        "report",
        "export",
        "bench",
        "cache",
    ):
        assert _status([command, "--help"]) == 0
        text = capsys.readouterr().out
        assert "example: fitlab " + command in " ".join(text.split()), command
        assert "--quiet" in text, command
    assert _status(["codegen", "--help"]) == 0
    assert "{c,python,glsl,hlsl,metal,drjit}" in capsys.readouterr().out


def test_top_level_help_names_every_language_codegen_writes(capsys):
    """``fitlab --help`` names every language codegen writes: those of fitlab.codegen.LANGUAGES."""
    from fitlab.codegen import LANGUAGES

    names = {"c": "C", "python": "Python", "glsl": "GLSL", "hlsl": "HLSL", "metal": "Metal", "drjit": "Dr.Jit"}
    assert set(LANGUAGES) == set(names)
    assert _status(["--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    line = text[text.index("codegen generate") : text.index(" render ")]
    assert line == "codegen generate C, Python, GLSL, HLSL, Metal or Dr.Jit source of the runtime BRDF from the fits"


def test_closed_pipe_ends_quietly():
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.Popen([sys.executable, "-m", "fitlab", "refit", "--list"], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    proc.stdout.close()  # the reader is gone before anything is written
    err = proc.stderr.read().decode()
    proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipe" not in err, err
    assert proc.returncode == 141


# -- all or nothing -------------------------------------------------------------------
def _fail_on_second_file(monkeypatch, exc=KeyboardInterrupt):
    """fitlab._io's open raises ``exc`` when the second temporary is opened (Ctrl-C part-way)."""
    import builtins

    import fitlab._io

    calls = []

    def flaky(path, *args, **kwargs):
        calls.append(path)
        if len(calls) == 2:
            raise exc()
        return builtins.open(path, *args, **kwargs)

    monkeypatch.setattr(fitlab._io, "open", flaky, raising=False)
    return calls


def _snapshot(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_atomic_write_many_interrupted_leaves_no_partial_set(tmp_path, monkeypatch):
    from fitlab._io import atomic_write_many

    for n in ("a", "b", "c"):
        (tmp_path / n).write_text(f"old {n}")
    before = _snapshot(tmp_path)
    calls = _fail_on_second_file(monkeypatch)
    with pytest.raises(KeyboardInterrupt):
        atomic_write_many({tmp_path / n: f"new {n}".encode() for n in ("a", "b", "c")})
    assert len(calls) == 2 and all(f".{os.getpid()}.tmp" in str(c) for c in calls)  # the temporaries carry the pid
    assert _snapshot(tmp_path) == before  # no new file, no stray *.tmp


def test_codegen_writes_all_files_or_none(tmp_path, monkeypatch, capsys):
    import fitlab.codegen

    out = tmp_path / "gen"
    out.mkdir()
    for n in ("x.c", "x.h", "x.py"):
        (out / n).write_text("old")
    before = _snapshot(out)
    monkeypatch.setattr(fitlab.codegen, "generate", lambda *a, **k: {n: "new" for n in ("x.c", "x.h", "x.py")})
    _fail_on_second_file(monkeypatch, OSError)
    assert main(["codegen", "--lang", "c", "--fits", str(FITS), "--out", str(out)]) == 1
    assert _snapshot(out) == before
    monkeypatch.undo()
    monkeypatch.setattr(fitlab.codegen, "generate", lambda *a, **k: {n: "new" for n in ("x.c", "x.h", "x.py")})
    assert main(["codegen", "--lang", "c", "--fits", str(FITS), "--out", str(out), "--quiet"]) == 0
    assert _snapshot(out) == {n: b"new" for n in ("x.c", "x.h", "x.py")}


def test_tabulate_writes_all_tables_or_none(tmp_path, monkeypatch):
    import fitlab.families.lambert_sphere.targets.tabulate as tabulate
    from fitlab.store import Table

    out = tmp_path / "data" / "lambert_sphere"
    out.mkdir(parents=True)
    (out / "h0.csv").write_text("old")
    before = _snapshot(out)
    tables = {n: Table(n, "test", "0", ("s", "c"), [[0.0, 0.5]]) for n in ("h0.csv", "h1.csv", "kd.csv")}
    monkeypatch.setattr(tabulate, "build_tables", lambda show_progress=True, names=(): tables)
    with pytest.raises(KeyboardInterrupt):  # Ctrl-C reaches the caller (main reports it) after the cleanup
        _fail_on_second_file(monkeypatch)
        tabulate.write_tables(out, show_progress=False)
    assert _snapshot(out) == before
    monkeypatch.undo()
    monkeypatch.setattr(tabulate, "build_tables", lambda show_progress=True, names=(): tables)
    _fail_on_second_file(monkeypatch, KeyboardInterrupt)
    assert main(["tabulate", "--quiet", "--family", "lambert_sphere", "--data", str(out.parent)]) == 130
    assert _snapshot(out) == before


def test_audit_writes_both_files_or_neither(tmp_path, monkeypatch, capsys):
    import fitlab.families.lambert_sphere.program.report.audit as audit
    from fitlab.core import Outputs

    out = tmp_path / "docs"
    out.mkdir()
    (out / "audit.md").write_text("old md")
    (out / "audit.json").write_text("old json")
    before = _snapshot(out)

    def fake_audit(fits_dir, show_progress=False):
        return Outputs({"runtime": [], "furnace": [], "missing_fits": []}, {"audit.json": b"{}", "audit.md": b"new"})

    monkeypatch.setattr(audit, "audit", fake_audit)
    _fail_on_second_file(monkeypatch, OSError)
    assert main(["audit", "--fits", str(FITS), "--out", str(out)]) == 1
    assert _snapshot(out) == before
    monkeypatch.undo()
    monkeypatch.setattr(audit, "audit", fake_audit)
    assert main(["audit", "--fits", str(FITS), "--out", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["files"] == [str(out / "audit.md"), str(out / "audit.json")]
    assert _snapshot(out) == {"audit.json": b"{}", "audit.md": b"new"}


# -- refit: the verdict --------------------------------------------------------------
def _committed(name: str):
    from fitlab.fit.refit import RefitResult
    from fitlab.store import read_fit

    return RefitResult(read_fit(FITS / f"{name}.json"), fit=None)


def test_refit_verdict_rule():
    from fitlab.fit.refit import refit_verdict

    res = _committed("l")
    v = res.record["validation"]

    def scaled(max_factor, rms_factor):  # a reference whose max and RMS are the refit's times these
        return {
            "max_rel": max_factor * v["max_rel"],
            "max_rel_nonzero": max_factor * v["max_rel_nonzero"],
            "rms_rel": rms_factor * v["rms_rel"],
        }

    better, worse = scaled(2, 2), scaled(0.5, 0.5)
    assert refit_verdict(res, better) is None
    assert refit_verdict(res, dict(v)) is None  # ending where it started is not worse
    assert refit_verdict(res, scaled(1 + 1e-9, 2)) is None  # the same max to rounding, a smaller RMS: kept
    assert refit_verdict(res, scaled(2, 0.5)) is None  # a smaller max and a larger RMS: kept
    assert "worse than its starting point" in refit_verdict(res, scaled(0.5, 2))  # a larger max: worse
    assert "worse than its starting point" in refit_verdict(res, scaled(1, 0.5))  # the same max, a larger RMS
    assert "worse than its starting point" in refit_verdict(res, worse)
    res.record["published"][0]["validation"].update(worse)
    assert "worse than the published preset paper" in refit_verdict(res, better)
    res = _committed("l")
    res.record["validation"]["max_rel"] = float("inf")  # misses an exact zero the start keeps
    assert "misses an exact zero" in refit_verdict(res, {**better, "max_rel": 1.0})
    res = _committed("H0")  # max better, RMS worse than the paper's preset: kept
    assert refit_verdict(res, None) is None
    res.record["validation"]["rms_rel"] = float("nan")
    assert "not finite" in refit_verdict(res, None)
    res.record["validation"]["rms_rel"] = float("inf")
    assert "not finite" in refit_verdict(res, None)


def test_worse_is_one_rule_defined_once():
    """fitlab.fit.metrics.worse: the max decides, then the max without exact zeros, then the RMS, each beyond
    rounding (relative and absolute); NaN counts as infinite.  It is the only definition in fitlab (refit's verdict,
    refit's and fit's keeping of the better fit all call it)."""
    import ast

    from fitlab.fit.metrics import ROUNDING, WORSE_RTOL, worse

    def f(m, mz=None, rms=1e-3):
        return {"max_rel": m, "max_rel_nonzero": m if mz is None else mz, "rms_rel": rms}

    assert worse(f(2e-3), f(1e-3, rms=1.0)) and not worse(f(1e-3, rms=1.0), f(2e-3))  # the max first
    assert worse(f(math.inf, 1e-3), f(1.0))  # missing an exact zero is the largest max
    assert worse(f(1e-3, 2e-3), f(1e-3, 1e-3)) and worse(f(1e-3, rms=2e-3), f(1e-3))  # then max*, then RMS
    assert not worse(f(1e-3), f(1e-3)) and not worse(f(1e-3 * (1 + WORSE_RTOL / 2)), f(1e-3))  # equal: not worse
    assert not worse(f(3 * ROUNDING / 4), f(ROUNDING / 4))  # a few ulp apart (an exact form's errors): equal
    assert worse(f(1e-3), f(1e-3, rms=math.nan)) is False and worse(f(math.nan), f(1.0))  # NaN is infinite
    defined = [str(p.relative_to(ROOT)) for p in (ROOT / "fitlab").rglob("*.py")
               for node in ast.walk(ast.parse(p.read_text())) if isinstance(node, ast.FunctionDef)
               and node.name.strip("_") == "worse"]  # fmt: skip
    assert defined == ["fitlab/fit/metrics.py"], defined


def test_refit_worse_than_its_start_fails_and_writes_nothing(tmp_path, monkeypatch, capsys):
    """A solver that ends at a worse point than it started: exit 1, one line, the old fit kept."""
    import dataclasses

    import fitlab.fit.refit as refit_module

    real = refit_module.fit_form

    def worse_solver(form, train, scale, theta0=None, **kwargs):
        res = real(form, train, scale, theta0, **{**kwargs, "minimax_rounds": 0})
        start = np.asarray(form.vector(form.start_values) if theta0 is None else theta0, dtype=float)
        return dataclasses.replace(res, theta=start * 1.3 + 0.01)  # a worse point than the start

    monkeypatch.setattr(refit_module, "fit_form", worse_solver)
    out = tmp_path / "fits"
    out.mkdir()
    (out / "l.cubic.json").write_text("keep me")  # what the refit would write (l's form in the default model)
    assert main(["refit", "--target", "l", "--out", str(out), "--quiet", "--json"]) == 1
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert "\n" not in err and "worse than its starting point" in err and "nothing written" in err
    summary = json.loads(captured.out)
    assert summary["ok"] is False and summary["written"] is False and summary["fits"][0]["failure"]
    assert _snapshot(out) == {"l.cubic.json": b"keep me"}


def _stub_refits(monkeypatch, worse: str | None = None):
    """refit --all of l and m, each 'refit' being its committed fit (``worse``: that one made worse)."""
    import fitlab.cli.refit

    monkeypatch.setattr(fitlab.cli.refit, "_start_metrics", lambda *a: None)  # the presets are the reference here
    monkeypatch.setattr(fitlab.cli.refit, "default_jobs", lambda: [("l", "quadratic"), ("m", "linear")])

    def timed_refit(target, form, **kwargs):
        res = _committed(target.name)
        if target.name == worse:
            for p in res.record["published"]:
                p["validation"].update(max_rel=1e-9, max_rel_nonzero=1e-9, rms_rel=1e-9)
        return res, 0.01

    monkeypatch.setattr(fitlab.cli.refit, "timed_refit", timed_refit)


def test_refit_all_writes_every_fit_or_none(tmp_path, monkeypatch, capsys):
    out = tmp_path / "fits"
    out.mkdir()
    (out / "l.json").write_text("old l")
    _stub_refits(monkeypatch, worse="m")
    assert main(["refit", "--all", "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert "m/linear" in err and "nothing written" in err and "\n" not in err
    assert _snapshot(out) == {"l.json": b"old l"}
    monkeypatch.undo()
    _stub_refits(monkeypatch)
    _fail_on_second_file(monkeypatch, KeyboardInterrupt)
    assert main(["refit", "--all", "--out", str(out), "--quiet"]) == 130  # Ctrl-C part-way through the writes
    assert _snapshot(out) == {"l.json": b"old l"}
    monkeypatch.undo()
    _stub_refits(monkeypatch)
    assert main(["refit", "--all", "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["ok"] and [f["target"] for f in summary["fits"]] == ["l", "m"]
    assert sorted(_snapshot(out)) == ["l.json", "m.json"]
    assert json.loads((out / "m.json").read_text())["params"] == json.loads((FITS / "m.json").read_text())["params"]
