"""Mitsuba 3 renders the generated Python BRDF: pixels match a direct evaluation; white furnace."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

from fitlab.families.lambert_sphere.render import (  # noqa: E402
    chandrasekhar_albedo_c, _chandrasekhar_kd, load_generated, oren_nayar, pixel_geometry, render_comparison, render_sphere,
)  # fmt: skip

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "fitlab" / "fits" / "generated" / "lambert_sphere.py"
SIZE = 12


@pytest.fixture(scope="module")
def gen():
    return load_generated(GENERATED)


def _local(n, v):
    t1 = np.cross(n, [0.3, 0.5, 0.1])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    return np.array([v @ t1, v @ t2, v @ n])


def expected_image(f, light, size, sub=6, extent=1.05):
    """Pixel averages of f(wi, wo) cos(theta_i) (unit irradiance), sub x sub points per pixel."""
    fine = pixel_geometry(size * sub, extent)
    out = np.zeros((size * sub, size * sub))
    wo = np.array([0.0, 0.0, 1.0])
    for i in range(size * sub):
        for j in range(size * sub):
            n = fine[i, j]
            if np.isnan(n[0]):
                continue
            wi_l, wo_l = _local(n, light), _local(n, wo)
            out[i, j] = float(f(wi_l, wo_l)) * max(wi_l[2], 0.0)
    blocks = out.reshape(size, sub, size, sub)
    return blocks.mean(axis=(1, 3)), blocks.std(axis=(1, 3))


def test_rendered_pixels_match_the_generated_brdf(gen):
    light = np.array([0.55, 0.3, 0.78])
    light /= np.linalg.norm(light)  # off both image axes: checks the camera's orientation too
    kd = 0.6
    spp = 32
    img = render_sphere("lambert_sphere", kd, light, SIZE, spp, generated=gen, seed=1)
    c = float(gen.c_of_kd(kd))
    want, spread = expected_image(lambda a, b: gen.brdf_local(a, b, c), light, SIZE)
    n = pixel_geometry(SIZE)
    inner = (np.nan_to_num(n[..., 2]) > 0.5) & (want > 0.05 * want.max())  # covered, lit pixels
    assert inner.sum() > 30
    # a pixel is the mean of spp jittered samples: within 4 standard errors of the pixel average
    tol = 4 * spread[inner] / np.sqrt(spp) + 0.005 * want[inner]
    assert np.all(np.abs(img[inner] - want[inner]) < tol)
    assert np.median(np.abs(img[inner] - want[inner]) / want[inner]) < 0.01
    mirrored = want[::-1, ::-1]
    assert np.max(np.abs(img[inner] - mirrored[inner]) / mirrored[inner]) > 0.1  # the test can tell orientation


def test_white_furnace(gen):
    """c = 1 under a uniform environment of radiance 1: each pixel is the directional albedo."""
    img = render_sphere("lambert_sphere", 1.0, None, SIZE, 64, generated=gen, seed=2)
    n = pixel_geometry(SIZE)
    inner = np.nan_to_num(n[..., 2]) > 0.3
    x, w = np.polynomial.legendre.leggauss(48)
    mu_l, wmu = 0.5 * (x + 1), 0.5 * w
    phi, wphi = np.pi * (x + 1), np.pi * w
    albedo = []
    for mu_o in n[inner][:, 2]:
        mu_i, ph = np.meshgrid(mu_l, phi, indexing="ij")
        f = gen.brdf(mu_i, mu_o, np.cos(ph), 1.0)
        albedo.append(np.einsum("i,j,ij,i->", wmu, wphi, f, mu_l))
    albedo = np.array(albedo)
    assert np.all(np.abs(albedo - 1.0) < 0.01)  # the refit runtime model conserves energy to 1 % (docs/audit.md)
    assert abs(img[inner].mean() - albedo.mean()) < 0.01
    assert np.all(np.abs(img[inner] - albedo) < 0.15)  # single pixels: 64 samples each


def test_comparison_materials_have_the_same_albedo():
    kd = 0.7
    c = chandrasekhar_albedo_c(kd)
    assert abs(_chandrasekhar_kd(c) - kd) < 1e-9
    wi = np.array([0.0, 0.0, 1.0])
    assert abs(float(oren_nayar(wi, wi, kd)) - kd / np.pi * (1 - 0.5 * 0.25 / 0.58)) < 1e-12  # normal incidence: A kd/pi


def test_render_comparison_writes_png(tmp_path):
    out = render_comparison(tmp_path / "r.png", GENERATED, kd=0.8, size=8, spp=1, lights=1, show_progress=False)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ValueError):
        render_comparison(tmp_path / "bad.png", GENERATED, kd=1.5)
    assert not (tmp_path / "bad.png").exists()


def test_render_cli_errors(tmp_path, capsys):
    from fitlab.cli import main

    out = tmp_path / "out"
    assert main(["render", "--generated", str(tmp_path / "missing.py"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "fitlab codegen --lang python" in err and "\n" not in err
    assert not out.exists()
    (tmp_path / "x.png").write_bytes(b"keep me")  # --out is a folder (render.png goes into it), never a file
    assert main(["render", "--generated", str(GENERATED), "--out", str(tmp_path / "x.png")]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert (tmp_path / "x.png").read_bytes() == b"keep me"
