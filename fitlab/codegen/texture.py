r"""Tables as engines ship them: a float32 texture, and lookups of it defined once, symbolically.

A :class:`Texture` is a 2-D array of float32 values, ``rows x columns``, shipped three ways from the same
numbers:

* C: a ``static const float PREFIX_data[ROWS][COLUMNS]`` array in a header of its own (``PREFIX_data.h``);
* a raw file ``PREFIX.f32``: the values as little-endian IEEE float32, row after row (row 0 first, each
  row from column 0), no header: ``rows * columns * 4`` bytes, a 2-D texture of format R32F (OpenGL
  ``GL_R32F``/``GL_RED``/``GL_FLOAT``, Vulkan ``VK_FORMAT_R32_SFLOAT``, Direct3D ``DXGI_FORMAT_R32_FLOAT``)
  ``columns`` texels wide and ``rows`` texels high, texel (x = column, y = row);
* numpy: the generated module reads that file.

Details: docs/tables.md, section ``fitlab.codegen.texture``."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from fitlab.codegen._model import Program
from fitlab.codegen._policy import clamp
from fitlab.codegen.languages import emit
from fitlab.codegen.names import LOOKUPS
from fitlab.codegen.program import call

__all__ = [
    "Texture",
    "TEXEL",
    "LOOKUPS",
    "texel",
    "lookup_1d",
    "lookup_2d",
    "lookup_3d",
    "combined_lookup_3d",
    "axis_weights",
    "emit_textured",
    "texture_bytes",
    "TEXTURE_SHIM",
    "texture_from_bytes",
]

#: the routine name every lookup reads texels through (printed PREFIX_texel, PREFIX_texel_f)
TEXEL = "texel"


def texel(row, col) -> sp.Expr:
    """The texture's value at (row, column), integer-valued expressions (a call of the generated texel function)."""
    return call(TEXEL, row, col)


def _lagrange(t) -> list:
    """The Lagrange cubics through the nodes 0, 1, 2, 3, at t."""
    return [-(t - 1) * (t - 2) * (t - 3) / 6, t * (t - 2) * (t - 3) / 2, -t * (t - 1) * (t - 3) / 2,
            t * (t - 1) * (t - 2) / 6]  # fmt: skip


def axis_weights(x, n: int, lookup: str) -> tuple[sp.Expr, list]:
    """(first node index, [weight of node first + k]) of coordinate ``x`` (clamped into [0, 1]) on an axis of
    ``n`` nodes k/(n - 1); ``lookup`` is ``linear`` (2 nodes) or ``cubic`` (4, Lagrange).  The window first ..
    first + 1 (or + 3) lies in 0 .. n - 1 for every x but NaN, which gives NaN weights."""
    if lookup not in LOOKUPS:
        raise ValueError(f"lookup must be one of {', '.join(LOOKUPS)}, not {lookup!r}")
    if n < LOOKUPS[lookup]:
        raise ValueError(f"a {lookup} lookup needs at least {LOOKUPS[lookup]} nodes per axis, not {n}")
    p = clamp(x, 0, 1) * (n - 1)
    node = sp.floor(p)
    # the window's first node, as conditionals rather than max/min: the same in every language (a NaN p fails
    # every comparison and gives a NaN index, hence NaN weights), and sympy does not compare them while printing
    if lookup == "linear":
        first = sp.Piecewise((n - 2, node > n - 2), (node, True))
        t = p - first
        return first, [1 - t, t]
    first = sp.Piecewise((0, node < 1), (n - 4, node > n - 3), (node - 1, True))
    return first, _lagrange(p - first)


def lookup_1d(row: int, x, n: int, lookup: str) -> sp.Expr:
    """The function tabulated in row ``row`` (columns 0 .. n-1 at x = k/(n - 1)), at ``x``."""
    first, w = axis_weights(x, n, lookup)
    return sp.Add(*(wk * texel(row, first + k) for k, wk in enumerate(w)))


def lookup_2d(row0: int | sp.Expr, x, y, n_x: int, n_y: int, lookup: str) -> sp.Expr:
    """The function tabulated in rows row0 .. row0 + n_y - 1 (row ``row0 + j`` at y = j/(n_y - 1), column k at
    x = k/(n_x - 1)), at (x, y): bilinear or bicubic (:func:`axis_weights`)."""
    fx, wx = axis_weights(x, n_x, lookup)
    fy, wy = axis_weights(y, n_y, lookup)
    return sp.Add(*(wy[a] * sp.Add(*(wx[b] * texel(row0 + fy + a, fx + b) for b in range(len(wx))))
                    for a in range(len(wy))))  # fmt: skip


def lookup_3d(row0: int, x, y, z, n_x: int, n_y: int, n_z: int, lookup: str, z_lookup: str | None = None) -> sp.Expr:
    """The function tabulated in ``n_z`` slabs of ``n_y`` rows from row ``row0`` (row ``row0 + k n_y + j`` at
    z = k/(n_z - 1), y = j/(n_y - 1); column i at x = i/(n_x - 1)), at (x, y, z): the lookup along z (``z_lookup``,
    else ``lookup``) of the slabs' :func:`lookup_2d` (trilinear, tricubic, or bicubic in the slabs and linear
    along z)."""
    return combined_lookup_3d(((row0, 1),), x, y, z, n_x, n_y, n_z, lookup, z_lookup)


def combined_lookup_3d(
    tables, x, y, z, n_x: int, n_y: int, n_z: int, lookup: str, z_lookup: str | None = None
) -> sp.Expr:
    """sum_m a_m f_m(x, y, z) for ``tables`` ((row0_m, a_m), ...), each f_m tabulated from row0_m as
    :func:`lookup_3d` reads it, with one set of weights and node indices for all: at each node the texels are
    combined, sum_m a_m texel_m, then interpolated once (the weights of x, y, z computed once; as many texels
    as tables per node)."""
    fx, wx = axis_weights(x, n_x, lookup)
    fy, wy = axis_weights(y, n_y, lookup)
    fz, wz = axis_weights(z, n_z, z_lookup or lookup)

    def node(k, a, b):
        return sp.Add(*(factor * texel(row0 + (fz + k) * n_y + fy + a, fx + b) for row0, factor in tables))

    return sp.Add(*(wz[k] * sp.Add(*(wy[a] * sp.Add(*(wx[b] * node(k, a, b) for b in range(len(wx))))
                                     for a in range(len(wy)))) for k in range(len(wz))))  # fmt: skip


@dataclass(frozen=True)
class Texture:
    """A float32 texture: ``data`` (rows, columns) and what it holds.

    blocks: (first row, number of rows, what they hold), in order, covering every row (written above each
    block in the C header, and in the layout notes).
    layout: lines that say how to address it (the generated files and docs quote them).
    """

    data: np.ndarray
    blocks: tuple = ()
    layout: tuple = field(default_factory=tuple)

    def __post_init__(self):
        data = np.ascontiguousarray(self.data, dtype=np.float32)
        if data.ndim != 2:
            raise ValueError("a texture is a 2-D array (rows, columns)")
        if not np.all(np.isfinite(data)):
            raise ValueError("a texture holds finite values only")
        object.__setattr__(self, "data", data)
        covered = sum(n for _, n, _ in self.blocks)
        if self.blocks and covered != data.shape[0]:
            raise ValueError(f"the blocks cover {covered} rows of {data.shape[0]}")

    @property
    def rows(self) -> int:
        return self.data.shape[0]

    @property
    def columns(self) -> int:
        return self.data.shape[1]

    @property
    def nbytes(self) -> int:
        return self.rows * self.columns * 4


def texture_bytes(texture: Texture) -> bytes:
    """The raw file: every value as little-endian float32, row after row."""
    return texture.data.astype("<f4").tobytes()


def texture_from_bytes(data: bytes, rows: int, columns: int) -> np.ndarray:
    """The values of a raw texture file (the inverse of :func:`texture_bytes`); a size that is not
    rows x columns float32 values is a ValueError."""
    if len(data) != rows * columns * 4:
        raise ValueError(f"a {columns} x {rows} R32F texture is {rows * columns * 4} bytes, not {len(data)}")
    return np.frombuffer(data, dtype="<f4").reshape(rows, columns)


def _float_literal(x: np.float32) -> str:
    """The shortest decimal that reads back as this float32 exactly, with C's F suffix."""
    mantissa, _, exponent = np.format_float_scientific(x, unique=True, trim="-", exp_digits=2).partition("e")
    return f"{mantissa if '.' in mantissa else mantissa + '.0'}e{exponent}F"


def _macro(program: Program, name: str) -> str:
    return f"{program.name.upper()}_{name}"


def _c_data_header(program: Program, texture: Texture, banner: str) -> str:
    """The header with the texture as a static const float array, its size and the texel functions."""
    guard = _macro(program, "DATA_H")
    prefix = program.prefix
    out = [banner, f"#ifndef {guard}\n#define {guard}\n\n/*\n"]
    out += [f" * {line}".rstrip() + "\n" for line in texture.layout]
    out.append(" */\n\n")
    out.append(f"#define {_macro(program, 'ROWS')} {texture.rows}\n#define {_macro(program, 'COLUMNS')} "
               f"{texture.columns}\n\n")  # fmt: skip
    out.append(f"static const float {prefix}data[{texture.rows}][{texture.columns}] = {{\n")
    for first, count, what in texture.blocks or ((0, texture.rows, "rows"),):
        out.append(f"    /* rows {first} .. {first + count - 1}: {what} */\n")
        for r in range(first, first + count):
            values = [_float_literal(v) for v in texture.data[r]]
            lines, line = [], "        "
            for v in values:
                if len(line) + len(v) + 2 > 116:
                    lines.append(line.rstrip())
                    line = "        "
                line += v + ", "
            lines.append(line.rstrip().rstrip(","))
            out.append(f"    {{ /* row {r} */\n" + "\n".join(lines) + "\n    },\n")
    out.append("};\n\n")
    out.append(
        "/* The texture's value at (row, column), integer-valued: every lookup forms indices in the table for every\n"
        " * input but NaN (its coordinates are clamped), and a NaN index reads index 0 (a NaN coordinate's weights\n"
        " * make the lookup NaN), so only the lower bound is checked: a check of both bounds per texel would cost\n"
        " * more than the rest of the lookup. */\n"
    )
    for scalar, suffix in (("double", ""), ("float", "_f")):
        out.append(f"static {scalar} {prefix}texel{suffix}({scalar} row, {scalar} col)\n{{\n"
                   f"    const int i = (row >= 0) ? (int)row : 0;\n"
                   f"    const int j = (col >= 0) ? (int)col : 0;\n"
                   f"    return ({scalar}){prefix}data[i][j];\n}}\n")  # fmt: skip
    out.append(f"\n#endif /* {guard} */\n")
    return "".join(out)


def _glsl_block(program: Program, texture: Texture) -> str:
    """The sampler (unless the includer names its own with PREFIX_TEXTURE) and the texel function."""
    name = _macro(program, "TEXTURE")
    lines = ["", "// The tables: one R32F texture (texelFetch only: no filtering, no mipmaps).",
             *(f"// {line}".rstrip() for line in texture.layout),
             f"// Bind it to the sampler {program.prefix}texture, or #define {name} as your own highp sampler2D "
             "before this file.", "#ifdef GL_ES", "precision highp float;", "precision highp int;",
             "precision highp sampler2D;", "#endif", f"#ifndef {name}", f"#define {name} {program.prefix}texture",
             f"uniform highp sampler2D {program.prefix}texture;", "#endif",
             f"float {program.prefix}texel(float row, float col) "
             f"{{ return texelFetch({name}, ivec2(col, row), 0).r; }}",
             ""]  # fmt: skip
    return "\n".join(lines) + "\n"


def _python_block(program: Program, texture: Texture, file_name: str) -> str:
    rows, cols = texture.rows, texture.columns
    layout = "\n".join(f"#: {line}".rstrip() for line in texture.layout)
    return f'''

# ---- the texture -------------------------------------------------------------------------------------
{layout}
TEXTURE_FILE = "{file_name}"
TEXTURE_SHAPE = ({rows}, {cols})


def _read_texture():
    """The texture file beside this module ({rows} x {cols} little-endian float32), as float64."""
    import pathlib

    path = pathlib.Path(__file__).with_name(TEXTURE_FILE)
    data = numpy.fromfile(path, dtype="<f4")
    if data.size != {rows * cols}:
        raise ValueError(f"{{path}}: {{data.size}} float32 values, expected {rows * cols} ({rows} rows x {cols} columns)")
    return data.reshape(TEXTURE_SHAPE).astype(numpy.float64)


TEXTURE = _read_texture()


def texel(row, col):
    """The texture's value at integer-valued (row, col); a NaN or out-of-range index reads index 0 (a NaN
    coordinate's weights make the lookup NaN)."""
    row, col = numpy.asarray(row, dtype=float), numpy.asarray(col, dtype=float)
    i = numpy.where((row >= 0) & (row <= {rows - 1}), row, 0).astype(numpy.intp)
    j = numpy.where((col >= 0) & (col <= {cols - 1}), col, 0).astype(numpy.intp)
    return TEXTURE[i, j]
'''  # noqa: E501 (a line of the generated module)


def _banner_of(text: str, comment: str) -> str:
    """The banner that opens an emitted file: its first block comment (C) or its leading comment lines."""
    if comment == "/*":
        end = text.index("*/\n") + 3
        return text[:end]
    lines = text.splitlines(keepends=True)
    k = 0
    while k < len(lines) and lines[k].startswith("//"):
        k += 1
    return "".join(lines[:k])


def emit_textured(program: Program, texture: Texture, lang: str, command: str | None = None) -> dict[str, bytes]:
    """{file name: bytes} of ``program`` (whose routines read ``texture`` through :func:`texel`) in ``lang``:
    c (PREFIX.h, PREFIX.c and PREFIX_data.h, the array), glsl (PREFIX.glsl and PREFIX.f32) or python
    (PREFIX.py and PREFIX.f32, which the module reads)."""
    if lang not in ("c", "glsl", "python"):
        raise ValueError(f"a program with a texture is printed in c, glsl or python, not {lang!r}")
    files = emit(program, lang, command)
    base, raw = program.name, f"{program.name}.f32"
    if lang == "c":
        header, source = files[f"{base}.h"], files[f"{base}.c"]
        banner = _banner_of(source, "/*")
        data_name = f"{base}_data.h"
        # the source's banner, then the array and its texel functions, then what emit wrote
        source = banner + f'#include "{data_name}"\n' + source[len(banner) :]
        out = {f"{base}.h": header, f"{base}.c": source, data_name: _c_data_header(program, texture, banner)}
        return {name: text.encode() for name, text in out.items()}
    if lang == "glsl":
        (text,) = files.values()
        banner = _banner_of(text, "//")
        # after the banner, before any function: the sampler and the texel function the routines call
        return {f"{base}.glsl": (banner + _glsl_block(program, texture) + text[len(banner):]).encode(),
                raw: texture_bytes(texture)}  # fmt: skip
    (text,) = files.values()
    return {f"{base}.py": (text + _python_block(program, texture, raw)).encode(), raw: texture_bytes(texture)}


#: compiles the GLSL of a textured program as C (after :data:`fitlab.codegen.native.GLSL_SHIM`): the sampler
#: becomes an array the test binds with ``shim_bind_texture(data, columns, rows)`` (ctypes), texelFetch a read
TEXTURE_SHIM = r"""
#define uniform static
#define highp
typedef int sampler2D;
typedef struct { int x, y; } shim_ivec2;
static shim_ivec2 shim_make_ivec2(int x, int y) { shim_ivec2 v; v.x = x; v.y = y; return v; }
#define ivec2(x, y) shim_make_ivec2((int)(x), (int)(y))
typedef struct { float r, g, b, a; } shim_texel;
static const float *shim_texture = 0;
static int shim_columns = 0, shim_rows = 0;
void shim_bind_texture(const float *data, int columns, int rows) { shim_texture = data; shim_columns = columns; shim_rows = rows; }
static shim_texel texelFetch(sampler2D sampler, shim_ivec2 p, int lod)
{
    shim_texel t; (void)sampler; (void)lod;
    t.r = (p.x >= 0 && p.x < shim_columns && p.y >= 0 && p.y < shim_rows) ? shim_texture[p.y * shim_columns + p.x] : 0.0f;
    t.g = t.b = 0.0f; t.a = 1.0f;
    return t;
}
"""  # noqa: E501 (C source)
