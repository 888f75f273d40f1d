"""The model a user gets by default: the runtime model whose parts are fitted to the true BRDF, what it claims
about itself (against the true BRDF, re-measured where it is printed), the physics every fit states, and the
cache that makes a second ``fitlab codegen`` answer at once."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from fitlab.cli import main
from fitlab.codegen import load_program, program_spec
from fitlab.codegen.languages import emit
from fitlab.codegen.native import build, compiler
from fitlab.core import get_target
from fitlab.families.lambert_sphere.program.runtime import accuracy, directional_albedo, runtime_model
from fitlab.families.lambert_sphere.program.spec import MODEL_PARTS, THREE_TERM_MODEL, TRUE_MODEL
from fitlab.store import FitFileError, fit_path, fit_sha256, load, write_fit

ROOT = Path(__file__).resolve().parents[1]
FITS = ROOT / "fitlab" / "fits"
GENERATED = FITS / "generated"
SPEC = program_spec("lambert_sphere")


# -- one default, the best at its cost ------------------------------------------------------------------------
def test_the_default_model_is_the_one_fitted_to_the_true_brdf():
    assert SPEC.default_model == TRUE_MODEL
    model = SPEC.model()
    assert model.physics == "true" and model.folder == "true"
    assert SPEC.model(THREE_TERM_MODEL).physics == "three_term"
    default = runtime_model()
    assert default.name == f"refit, model {TRUE_MODEL}"
    for part in MODEL_PARTS:
        assert load(FITS / "true" / default.sources[part]).physics == "true", part


def test_every_packaged_fit_states_its_physics():
    """Every fit file says what it was fitted against; those of the true model's folder say "true", the others
    their target's physics (a fit made by ``fitlab refit`` is a fit of its target's values)."""
    files = sorted(FITS.glob("*.json")) + sorted((FITS / "true").glob("*.json"))
    assert len(files) > 100
    for path in files:
        record = json.loads(path.read_text())
        assert "physics" in record, path.name
        want = "true" if path.parent.name == "true" else get_target(record["target"]).physics
        assert record["physics"] == want, path.name


def test_a_model_of_mixed_physics_is_refused_unless_asked_for(tmp_path):
    """A --fits refit of a three-term part beside the parts fitted to the true BRDF is refused by name, with the
    two ways out; --model three-term prints every part fitted to its own target, --allow-mixed-physics the mix."""
    fits = tmp_path / "fits"
    write_fit(fits / "m.quadratic.json", json.loads((FITS / "m.quadratic.json").read_text()))  # three-term m
    with pytest.raises(FitFileError, match=r"m\.quadratic\.json was fitted to physics three_term.*--model three-term"):
        load_program(fits)
    with pytest.raises(FitFileError, match="three_term"):
        runtime_model(fits_dir=fits)
    assert runtime_model(fits_dir=fits, model=THREE_TERM_MODEL).sources["m"] == "m.quadratic.json"
    mixed = load_program(fits, allow_mixed_physics=True)
    assert mixed.model is not None and "mixed physics" in mixed.model[0]


def test_the_command_refuses_a_mix_in_one_line_before_writing(tmp_path, capsys):
    fits = tmp_path / "fits"
    write_fit(fits / "m.quadratic.json", json.loads((FITS / "m.quadratic.json").read_text()))
    out = tmp_path / "gen"
    assert main(["codegen", "--lang", "python", "--fits", str(fits), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "m.quadratic.json" in err and "--model three-term" in err
    assert not out.exists()


# -- claims of the BRDF, against the true BRDF ----------------------------------------------------------------
def _claim(text: str) -> dict:
    m = re.search(r"max (\S+), RMS (\S+) relative over mu_i, mu_o in \[0\.01, 1\]", text)
    g = re.search(r"max (\S+) down to mu_i, mu_o = 1e-6", text)
    a = re.search(r"directional albedo at c = 1 from (\S+) to (\S+?)\.?\s", text)
    assert m and g and a, text[:3000]
    return {"max": m[1], "rms": m[2], "grazing": g[1], "albedo": (a[1], a[2])}


def test_the_banner_states_the_brdfs_error_as_measured_again():
    """The committed C states the default model's error against the true BRDF; measuring runtime_model() (the same
    parts, as numpy) on the same sets gives the same figures to the digits printed."""
    text = (GENERATED / "lambert_sphere.c").read_text()
    stated = _claim(text)
    a = accuracy(runtime_model())
    assert stated["max"] == f"{a['max']:.2e}" and stated["rms"] == f"{a['rms']:.2e}"
    assert stated["grazing"] == f"{a['max_grazing']:.2e}"
    assert stated["albedo"] == (f"{a['albedo_c1_min']:.6f}", f"{a['albedo_c1_max']:.6f}")
    # the routine's own documentation says it too, in every language
    for name in ("lambert_sphere.h", "lambert_sphere.py", "lambert_sphere.glsl"):
        assert (
            f"max {stated['max']}, RMS {stated['rms']} relative over mu_i, mu_o in [0.01, 1]"
            in (GENERATED / name).read_text()
        ), name


def test_the_three_term_model_states_its_own_larger_error():
    """The claim is measured, not copied: the model of parts fitted to their three-term targets (the same
    structure and forms) states its own error, which is larger against the true BRDF."""
    program = load_program(None, model=THREE_TERM_MODEL)
    banner = emit(program, "python")["lambert_sphere.py"]
    three, true = _claim(banner), _claim((GENERATED / "lambert_sphere.py").read_text())
    assert float(three["max"]) > 2 * float(true["max"])
    assert "Model: three-term" in banner


@pytest.mark.skipif(compiler() is None, reason="no C compiler on PATH")
def test_the_default_c_is_runtime_model_to_1e13(tmp_path):
    program = load_program(None)
    files = emit(program, "c")
    assert files["lambert_sphere.c"] == (GENERATED / "lambert_sphere.c").read_text()
    native = build(files, program, tmp_path)
    rng = np.random.default_rng(58)
    n = 20_000
    mu_i, mu_o = rng.uniform(0.01, 1.0, (2, n))
    phi, c = rng.uniform(0.0, np.pi, n), rng.uniform(0.0, 1.0, n)
    want = runtime_model()(mu_i, mu_o, phi, c)
    got = native("brdf", mu_i, mu_o, np.cos(phi), c)
    assert np.all(want > 0)
    assert np.max(np.abs(got - want) / want) < 1e-13


def test_the_default_models_albedo_at_c1_stays_within_bounds():
    """The directional albedo at c = 1 lies in [0.9995, 1] at every incidence, grazing and normal included (a grid
    four times finer than the one the energy scale is computed on)."""
    mu = np.concatenate(([1e-6, 1e-4, 1e-3], np.linspace(0.0025, 1.0, 400)))
    a = directional_albedo(runtime_model(), mu, 1.0)
    assert a.max() <= 1.0 and a.min() >= 0.9995


# -- the build step in seconds ----------------------------------------------------------------------------------
def _codegen(tmp_path, *extra) -> int:
    return main(["codegen", "--lang", "python", "--out", str(tmp_path / "gen"), "--quiet", *extra])


def test_a_second_codegen_reads_the_first_from_the_cache(tmp_path, monkeypatch):
    """Unchanged inputs: the second run prints nothing anew (fitlab.codegen.generate is not called) and writes the
    same bytes; a changed fit file is a miss, measured and printed again."""
    import fitlab.codegen as codegen

    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path / "cache"))
    fits = tmp_path / "fits"
    record = json.loads((FITS / "true" / "m.quadratic.json").read_text())
    write_fit(fits / "m.quadratic.json", record)
    calls = []
    real = codegen.generate

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(codegen, "generate", counting)
    assert _codegen(tmp_path, "--fits", str(fits)) == 0
    first = (tmp_path / "gen" / "lambert_sphere.py").read_bytes()
    assert _codegen(tmp_path, "--fits", str(fits)) == 0
    assert len(calls) == 1 and (tmp_path / "gen" / "lambert_sphere.py").read_bytes() == first
    record["params"] = {k: v * (1 + 1e-9) for k, v in record["params"].items()}  # within the stated accuracy
    write_fit(fits / "m.quadratic.json", record)
    assert _codegen(tmp_path, "--fits", str(fits)) == 0
    assert len(calls) == 2
    changed = (tmp_path / "gen" / "lambert_sphere.py").read_bytes()
    assert changed != first and fit_sha256(fit_path(fits, "m", "quadratic")).encode() in changed


def test_a_refused_run_is_not_kept(tmp_path, monkeypatch, capsys):
    """A run refused for its fits stores nothing: the same command is refused again, in the same one line."""
    monkeypatch.setenv("FITLAB_CACHE_DIR", str(tmp_path / "cache"))
    fits = tmp_path / "fits"
    write_fit(fits / "m.quadratic.json", json.loads((FITS / "m.quadratic.json").read_text()))
    errors = []
    for _ in range(2):
        assert _codegen(tmp_path, "--fits", str(fits)) == 2
        errors.append(capsys.readouterr().err)
    assert errors[0] == errors[1] and "three_term" in errors[0]
    assert not (tmp_path / "gen").exists()
