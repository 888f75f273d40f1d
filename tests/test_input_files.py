"""Only regular files are read: a FIFO, a device or a folder named like a fit file is
refused with one line before it is opened, so that it can neither hang a command nor be passed over.

Each call runs in a thread with a time limit.  Should it block on the FIFO, the test opens the FIFO's
other end itself, which ends the blocked read, and fails."""

from __future__ import annotations

import contextlib
import os
import shutil
import threading
from pathlib import Path

import pytest

from fitlab._io import InputFileError, read_regular_file, regular_file
from fitlab.cli import main
from fitlab.store import FitFileError, load

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"


def finishes(call, fifos, seconds: float = 30.0):
    """``call()``'s result or exception, run in a thread; fails when it is still blocked after ``seconds``
    (after unblocking it: each FIFO's writing end is opened and closed, which the reader sees as an end)."""
    result = {}

    def run():
        try:
            result["value"] = call()
        except BaseException as exc:  # noqa: BLE001 - handed to the test
            result["error"] = exc

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        for fifo in fifos:
            with contextlib.suppress(OSError):
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(seconds)
        pytest.fail(f"blocked on a FIFO for more than {seconds:g} s")
    if "error" in result:
        raise result["error"]
    return result.get("value")


def test_load_refuses_a_fifo_without_blocking(tmp_path):
    fifo = tmp_path / "H0.json"
    os.mkfifo(fifo)
    with pytest.raises(FitFileError) as info:
        finishes(lambda: load(fifo), [fifo])
    assert str(info.value) == f"{fifo}: not a regular file (a FIFO), not a fit file"


def _fits_with(tmp_path, name):
    fits = tmp_path / "fits"
    shutil.copytree(FITS, fits, ignore=shutil.ignore_patterns("generated"))
    (fits / name).unlink(missing_ok=True)
    os.mkfifo(fits / name)
    return fits, fits / name


@pytest.mark.parametrize("name, extra", [
    ("m.sr_1_abcdef.json", ["--model", "default-forms", "--form", "m=sr_1_abcdef"]),  # a discovered form: was read, and hung
    # a registered form, where the default model reads it (the folder laid out as the packaged fits): was passed
    # over for the packaged fit, as if the folder had none
    ("true/H0.log_exp_true.json", []),
])  # fmt: skip
def test_codegen_refuses_a_fifo_in_fits(tmp_path, capsys, name, extra):
    fits, fifo = _fits_with(tmp_path, name)
    out = tmp_path / "gen"
    code = finishes(lambda: main(["codegen", "--lang", "c", "--fits", str(fits), "--out", str(out), *extra]), [fifo])
    err = capsys.readouterr().err.strip()
    assert (code, err) == (2, f"fitlab codegen: error: {fifo}: not a regular file (a FIFO), not a fit file")
    assert not out.exists() or list(out.iterdir()) == []


def test_read_regular_file_checks_type_and_size(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(InputFileError) as info:
        finishes(lambda: read_regular_file(fifo, 100), [fifo])
    assert (info.value.kind, str(info.value)) == ("not_regular", f"{fifo}: not a regular file (a FIFO)")
    with pytest.raises(InputFileError) as info:
        regular_file(tmp_path, 100)
    assert (info.value.kind, info.value.reason) == ("folder", "a folder, not a file")
    with pytest.raises(InputFileError) as info:
        regular_file(tmp_path / "absent", 100)
    assert (info.value.kind, info.value.reason) == ("missing", "no such file")
    big = tmp_path / "big"
    big.write_bytes(b"x" * 101)
    with pytest.raises(InputFileError) as info:
        read_regular_file(big, 100)
    assert (info.value.kind, info.value.reason) == ("too_large", "101 bytes, more than the 100 bytes fitlab reads")
    assert read_regular_file(big, 101) == b"x" * 101
    assert regular_file(big, 101).st_size == 101


# -- scenes -----------------------------------------------------------------------------------------
def _scene_readers():
    from fitlab.families.lambert_sphere.mc import scene as mc_scene
    from fitlab.families.microfacet_energy.mc import scene as microsurface_scene

    return {"lambert_sphere": mc_scene, "microfacet_energy": microsurface_scene}


@pytest.mark.parametrize("family", ["lambert_sphere", "microfacet_energy"])
def test_a_fifo_scene_is_refused_without_blocking(tmp_path, family):
    reader = _scene_readers()[family]
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    with pytest.raises(reader.SceneError) as info:
        finishes(lambda: reader.load_scene(fifo), [fifo])
    assert str(info.value) == f"{fifo}:1: (file): not a regular file (a FIFO), not a scene"


@pytest.mark.parametrize("family", ["lambert_sphere", "microfacet_energy"])
def test_a_scene_over_the_size_limit_is_refused_before_it_is_read(tmp_path, family):
    reader = _scene_readers()[family]
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:  # sparse: 2 MB of nothing, never parsed
        fh.truncate(2_000_000)
    with pytest.raises(reader.SceneError) as info:
        reader.load_scene(big)
    assert str(info.value) == f"{big}:1: (file): 2000000 bytes, more than the 1000000 bytes fitlab reads"


def test_simulate_refuses_a_fifo_scene_without_blocking(tmp_path, capsys):
    fifo = tmp_path / "scene.toml"
    os.mkfifo(fifo)
    code = finishes(lambda: main(["simulate", str(fifo), "--out", str(tmp_path / "out")]), [fifo])
    assert (code, capsys.readouterr().err.strip()) == (
        2,
        f"fitlab simulate: error: {fifo}:1: (file): not a regular file (a FIFO), not a scene",
    )
    assert not (tmp_path / "out").exists()
