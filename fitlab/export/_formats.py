r"""The file formats of ``fitlab export``: one encoder per format, each the image's bytes, and the precision each keeps.

Details: docs/reference/file_formats.md, section ``fitlab.export._formats``."""

from __future__ import annotations

import io
import re

import numpy as np

from fitlab.export._image import CHANNEL_NAMES, Image

__all__ = ["FORMATS", "EXTRA", "file_name", "encode", "tolerance", "PNG_LEVELS"]

#: format -> the file name's ending after the table's name
FORMATS = {
    "exr": ".exr",
    "exr-half": "_half.exr",
    "ktx2": ".ktx2",
    "ktx2-half": "_half.ktx2",
    "png": ".png",
    "c": ".h",
    "glsl": ".glsl",
}
#: the Python package each format needs and the fitlab extra that installs it
EXTRA = {"exr": ("OpenEXR", "export"), "exr-half": ("OpenEXR", "export"), "png": ("png", "export")}
#: the levels of a 16-bit PNG channel
PNG_LEVELS = 65535


def file_name(name: str, fmt: str) -> str:
    """The file ``fmt`` writes for the table ``name``."""
    return name + FORMATS[fmt]


def tolerance(fmt: str, values) -> np.ndarray:
    """The largest |stored - value| ``fmt`` allows for each of ``values`` (float64): what a reader of the file
    must find, at most, against the table's float64 values."""
    v = np.abs(np.asarray(values, dtype=np.float64))
    if fmt in ("exr", "ktx2", "c", "glsl"):
        return np.maximum(v * 2.0**-24, 2.0**-150)
    if fmt in ("exr-half", "ktx2-half"):
        return np.where(v >= 2.0**-14, v * 2.0**-11, 2.0**-25)
    if fmt == "png":
        return np.full_like(v, 0.5 / PNG_LEVELS)
    raise ValueError(f"unknown format {fmt!r}")


def encode(image: Image, fmt: str) -> bytes:
    """The bytes of ``image`` in ``fmt`` (:data:`FORMATS`)."""
    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}, not {fmt!r}")
    return _ENCODERS[fmt](image)


def _exr(image: Image, dtype) -> bytes:
    import OpenEXR

    channels = {CHANNEL_NAMES[k]: np.ascontiguousarray(image.data[:, :, k].astype(dtype))
                for k in range(image.data.shape[2])}  # fmt: skip
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "comments": "\n".join(image.description()),
        "fitlab:table": image.name,
        "fitlab:origin": image.origin,
    }
    # OpenEXR writes files only: through a temporary name in a private folder, read back at once
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory(prefix="fitlab-exr-") as folder:
        path = Path(folder) / "image.exr"
        with OpenEXR.File(header, channels) as f:
            f.write(str(path))
        return path.read_bytes()


def _png(image: Image) -> bytes:
    import png

    data = image.data
    if data.min() < 0.0 or data.max() > 1.0:
        raise ValueError(f"table {image.name} has values outside [0, 1], which a 16-bit PNG cannot hold")
    levels = np.rint(data * PNG_LEVELS).astype(np.uint16)
    if levels.shape[2] == 2:
        levels = np.concatenate((levels, np.zeros_like(levels[:, :, :1])), axis=2)
    planes = levels.shape[2]
    writer = png.Writer(image.width, image.height, greyscale=planes == 1, alpha=planes == 4, bitdepth=16, gamma=1.0)
    buffer = io.BytesIO()
    writer.write(buffer, levels.reshape(image.height, image.width * planes).tolist())
    chunks = list(png.Reader(bytes=buffer.getvalue()).chunks())
    text = [
        (b"tEXt", b"fitlab:table\0" + image.name.encode("latin-1")),
        (b"tEXt", b"fitlab:origin\0" + image.origin.encode("latin-1")),
        (b"tEXt", b"Comment\0" + "\n".join(image.description()).encode("latin-1")),
    ]
    first_data = next(i for i, (kind, _) in enumerate(chunks) if kind == b"IDAT")
    out = io.BytesIO()
    png.write_chunks(out, chunks[:first_data] + text + chunks[first_data:])
    return out.getvalue()


def _ktx_writer() -> str:
    """KTXwriter (KTX §5.5): the tool that wrote the file, with its version."""
    from fitlab import __version__

    return f"fitlab {__version__}"


#: what a KTX2 file says of its fourth channel when the table has three
_KTX2_PADDING = (
    "channel A: 1, padding: KTX2 stores a three-channel table as four channels (the KTX "
    "specification's format mapping has no Metal format for R32G32B32_SFLOAT and neither a Metal nor "
    "a DXGI format for R16G16B16_SFLOAT)"
)


def _ktx2(image: Image, component_bytes: int) -> bytes:
    from fitlab.export import _ktx2

    description = image.description()
    if image.data.shape[2] == 3:
        description.insert(6, _KTX2_PADDING)  # after the lines of the name, order, colour space and 3 channels
    # KTXorientation (KTX §5.2): "rd", S to the right and T down, the first row stored at the top of the picture,
    # whichever row of the table it holds (image.origin, stated in fitlab:origin and fitlab:layout)
    key_values = {
        "KTXorientation": "rd",
        "KTXwriter": _ktx_writer(),
        "fitlab:table": image.name,
        "fitlab:origin": image.origin,
        "fitlab:layout": "\n".join(description),
    }
    return _ktx2.encode(image.data, component_bytes, key_values)


def _decimal(v: np.float32) -> str:
    """The shortest decimal that reads back as the float32 ``v``, always with a point or an exponent."""
    text = np.format_float_scientific(v, unique=True, trim="0", exp_digits=2)
    return text.replace(".e", ".0e")


def _identifier(name: str) -> str:
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise ValueError(f"table name {name!r} is not an identifier")
    return name


def _values(image: Image) -> list[str]:
    return [_decimal(v) for v in image.data.astype(np.float32).ravel()]


def _comment(image: Image) -> list[str]:
    return [" * " + line for line in image.description()]


def _c(image: Image) -> bytes:
    name = _identifier(image.name)
    values = _values(image)
    per_row = image.width * image.data.shape[2]
    rows = []
    for j in range(image.height):
        row = values[j * per_row : (j + 1) * per_row]
        texels = ["{" + ", ".join(v + "f" for v in row[i:i + image.data.shape[2]]) + "}"
                  for i in range(0, per_row, image.data.shape[2])]  # fmt: skip
        rows.append("    {" + ", ".join(texels) + "}")
    guard = f"FITLAB_{name.upper()}_H"
    lines = [
        "/* Generated by fitlab export; do not edit.",
        *_comment(image),
        " */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        f"static const float {name}[{image.height}][{image.width}][{image.data.shape[2]}] = {{",
        ",\n".join(rows),
        "};",
        "",
        f"#endif /* {guard} */",
        "",
    ]
    return "\n".join(lines).encode()


def _glsl(image: Image) -> bytes:
    name = _identifier(image.name)
    values = _values(image)
    per_row = image.width * image.data.shape[2]
    rows = ["    " + ", ".join(values[j * per_row : (j + 1) * per_row]) for j in range(image.height)]
    lines = [
        "/* Generated by fitlab export; do not edit.",
        *_comment(image),
        f" * texel (x, y), channel k is {name}[(y * {name}_WIDTH + x) * {name}_CHANNELS + k]",
        " */",
        f"const int {name}_WIDTH = {image.width};",
        f"const int {name}_HEIGHT = {image.height};",
        f"const int {name}_CHANNELS = {image.data.shape[2]};",
        f"const float {name}[{len(values)}] = float[](",
        ",\n".join(rows),
        ");",
        "",
    ]
    return "\n".join(lines).encode()


_ENCODERS = {
    "exr": lambda image: _exr(image, np.float32),
    "exr-half": lambda image: _exr(image, np.float16),
    "ktx2": lambda image: _ktx2(image, 4),
    "ktx2-half": lambda image: _ktx2(image, 2),
    "png": _png,
    "c": _c,
    "glsl": _glsl,
}
