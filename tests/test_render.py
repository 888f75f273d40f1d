"""``fitlab render``: the comparison picture (the registered lambert_sphere plugin beside Lambert, Oren-Nayar and
Chandrasekhar) and its errors.  The plugin's renders themselves are tested in tests/test_mitsuba_plugin.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

from fitlab.families.lambert_sphere.mitsuba.render import (  # noqa: E402
    _chandrasekhar_kd,
    chandrasekhar_albedo_c,
    oren_nayar,
    render_comparison,
    render_sphere,
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


def _frame(n):
    """Local frames (t, b, n) at normals n (k x 3): any tangent serves an isotropic BRDF."""
    t = np.cross(n, [0.3, 0.5, 0.1])
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    return t, np.cross(n, t), n


def _expected_image(f_local, light, size, sub=6):
    """Pixel averages (and their spread) of f(wi, wo) cos(theta_i) (``f_local`` of local-frame wi, wo), unit
    irradiance toward ``light``, seen from +z, on sub x sub points per pixel (the renderer's camera)."""
    from fitlab.families.lambert_sphere.mitsuba.render import pixel_geometry

    fine = pixel_geometry(size * sub).reshape(-1, 3)
    on = ~np.isnan(fine[:, 0])
    t, b, n = _frame(fine[on])
    local = lambda v: np.stack([t @ v, b @ v, n @ v], axis=-1)  # noqa: E731
    wi, wo = local(np.asarray(light, float)), local(np.array([0.0, 0.0, 1.0]))
    values = np.zeros(len(fine))
    values[on] = f_local(wi, wo) * np.maximum(wi[:, 2], 0.0)
    blocks = values.reshape(size, sub, size, sub)
    return blocks.mean(axis=(1, 3)), blocks.std(axis=(1, 3))


@pytest.mark.e2e
def test_render_comparison_writes_png(tmp_path, monkeypatch):
    """The picture is a PNG of one panel per material and light, and its panels are the renders: the plugin's
    (the generated Dr.Jit module) against the generated numpy module integrated over each pixel (as
    tests/test_mitsuba_plugin.py checks the plugin against the generated C), Mitsuba's diffuse against kd/pi."""
    import matplotlib.image

    from fitlab.families.lambert_sphere.mitsuba import render
    from fitlab.families.lambert_sphere.mitsuba.render import light_directions, pixel_geometry

    size, spp, kd = 8, 16, 0.8
    panels = {}
    real = render.render_sphere

    def recorded(material, kd, light, *args, **kwargs):
        panels[material] = real(material, kd, light, *args, **kwargs)
        return panels[material]

    monkeypatch.setattr(render, "render_sphere", recorded)
    png = render_comparison(GENERATED, kd=kd, size=size, spp=spp, lights=1, show_progress=False, variant="scalar_rgb")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    out = tmp_path / "r.png"
    out.write_bytes(png)
    assert matplotlib.image.imread(out).shape[:2] == (880, 220)  # 4 materials x 1 light, 2.2 in each at 100 dpi
    assert set(panels) == {"lambert_sphere", "lambert", "oren_nayar", "chandrasekhar"}
    (light,) = light_directions(1)
    inner = np.nan_to_num(pixel_geometry(size)[..., 2]) > 0.5  # covered, lit pixels
    assert inner.sum() > 20
    generated = render.load_generated(GENERATED.with_name("lambert_sphere.py"))  # the same program, printed for numpy
    material = generated.prepare(kd)
    refs = {
        "lambert": lambda wi, wo: np.full(len(wi), kd / np.pi),
        "lambert_sphere": lambda wi, wo: generated.eval_local(material, wi, wo),
    }
    for name, f_local in refs.items():
        want, spread = _expected_image(f_local, light, size)
        got = panels[name]
        # a pixel is the mean of spp uniformly placed samples: within 4 standard errors of the pixel average
        tol = 4 * spread[inner] / np.sqrt(spp) + 1e-4 * want[inner]
        assert np.all(np.abs(got[inner] - want[inner]) < tol), name
        assert np.median(np.abs(got[inner] - want[inner]) / want[inner]) < 0.02, name
    with pytest.raises(ValueError):
        render_comparison(GENERATED, kd=1.5)
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
