"""Ctrl-C in ``fitlab refit``: at any moment before the fit is in place, exit status 130, one line on
stderr, and the old file as it was; after that, the command ends as it would have (exit 0, the new file
complete).  A SIGINT that lands in a garbage-collector callback (JAX's, jax-ml/jax#18246), where Python
drops the KeyboardInterrupt, still stops the command (fitlab._interrupt)."""

from __future__ import annotations

import gc
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fitlab.cli import main

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
NAME = "m.quadratic.json"  # what `fitlab refit --target m` writes (fitlab.codegen.model_form("m"))
OLD = b'{"old": "a fit the interrupted refit must leave as it was"}\n'


def _old_out(tmp_path) -> Path:
    out = tmp_path / "fits"
    out.mkdir(parents=True)
    (out / NAME).write_bytes(OLD)
    return out


def _interrupted_as_it_should(out: Path, err: str) -> None:
    lines = [line for line in err.splitlines() if line.strip()]
    assert lines == ["fitlab refit: interrupted"], err
    assert sorted(p.name for p in out.iterdir()) == [NAME]  # no temporary left
    assert (out / NAME).read_bytes() == OLD


def _stub_refit(monkeypatch, during):
    """The refit of m is its committed fit, after ``during()`` ran in its place."""
    import fitlab.cli.refit
    from fitlab.fit.refit import RefitResult
    from fitlab.store import read_fit

    def timed_refit(target, form, **kwargs):
        during()
        return RefitResult(read_fit(FITS / NAME), fit=None), 0.01

    monkeypatch.setattr(fitlab.cli.refit, "timed_refit", timed_refit)


def test_a_sigint_in_a_gc_callback_stops_the_refit(tmp_path, monkeypatch, capsys):
    """The signal lands in a gc callback (where Python drops the KeyboardInterrupt, as in JAX's): the refit
    stops soon after the collection, exit 130, the old file kept (before: exit 0, the file overwritten)."""
    from fitlab.cli._common import one_line

    state = {"finished": False}

    def sigint_in_callback(phase, info):
        if phase == "start":
            os.kill(os.getpid(), signal.SIGINT)
            sum(range(1000))  # Python code inside the callback: the handler runs here

    def during():
        gc.callbacks.append(sigint_in_callback)
        try:
            gc.collect()
        finally:
            gc.callbacks.remove(sigint_in_callback)
        deadline = time.monotonic() + 20  # the rest of a solve: fitlab's Python code, called again and again
        while time.monotonic() < deadline:
            one_line("a solve step")
        state["finished"] = True

    _stub_refit(monkeypatch, during)
    out = _old_out(tmp_path)
    # the handler before main(): Python's default, or SIG_IGN where the run was started in the background
    before = signal.getsignal(signal.SIGINT)
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 130
    _interrupted_as_it_should(out, capsys.readouterr().err)
    assert not state["finished"]  # stopped after the collection, not at the write
    assert signal.getsignal(signal.SIGINT) is before  # main() put the handler back


def test_a_sigint_in_a_weakref_callback_stops_the_refit(tmp_path, monkeypatch, capsys):
    """The signal lands in a weakref callback of the import machinery (its module-lock ``cb``, which fitlab
    takes for a safe place to raise): Python drops the KeyboardInterrupt there ("Exception ignored in"),
    fitlab's unraisable hook delivers it again, and the refit stops soon after, exit 130, one line (before:
    the request was lost until the write, after the whole solve; under ``python -m fitlab`` the dropped
    exception's traceback printed on stderr)."""
    import weakref

    state = {"finished": False}
    # a callback whose code is the import machinery's, as _get_module_lock's cb is
    callback_code = compile(
        "def cb(ref):\n    os.kill(os.getpid(), signal.SIGINT)\n    sum(range(1000))\n",
        "<frozen importlib._bootstrap>",
        "exec",
    )
    namespace = {"os": os, "signal": signal}
    exec(callback_code, namespace)

    class Lock:
        pass

    def during():
        lock = Lock()
        ref = weakref.ref(lock, namespace["cb"])
        del lock  # the callback runs here, from the object's deallocation
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            one_line("a solve step")
        state["finished"] = ref() is None  # (the lock is gone) the whole solve ran: the request was lost

    from fitlab.cli._common import one_line

    _stub_refit(monkeypatch, during)
    out = _old_out(tmp_path)
    before = sys.unraisablehook
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 130
    _interrupted_as_it_should(out, capsys.readouterr().err)
    assert not state["finished"]
    assert sys.unraisablehook is before  # main() put pytest's hook back


@pytest.mark.parametrize("where", ["writing the temporary", "just before the renames"])
def test_a_sigint_while_writing_keeps_the_old_file(tmp_path, monkeypatch, capsys, where):
    import builtins

    import fitlab._io

    _stub_refit(monkeypatch, lambda: None)
    if where == "writing the temporary":

        def sigint_open(path, *args, **kwargs):
            os.kill(os.getpid(), signal.SIGINT)
            return builtins.open(path, *args, **kwargs)

        monkeypatch.setattr(fitlab._io, "open", sigint_open, raising=False)
    else:
        real = getattr(fitlab._io, "check", lambda: None)

        def sigint_check():
            os.kill(os.getpid(), signal.SIGINT)
            sum(range(1000))  # the handler runs here: inside the write's hold, it only records the request
            real()

        monkeypatch.setattr(fitlab._io, "check", sigint_check, raising=False)
    out = _old_out(tmp_path)
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 130
    _interrupted_as_it_should(out, capsys.readouterr().err)


def test_a_sigint_during_the_renames_is_too_late(tmp_path, monkeypatch, capsys):
    """Once the write's last check has passed, the fit goes into place and refit ends as it would have."""
    import fitlab._io

    _stub_refit(monkeypatch, lambda: None)
    real = os.replace

    def sigint_replace(src, dst):
        os.kill(os.getpid(), signal.SIGINT)
        sum(range(1000))
        real(src, dst)

    monkeypatch.setattr(fitlab._io.os, "replace", sigint_replace)
    out = _old_out(tmp_path)
    assert main(["refit", "--target", "m", "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    assert json.loads((out / NAME).read_text())["params"] == json.loads((FITS / NAME).read_text())["params"]


def _numpy_loaded(pid: int) -> bool:
    """Whether process ``pid`` has numpy mapped: fitlab.cli imports no numpy, so the command's own imports
    (after main() put fitlab's handler in place) are under way."""
    try:
        return "_multiarray_umath" in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


def _run(out: Path, delay: float | None, env) -> tuple[int, str, float]:
    """``python -m fitlab refit --target m`` into ``out``; SIGINT ``delay`` seconds after numpy is loaded
    (None: no signal).  Returns the exit status, stderr and the seconds from numpy's loading to the exit."""
    proc = subprocess.Popen([sys.executable, "-m", "fitlab", "refit", "--target", "m", "--out", str(out), "--quiet"],
                            cwd=out.parent, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)  # fmt: skip
    while not _numpy_loaded(proc.pid) and proc.poll() is None:
        time.sleep(0.005)
    start = time.monotonic()
    if delay is not None:
        time.sleep(delay)
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    err = proc.communicate(timeout=300)[1].decode()
    return proc.returncode, err, time.monotonic() - start


@pytest.mark.e2e
@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc to see the child's imports")
def test_ctrl_c_at_any_moment_of_a_real_refit(tmp_path, capsys):
    """SIGINT at moments spread over a whole ``fitlab refit --target m`` (its imports, the exact values, the
    solve, the write): each run ends with exit 130, one line and the old file, or, where the signal came
    after the fit was in place, exit 0 and the new fit complete.  No timing is asserted."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = _old_out(tmp_path / "whole")
    status, err, whole = _run(out, None, env)
    assert status == 0 and err == "", err
    new = json.loads((out / NAME).read_text())
    assert new["target"] == "m" and new["form"] == "quadratic"
    outcomes = []
    for fraction in (0.0, 0.2, 0.4, 0.6, 0.8, 0.95):
        out = _old_out(tmp_path / f"at{fraction}")
        status, err, _ = _run(out, fraction * whole, env)
        outcomes.append((fraction, status))
        if status == 130:
            _interrupted_as_it_should(out, err)
        else:  # the signal came after the fit was in place (or after the run)
            assert status == 0 and err == "", (fraction, status, err)
            assert json.loads((out / NAME).read_text())["params"] == new["params"]
            assert sorted(p.name for p in out.iterdir()) == [NAME]
    with capsys.disabled():
        print(f"\nrefit --target m: {whole:.1f} s after numpy loaded; SIGINT at fraction -> exit status: {outcomes}")
    assert any(status == 130 for _, status in outcomes)


INJECT = """
import os
import runpy

import fitlab.cli.refit


def timed_refit(target, form, **kwargs):  # Ctrl-C raised below an exec() of a string (an import inside one)
    exec("import os, signal\\nfrom fitlab.cli._common import one_line\\nos.kill(os.getpid(), signal.SIGINT)\\n"
         "for _ in range(10**7): one_line('x')")
    raise AssertionError("not interrupted")


fitlab.cli.refit.timed_refit = timed_refit
runpy.run_module("fitlab", run_name="__main__", alter_sys=True)
"""


@pytest.mark.e2e
def test_python_m_fitlab_exits_130_after_a_ctrl_c_inside_exec(tmp_path):
    """CPython remembers a KeyboardInterrupt that left an exec() of a string and ends ``python -m`` by SIGINT
    whatever its exit status (before: status -2 after printing "interrupted")."""
    (tmp_path / "fitlab_sigint_exec").mkdir()
    (tmp_path / "fitlab_sigint_exec" / "__main__.py").write_text(INJECT)
    out = _old_out(tmp_path)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "fitlab_sigint_exec", "refit", "--target", "m", "--out", str(out),
                           "--quiet"], cwd=tmp_path, env=env, capture_output=True, timeout=300)  # fmt: skip
    assert proc.returncode == 130, (proc.returncode, proc.stderr.decode())
    _interrupted_as_it_should(out, proc.stderr.decode())
