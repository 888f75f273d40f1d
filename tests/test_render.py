"""``fitlab render``: the comparison picture (the registered lambert_sphere plugin beside Lambert, Oren-Nayar and
Chandrasekhar) and its errors.  The plugin's renders themselves are tested in tests/test_mitsuba_plugin.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

from fitlab.families.lambert_sphere.render import (  # noqa: E402
    chandrasekhar_albedo_c, _chandrasekhar_kd, oren_nayar, render_comparison, render_sphere,
)  # fmt: skip

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "fitlab" / "fits" / "generated" / "lambert_sphere_drjit.py"


def test_comparison_materials_have_the_same_albedo():
    kd = 0.7
    c = chandrasekhar_albedo_c(kd)
    assert abs(_chandrasekhar_kd(c) - kd) < 1e-9
    wi = (0.0, 0.0, 1.0)
    assert abs(oren_nayar(wi, wi, kd) - kd / np.pi * (1 - 0.5 * 0.25 / 0.58)) < 1e-12  # normal incidence: A kd/pi


def test_comparison_materials_render_in_scalar_rgb():
    """Each of the four materials renders (vectorised BSDFs, here with Python floats) and is lit where the light
    falls: a sphere lit from the viewer is brightest near the centre."""
    light = np.array([0.0, 0.0, 1.0])
    for material in ("lambert_sphere", "lambert", "oren_nayar", "chandrasekhar"):
        img = render_sphere(material, 0.6, light, 8, 1, variant="scalar_rgb")
        assert np.all(np.isfinite(img)) and img[3:5, 3:5].min() > 0.05, material
        assert img[0, 0] == 0.0  # off the sphere


def test_render_comparison_writes_png(tmp_path):
    out = render_comparison(tmp_path / "r.png", GENERATED, kd=0.8, size=8, spp=1, lights=1, show_progress=False,
                            variant="scalar_rgb")  # fmt: skip
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError):
        render_comparison(tmp_path / "bad.png", GENERATED, kd=1.5)
    assert not (tmp_path / "bad.png").exists()


def test_render_cli_errors(tmp_path, capsys):
    from fitlab.cli import main

    out = tmp_path / "out"
    assert main(["render", "--generated", str(tmp_path / "missing.py"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "fitlab codegen --lang drjit" in err and "\n" not in err
    assert not out.exists()
    (tmp_path / "x.png").write_bytes(b"keep me")  # --out is a folder (render.png goes into it), never a file
    assert main(["render", "--generated", str(GENERATED), "--out", str(tmp_path / "x.png")]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert (tmp_path / "x.png").read_bytes() == b"keep me"
    numpy_module = GENERATED.with_name("lambert_sphere.py")  # generated, but numpy: not what the plugin runs
    assert main(["render", "--generated", str(numpy_module), "--out", str(out)]) == 2
    assert "not a generated Dr.Jit module" in capsys.readouterr().err
