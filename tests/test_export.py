"""``fitlab export``: the tables engines load, checked against the exact engine before they are stored, and read
back from every file by readers fitlab did not write (OpenEXR's and Mitsuba's for EXR, Mitsuba's libpng for PNG,
a C compiler for the header) within the precision each format keeps (:func:`fitlab.export.tolerance`)."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitlab.cli import main
from fitlab.export import FORMATS, Image, encode, file_name, texel_centres, tolerance
from fitlab.families.microfacet_energy.exact import directional_albedo, split_sum
from fitlab.families.microfacet_energy.program.images import IMAGES as MICROFACET_IMAGES
from fitlab.families.microfacet_energy.program.images import albedo_table, dfg

SIZE = 8


@pytest.fixture(scope="module")
def images():
    """Every microfacet table at SIZE texels a side, and the Lambert sphere's texture at 9 nodes."""
    from fitlab.families.lambert_sphere.program.images import texture_image

    found = {name: spec.build(SIZE) for name, spec in MICROFACET_IMAGES.items()}
    found["lambert_sphere_texture"] = texture_image(9)
    return found


# -- the values, before any format ---------------------------------------------------------
def test_dfg_is_the_split_sum_by_the_engines_other_route(images):
    """Both DFG tables against the split sum by the direction route (the table takes the half-vector route),
    to 1e-8, on every texel; and A + B is the albedo with F = 1."""
    mu, roughness = texel_centres(SIZE), texel_centres(SIZE)
    a, b = split_sum(mu[None, :], (roughness**2)[:, None], method="direction")
    karis, filament = images["dfg_karis"].data, images["dfg_filament"].data
    assert np.abs(karis[:, :, 0] - a).max() < 1e-8
    assert np.abs(karis[:, :, 1] - b).max() < 1e-8
    assert np.abs(filament[:, :, 0] - b).max() < 1e-8
    assert np.abs(filament[:, :, 1] - (a + b)).max() < 1e-8
    e = directional_albedo(mu[None, :], (roughness**2)[:, None], "ggx_correlated")
    assert np.abs(filament[:, :, 1] - e).max() < 1e-14


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_split_sum_limits(dtype):
    """alpha = 0 (the mirror): w_o . h = mu, so B = (1 - mu)^5 and A = 1 - B; alpha = 1 (D = 1/pi): A + B is
    1 - mu log((1 + mu)/mu), the correlated closed form; mu = 0: A + B = 1 (every visible facet reflects up)."""
    mu = np.linspace(0.0, 1.0, 11).astype(dtype)
    a, b = split_sum(mu, 0.0)
    assert np.abs(b - (1 - mu.astype(np.float64)) ** 5).max() < 1e-15
    assert np.abs(a + b - 1).max() < 1e-15
    m = mu[1:].astype(np.float64)
    a, b = split_sum(m, 1.0)
    assert np.abs(a + b - (1 - m * np.log((1 + m) / m))).max() < 1e-12
    for alpha in (1e-3, 0.3, 1.0):
        a, b = split_sum(0.0, alpha)
        assert abs(a + b - 1) < 1e-9 and 0 < b < 1


def test_albedo_tables_hold_the_engines_values(images):
    """E, 1 - E and the row's E_avg of each model at the texel centres, to rounding."""
    from fitlab.families.microfacet_energy.exact import average_albedo

    mu, alpha = texel_centres(SIZE), texel_centres(SIZE)
    for name, model in (("E_ggx_sep", "ggx_separable"), ("E_ggx_cor", "ggx_correlated"), ("E_on", "oren_nayar")):
        data = images[name].data
        e = directional_albedo(mu[None, :], alpha[:, None], model)
        # the table evaluates row by row, this test all at once: the same sums, grouped differently
        assert np.abs(data[:, :, 0] - e).max() < 1e-14
        assert np.abs(data[:, :, 1] - (1 - e)).max() < 1e-14
        assert np.abs(data[:, :, 2] - average_albedo(alpha, model)[:, None]).max() < 1e-14


def test_value_ranges_are_what_the_specs_state(images):
    """What decides PNG before any work (the spec's value_range) holds for the values; the Oren-Nayar table
    leaves [0, 1] (E > 1 at small roughness), so PNG is not among its formats."""
    for name, spec in MICROFACET_IMAGES.items():
        lo, hi = spec.value_range
        data = images[name].data
        assert lo <= data.min() and data.max() <= hi, name
        assert ("png" in spec.formats) == (lo >= 0.0 and hi <= 1.0), name
    assert images["E_on"].data[:, :, 1].min() < 0


# -- each format, read back by a reader fitlab did not write ---------------------------------
def _write(image: Image, fmt: str, folder) -> str:
    path = folder / file_name(image.name, fmt)
    path.write_bytes(encode(image, fmt))
    return str(path)


def _cases(images):
    return [(name, fmt) for name in images for fmt in FORMATS if fmt in _formats(name)]


def _formats(name):
    if name == "lambert_sphere_texture":
        return ("exr",)
    return MICROFACET_IMAGES[name].formats


def _exr_pixels(channels, count: int) -> np.ndarray:
    """(height, width, count) float64 from OpenEXR's channels (it groups R, G, B (A) into one array)."""
    names = "RGBA"[:count]
    if names in channels:
        return channels[names].pixels.astype(np.float64).reshape(*channels[names].pixels.shape[:2], count)
    return np.stack([channels[c].pixels.astype(np.float64) for c in names], axis=2)


@pytest.mark.parametrize("fmt", ["exr", "exr-half"])
def test_exr_read_by_openexr_within_its_precision(images, tmp_path, fmt):
    import OpenEXR

    for name, image in images.items():
        if fmt not in _formats(name):
            continue
        with OpenEXR.File(_write(image, fmt, tmp_path)) as f:
            header, channels = dict(f.header()), f.channels()  # the File clears its header on exit
            stored = _exr_pixels(channels, image.data.shape[2])
        assert stored.shape == image.data.shape
        assert np.all(np.abs(stored - image.data) <= tolerance(fmt, image.data)), name
        assert header.get("fitlab:table") == image.name, (name, sorted(header))
        assert "linear" in header["comments"] and "texel" in header["comments"]


@pytest.mark.parametrize("fmt", ["exr", "exr-half", "png"])
def test_mitsuba_bitmap_reads_every_file_within_its_precision(images, tmp_path, fmt):
    """Mitsuba's Bitmap (its own OpenEXR and libpng) reads the files: values, channels and the stated layout."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    read = 0
    for name, image in images.items():
        if fmt not in _formats(name):
            continue
        bitmap = mi.Bitmap(_write(image, fmt, tmp_path))
        stored = np.array(bitmap).astype(np.float64).reshape(image.height, image.width, -1)
        if fmt == "png":
            assert bitmap.component_format() == mi.Struct.Type.UInt16
            stored = stored / 65535.0
            stored = stored[:, :, :image.data.shape[2]]  # a two-channel table's B is 0
        assert stored.shape == image.data.shape, name
        assert np.all(np.abs(stored - image.data) <= tolerance(fmt, image.data)), name
        text = str(bitmap.metadata())
        assert "linear" in text and image.name in text
        read += 1
    assert read >= 3


def test_png_is_sixteen_bit_linear_and_states_its_layout(images, tmp_path):
    """The chunks as a PNG reader sees them (pypng's reader): 16 bits, gAMA 1.0, the description in tEXt."""
    import png

    image = images["dfg_karis"]
    reader = png.Reader(filename=_write(image, "png", tmp_path))
    width, height, rows, info = reader.read()
    assert (width, height, info["bitdepth"], info["planes"]) == (SIZE, SIZE, 16, 3)
    assert info["gamma"] == 1.0
    levels = np.array([list(r) for r in rows], dtype=np.float64).reshape(height, width, 3)
    assert np.all(levels[:, :, 2] == 0)
    text = [data for kind, data in png.Reader(filename=str(tmp_path / "dfg_karis.png")).chunks() if kind == b"tEXt"]
    assert b"fitlab:table\0dfg_karis" in text
    comment = next(data for data in text if data.startswith(b"Comment\0")).decode("latin-1")
    assert "linear" in comment and "perceptual roughness" in comment


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_header_compiles_and_holds_the_float32_values(images, tmp_path):
    """A C program includes the header and prints every value with %.9g (float32's round trip)."""
    image = images["E_ggx_cor"]
    header = _write(image, "c", tmp_path)
    h, w, c = image.data.shape
    source = tmp_path / "read.c"
    source.write_text(f'#include <stdio.h>\n#include "{header}"\nint main(void) {{\n'
                      f"  for (int j = 0; j < {h}; ++j) for (int i = 0; i < {w}; ++i) for (int k = 0; k < {c}; ++k)\n"
                      f'    printf("%.9g\\n", (double){image.name}[j][i][k]);\n  return 0;\n}}\n')
    exe = tmp_path / "read"
    subprocess.run(["cc", "-std=c99", "-Wall", "-Werror", "-o", str(exe), str(source)], check=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout.split()
    stored = np.array([float(v) for v in out]).reshape(h, w, c)
    assert np.array_equal(stored.astype(np.float32), image.data.astype(np.float32))


def test_glsl_constants_hold_the_float32_values(images, tmp_path):
    image = images["dfg_filament"]
    with open(_write(image, "glsl", tmp_path)) as f:
        text = f.read()
    sizes = {k: int(v) for k, v in re.findall(r"const int dfg_filament_(\w+) = (\d+);", text)}
    assert sizes == {"WIDTH": SIZE, "HEIGHT": SIZE, "CHANNELS": 2}
    body = text.split("float[](", 1)[1].split(");", 1)[0]
    values = np.array([float(v) for v in body.replace("\n", " ").split(",")], dtype=np.float32)
    assert np.array_equal(values, image.data.astype(np.float32).ravel())


def test_lambert_texture_exr_is_the_generated_texture_bit_for_bit(images, tmp_path):
    """The texture the generated tables BRDF reads (float32) comes back from the float EXR unchanged."""
    import OpenEXR

    from fitlab.families.lambert_sphere.program.table_export import texture

    with OpenEXR.File(_write(images["lambert_sphere_texture"], "exr", tmp_path)) as f:
        stored = f.channels()["R"].pixels
    assert stored.dtype == np.float32 and np.array_equal(stored, texture(9).data)


def test_encoding_is_reproducible(images):
    for name, fmt in _cases(images):
        assert encode(images[name], fmt) == encode(images[name], fmt), (name, fmt)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6))
def test_png_quantisation_is_round_to_nearest(tmp_path_factory, values):
    """Any values in [0, 1] come back from the PNG within half a level (pypng's reader)."""
    import png

    image = Image("t", np.array(values).reshape(1, 3, 2), ("a", "b"), ())
    folder = tmp_path_factory.mktemp("png")
    _, _, rows, _ = png.Reader(filename=_write(image, "png", folder)).read()
    levels = np.array([list(r) for r in rows], dtype=np.float64).reshape(1, 3, 3)[:, :, :2]
    assert np.all(np.abs(levels / 65535 - image.data) <= tolerance("png", image.data))


def test_half_tolerance_covers_subnormals_and_extremes(tmp_path):
    """Values across half's range, subnormals and 0 included, within the stated half tolerance."""
    import OpenEXR

    values = np.array([0.0, 1e-7, 3e-5, 6.1e-5, 1e-3, 0.5, 0.999, 1.0, 1000.0, 6.5e4]).reshape(1, 10, 1)
    image = Image("t", values, ("v",), ())
    with OpenEXR.File(_write(image, "exr-half", tmp_path)) as f:
        stored = f.channels()["R"].pixels.astype(np.float64)
    assert np.all(np.abs(stored - values[:, :, 0]) <= tolerance("exr-half", values[:, :, 0]))


# -- the command ----------------------------------------------------------------------------
def test_export_writes_every_file_with_the_stated_size(tmp_path, capsys):
    out = tmp_path / "tables"
    assert main(["export", "dfg_karis", "E_ggx_sep", "--format", "exr", "--format", "png", "--format", "c",
                 "--size", "4", "--out", str(out), "--quiet"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["E_ggx_sep.exr", "E_ggx_sep.h", "E_ggx_sep.png",
                                                     "dfg_karis.exr", "dfg_karis.h", "dfg_karis.png"]
    assert "[4][4][2]" in (out / "dfg_karis.h").read_text()
    expected = dfg(4, "karis")
    assert (out / "dfg_karis.exr").read_bytes() == encode(expected, "exr")
    assert (out / "E_ggx_sep.h").read_bytes() == encode(albedo_table("ggx_separable", 4), "c")


@pytest.mark.parametrize("argv, words", [
    (["nosuch"], ["no table 'nosuch'"]),
    (["E_on", "--format", "png"], ["E_on is not written as png"]),
    (["lambert_sphere_texture", "--format", "exr-half"], ["not written as exr-half"]),
    (["dfg_karis", "--size", "2"], ["--size 2"]),
    (["lambert_sphere_texture", "--size", "8"], ["--size 8"]),
    ([], ["name at least one table"]),
])
def test_bad_requests_are_refused_before_any_work(tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    assert main(["export", *argv, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and all(w in err for w in words), err
    assert not out.exists()


def test_list_names_every_table(capsys):
    assert main(["export", "--list"]) == 0
    out = capsys.readouterr().out
    for name in (*MICROFACET_IMAGES, "lambert_sphere_texture"):
        assert name in out


def test_ctrl_c_while_building_writes_nothing(tmp_path, monkeypatch, capsys):
    """A Ctrl-C while the second table is built: exit 130, and not even the first table's files are written."""
    import fitlab.families.microfacet_energy.program.images as images

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(images, "albedo_table", interrupted)
    out = tmp_path / "out"
    assert main(["export", "dfg_karis", "E_ggx_cor", "--size", "4", "--out", str(out), "--quiet"]) == 130
    assert not out.exists() or list(out.iterdir()) == []
