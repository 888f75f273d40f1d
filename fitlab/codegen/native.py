r"""Compile the generated C and call it from numpy (ctypes): for tests and benchmarks.

``build(files, workdir)`` compiles the generated source plus a loop wrapper
per routine, ``NAME_loop(n, in0, in1, ..., out)`` in double and
``NAME_f_loop`` in float, into a shared library; :class:`NativeModel` calls
those loops on numpy arrays.  The wrapper only loops: the per-element work
is the generated function, so timings of a loop are timings of the function.
The model records the compiler command line it was built with (``command``).

``build_glsl(files, workdir)`` compiles the generated GLSL as C, against a shim
of the GLSL built-ins (:data:`GLSL_SHIM`: GLSL's float subset is C), with the
same float loops: the shader functions called on arrays, in float only.  The
shim is IEEE float, so it checks the GLSL's arithmetic and its NaN policy as
written; a GPU compiler may fold NaN away (GLSL does not require NaN).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from fitlab.codegen._model import Program

__all__ = [
    "compiler",
    "cxx_compiler",
    "build_library",
    "c_function",
    "STRICT_FLAGS",
    "GLSL_FLAGS",
    "GLSL_SHIM",
    "HLSL_SHIM",
    "METAL_STDLIB",
    "METAL_FLAGS",
    "build",
    "build_glsl",
    "NativeModel",
    "CompileError",
]

#: the standard of the generated C: it compiles clean under these
STRICT_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror")


class CompileError(RuntimeError):
    pass


def compiler() -> str | None:
    """A C compiler on PATH (cc, gcc or clang), or None."""
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return path
    return None


#: flags the GLSL-as-C shim is compiled with (the shim's built-ins are static, some unused)
GLSL_FLAGS = ("-std=c99", "-O2", "-Wall", "-Werror", "-Wno-unused-function")

#: GLSL's float built-ins as C (float versions of libm), for compiling the generated GLSL as C
GLSL_SHIM = r"""
#include <math.h>
typedef struct { float x, y, z; } vec3;
#define SHADER_VEC3 vec3
static vec3 glsl_vec3(const float *p) { vec3 v; v.x = p[0]; v.y = p[1]; v.z = p[2]; return v; }
static vec3 glsl_make_vec3(float x, float y, float z) { vec3 v; v.x = x; v.y = y; v.z = z; return v; }
#define vec3(x, y, z) glsl_make_vec3(x, y, z)
typedef struct { float x, y, z, w; } vec4;
#define SHADER_VEC4 vec4
static vec4 glsl_make_vec4(float x, float y, float z, float w) { vec4 v; v.x = x; v.y = y; v.z = z; v.w = w; return v; }
#define vec4(x, y, z, w) glsl_make_vec4(x, y, z, w)
static float max(float a, float b) { return fmaxf(a, b); }
static float min(float a, float b) { return fminf(a, b); }
static float abs_(float a) { return fabsf(a); }
#define abs abs_
#define sqrt sqrtf
#define pow powf
#define exp expf
#define log logf
#define acos acosf
#define atan atanf
#define tanh tanhf
#define cos cosf
#define sin sinf
"""


def _loop_source(program: Program) -> str:
    lines = [f'#include "{program.name}.h"', ""]
    for r in program.routines:
        func, sig = program.prefix + r.name, r.signature()
        for scalar, suffix in (("double", ""), ("float", "_f")):
            params = ", ".join(f"const {scalar} *{a}" for a in sig)
            args = ", ".join(f"{a} + 3 * i" if a in r.vectors else f"{a}[i]" for a in sig)
            lines.append(f"void {func}{suffix}_loop(long n, {params}, {scalar} *out)")
            lines.append(f"{{ long i; for (i = 0; i < n; ++i) {_store(r, f'{func}{suffix}', args, False)} }}")
    return "\n".join(lines + _material_loops(program, by_value=False)) + "\n"


def _store(r, func: str, args: str, by_value: bool) -> str:
    """The statement of a loop that stores point i: out[i] = value, or for a routine with an output vector
    (value, x, y, z) at out + 4 i (C writes the vector through its pointer, a shader returns a 4-vector)."""
    if not r.out:
        return f"out[i] = {func}({args});"
    if by_value:
        return (
            f"{{ SHADER_VEC4 v = {func}({args}); out[4 * i] = v.w; out[4 * i + 1] = v.x; out[4 * i + 2] = v.y; "
            "out[4 * i + 3] = v.z; }"
        )
    return f"out[4 * i] = {func}({args}, out + 4 * i + 1);"


def _material_loops(program: Program, by_value: bool, scalars=(("double", "", ""), ("float", "_f", "_f"))) -> list[str]:
    """Loops of the per-material routines: ``PREPARE_loop(n, params..., material *out)`` fills n structs;
    ``EVAL_loop(n, const material *m, const long *which, args..., out)`` evaluates point i with material
    which[i] (the set-up hoisted, as a renderer calls it); ``EVAL_rgb_loop`` the same with three materials
    per point (m + 3 which[i]) and three outputs.  ``scalars``: (type, suffix of the functions called, suffix
    of the loops) (GLSL: float functions without a suffix, loops named like C's float ones)."""
    m, prefix, lines = program.material, program.prefix, []
    if m is None:
        return lines
    for scalar, suffix, loop in scalars:
        struct = f"{prefix}material{suffix}"
        for name, params in ((m.prepare_name, m.params), *((n, (a,)) for n, a, _ in m.setups)):
            decl = ", ".join(f"const {scalar} *{a}" for a in params)
            lines.append(f"void {prefix}{name}{loop}_loop(long n, {decl}, {struct} *out)")
            lines.append(
                f"{{ long i; for (i = 0; i < n; ++i) out[i] = {prefix}{name}{suffix}"
                f"({', '.join(f'{a}[i]' for a in params)}); }}"
            )
        for r in m.evaluators:
            sig = r.signature()
            decl = ", ".join(f"const {scalar} *{a}" for a in sig)
            args = ", ".join(f"{a} + 3 * i" if a in r.vectors else f"{a}[i]" for a in sig)
            if by_value:  # GLSL: structs and vectors by value
                args = ", ".join(f"glsl_vec3({a} + 3 * i)" if a in r.vectors else f"{a}[i]" for a in sig)
            one = "m[which[i]]" if by_value else "m + which[i]"
            lines.append(
                f"void {prefix}{r.name}{loop}_loop(long n, const {struct} *m, const long *which, {decl}, {scalar} *out)"
            )
            store = _store(r, f"{prefix}{r.name}{suffix}", f"{one}, {args}", by_value)
            lines.append(f"{{ long i; for (i = 0; i < n; ++i) {store} }}")
            if r.out:
                continue
            if by_value:
                three = "m[3 * which[i]], m[3 * which[i] + 1], m[3 * which[i] + 2]"
                lines.append(
                    f"void {prefix}{r.name}_rgb{loop}_loop(long n, const {struct} *m, const long *which, "
                    f"{decl}, {scalar} *out)"
                )
                lines.append(
                    f"{{ long i; for (i = 0; i < n; ++i) {{ "
                    f"SHADER_VEC3 v = {prefix}{r.name}_rgb({three}, {args}); "
                    "out[3 * i] = v.x; out[3 * i + 1] = v.y; out[3 * i + 2] = v.z; } }"
                )
            else:
                lines.append(
                    f"void {prefix}{r.name}_rgb{loop}_loop(long n, const {struct} *m, const long *which, "
                    f"{decl}, {scalar} *out)"
                )
                lines.append(
                    f"{{ long i; for (i = 0; i < n; ++i) {prefix}{r.name}_rgb{suffix}(m + 3 * which[i], "
                    f"{args}, out + 3 * i); }}"
                )
    return lines


#: HLSL's float subset is C too, with float3 for vec3 (the same shim, and the name)
HLSL_SHIM = GLSL_SHIM + (
    "typedef vec3 float3;\n#define float3(x, y, z) glsl_make_vec3(x, y, z)\n"
    "typedef vec4 float4;\n#define float4(x, y, z, w) glsl_make_vec4(x, y, z, w)\n"
)

#: a C++ stand-in for <metal_stdlib>: the Metal Shading Language is C++14 with float overloads of the
#: built-ins and a float3 type; the generated .metal file compiles against it as C++ (-I the folder)
METAL_STDLIB = r"""
#pragma once
#include <cmath>
namespace metal {
using std::abs; using std::acos; using std::exp; using std::log; using std::pow; using std::sqrt; using std::atan;
using std::tanh; using std::cos; using std::sin;
struct float3 { float x, y, z; float3() : x(0), y(0), z(0) {} float3(float a, float b, float c) : x(a), y(b), z(c) {} };
struct float4 {
    float x, y, z, w;
    float4() : x(0), y(0), z(0), w(0) {}
    float4(float a, float b, float c, float d) : x(a), y(b), z(c), w(d) {}
};
}
"""


def _glsl_loop_source(program: Program, lang: str = "glsl") -> str:
    """Loops over the shader functions: C against :data:`GLSL_SHIM` / :data:`HLSL_SHIM`, or C++ (extern "C"
    loops) against :data:`METAL_STDLIB` for Metal."""
    if lang == "metal":
        head = [
            "#include <metal_stdlib>",
            f'#include "{program.name}.metal"',
            "#define SHADER_VEC3 float3",
            "#define SHADER_VEC4 float4",
            "static float3 glsl_vec3(const float *p) { return float3(p[0], p[1], p[2]); }",
            'extern "C" {',
        ]
    else:
        # the language names a struct type by its tag; C needs a typedef (allowed before the struct's definition)
        struct = [f"typedef struct {program.prefix}material {program.prefix}material;"] if program.material else []
        head = [GLSL_SHIM if lang == "glsl" else HLSL_SHIM, *struct, f'#include "{program.name}.{lang}"']
    lines = [*head, ""]
    for r in program.routines:
        func, sig = program.prefix + r.name, r.signature()
        params = ", ".join(f"const float *{a}" for a in sig)
        args = ", ".join(f"glsl_vec3({a} + 3 * i)" if a in r.vectors else f"{a}[i]" for a in sig)
        lines.append(f"void {func}_f_loop(long n, {params}, float *out)")
        lines.append(f"{{ long i; for (i = 0; i < n; ++i) {_store(r, func, args, True)} }}")
    tail = ["}"] if lang == "metal" else []
    return "\n".join(lines + _material_loops(program, by_value=True, scalars=(("float", "", "_f"),)) + tail) + "\n"


#: a folder of compiled libraries keyed by content hash (:func:`_compile`); unset: every build compiles
NATIVE_CACHE_ENV = "FITLAB_NATIVE_CACHE"


def _cache_key(workdir: Path, cmd: list[str]) -> str:
    """sha256 of the compiler command (the work folder's path written as ``@``) and of the name and bytes of
    every file in the work folder: what the library is compiled from (sources and the headers they include)."""
    h = hashlib.sha256()
    where = str(workdir)
    h.update("\0".join(a.replace(where, "@") for a in cmd).encode())
    for f in sorted(p for p in workdir.iterdir() if p.is_file() and p.suffix != ".so"):
        h.update(b"\0" + f.name.encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def _compile(workdir: Path, sources: list[Path], lib: Path, flags, cxx: bool = False) -> list[str]:
    """Compile ``sources`` into the shared library ``lib`` with the C compiler (C++ with ``cxx``).

    Where ``$FITLAB_NATIVE_CACHE`` names a folder (the test suite sets one per run), a library compiled before
    from the same command and the same work-folder files (:func:`_cache_key`) is copied from it instead;
    a new one is added (written under a temporary name, then renamed: concurrent processes never see half
    a file).  Failed compilations are never kept."""
    cc = cxx_compiler() if cxx else compiler()
    if cc is None:
        raise CompileError(
            "no C++ compiler found (c++, g++ or clang++)" if cxx else "no C compiler found (cc, gcc or clang)"
        )
    cmd = [cc, *flags, "-shared", "-fPIC", "-o", str(lib), *map(str, sources), "-lm"]
    folder = os.environ.get(NATIVE_CACHE_ENV)
    cached = Path(folder) / f"{_cache_key(Path(workdir), cmd)}.so" if folder else None
    if cached is not None and cached.is_file():
        shutil.copyfile(cached, lib)
        return cmd
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise CompileError(f"{' '.join(cmd)} failed:\n{res.stderr}")
    if cached is not None:
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            part = cached.with_name(f"{cached.name}.{os.getpid()}.part")
            shutil.copyfile(lib, part)
            os.replace(part, cached)
        except OSError:
            pass  # a cache that cannot be written only costs time
    return cmd


def _written(files: dict[str, str], workdir: Path, loops: dict[str, str]) -> Path:
    """``workdir`` (created) holding the generated ``files`` and the timing ``loops``."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for name, text in {**files, **loops}.items():
        (workdir / name).write_text(text)
    return workdir


def build_library(files: dict[str, str], workdir: Path, flags=STRICT_FLAGS) -> ctypes.CDLL:
    """C sources ({file name: text}, every ``.c`` compiled) as one shared library in ``workdir``, loaded (the
    same compiler, flags and cache as :func:`build`); a failed compilation raises :class:`CompileError`."""
    workdir = _written(files, workdir, {})
    lib = workdir / "libfitlab_native.so"
    _compile(workdir, [workdir / name for name in sorted(files) if name.endswith(".c")], lib, flags)
    return ctypes.CDLL(str(lib))


_C_FUNCTION_FOLDERS: list = []


@functools.cache
def c_function(source: str, name: str, argtypes: tuple):
    """The ``void`` C function ``name`` of ``source`` with ctypes ``argtypes``, compiled by :func:`build_library`
    once per process into a temporary folder that lives as long as the process."""
    folder = tempfile.TemporaryDirectory(prefix="fitlab-c-function-")
    _C_FUNCTION_FOLDERS.append(folder)
    f = getattr(build_library({f"{name}.c": source}, Path(folder.name)), name)
    f.restype, f.argtypes = None, list(argtypes)
    return f


def build(files: dict[str, str], program: Program, workdir: Path, flags=STRICT_FLAGS) -> NativeModel:
    """Write ``files`` (the generated C) to ``workdir``, compile with ``flags``
    (and -shared -fPIC) and load; the model's ``command`` is the compiler's command line."""
    workdir = _written(files, workdir, {"loops.c": _loop_source(program)})
    lib = workdir / f"lib{program.name}.so"
    cmd = _compile(workdir, [workdir / f"{program.name}.c", workdir / "loops.c"], lib, flags)
    return NativeModel(ctypes.CDLL(str(lib)), {r.name: r for r in program.routines}, program.prefix, cmd,
                       material=program.material)  # fmt: skip


#: flags the Metal-as-C++ shim is compiled with
METAL_FLAGS = ("-std=c++17", "-O2", "-Wall", "-Werror", "-Wno-unused-function")


def cxx_compiler() -> str | None:
    """A C++ compiler on PATH (c++, g++ or clang++), or None."""
    for name in ("c++", "g++", "clang++"):
        path = shutil.which(name)
        if path:
            return path
    return None


def build_glsl(files: dict[str, str], program: Program, workdir: Path, flags=None, lang: str = "glsl") -> NativeModel:
    """Write ``files`` (the generated GLSL, HLSL or Metal: ``lang``) to ``workdir``, compile them against a shim
    of the language's built-ins (GLSL and HLSL as C: :data:`GLSL_SHIM`, :data:`HLSL_SHIM`; Metal as C++:
    :data:`METAL_STDLIB`) and load: a model of the shader functions, callable in float only
    (``dtype=np.float32``)."""
    if lang not in ("glsl", "hlsl", "metal"):
        raise ValueError(f"no shim for {lang!r}")
    loops = f"{lang}_loops.{'cpp' if lang == 'metal' else 'c'}"
    extra = {"metal_stdlib": METAL_STDLIB} if lang == "metal" else {}
    workdir = _written(files, workdir, {loops: _glsl_loop_source(program, lang), **extra})
    lib = workdir / f"lib{program.name}_{lang}.so"
    if lang == "metal":  # <metal_stdlib> is the shim in the work folder
        cmd = _compile(workdir, [workdir / loops], lib, (*(flags or METAL_FLAGS), f"-I{workdir}"), cxx=True)
    else:
        cmd = _compile(workdir, [workdir / loops], lib, flags or GLSL_FLAGS)
    return NativeModel(ctypes.CDLL(str(lib)), {r.name: r for r in program.routines}, program.prefix, cmd,
                       dtypes=(np.float32,), material=program.material)  # fmt: skip


class NativeModel:
    """Call a compiled routine on arrays: ``m("brdf", mu_i, mu_o, cos_phi, c, dtype=np.float32)``.

    command: the compiler command line the library was built with (None when not built here).
    dtypes: the scalar types its loops exist in.
    material: the program's per-material set-up (:class:`fitlab.codegen.Material`), or None.
    Its routines are called the same way: ``m("prepare_c", c)`` gives materials, an array (n, fields);
    ``m("eval", materials, which, mu_i, mu_o, cos_phi)`` evaluates point i with materials[which[i]]
    (``which``: integers); ``m("eval_rgb", materials, which, ...)`` with materials[3 which[i] + k],
    k = 0, 1, 2, and an output with a last axis of 3.
    """

    def __init__(self, lib, routines, prefix: str, command=None, dtypes=(np.float64, np.float32), material=None):
        self.lib = lib
        self.routines = routines
        self.prefix = prefix
        self.command = None if command is None else tuple(command)
        self.dtypes = tuple(dtypes)
        self.material = material
        self._evaluators = {} if material is None else {r.name: r for r in material.evaluators}
        self._setups = (
            {}
            if material is None
            else {material.prepare_name: material.params, **{n: (a,) for n, a, _ in material.setups}}
        )

    def loop(self, func: str, dtype=np.float64):
        if np.dtype(dtype) not in [np.dtype(d) for d in self.dtypes]:
            raise TypeError(
                f"this model has no {np.dtype(dtype)} loops (it has {[np.dtype(d).name for d in self.dtypes]})"
            )
        f = getattr(self.lib, func + ("_f" if dtype == np.float32 else "") + "_loop")
        f.restype = None
        return f

    def __call__(self, name: str, *args, dtype=np.float64):
        if name in self._setups:
            return self._prepare(name, *args, dtype=dtype)
        base = name[:-4] if name.endswith("_rgb") else name
        if base in self._evaluators:
            return self._evaluate(name, self._evaluators[base], *args, dtype=dtype, rgb=base != name)
        r = self.routines[name]
        return self.call(self.prefix + name, r.signature(), r.vectors, *args, dtype=dtype, out=r.out)

    def _ptr(self, a, dtype):
        return a.ctypes.data_as(ctypes.POINTER(ctypes.c_float if dtype == np.float32 else ctypes.c_double))

    def _prepare(self, name, *args, dtype=np.float64):
        params = self._setups[name]
        if len(args) != len(params):
            raise TypeError(f"{self.prefix}{name} takes {params}")
        arrays = [np.asarray(a, dtype=dtype) for a in args]
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
        arrays = [np.ascontiguousarray(np.broadcast_to(a, shape)) for a in arrays]
        assert self.material is not None  # a set-up routine belongs to the material
        out = np.empty((*shape, len(self.material.fields)), dtype=dtype)
        self.loop(self.prefix + name, dtype)(ctypes.c_long(int(np.prod(shape))), *(self._ptr(a, dtype) for a in arrays),
                                             self._ptr(out, dtype))  # fmt: skip
        return out

    def _evaluate(self, name, r, materials, which, *args, dtype=np.float64, rgb=False):
        sig = r.signature()
        if len(args) != len(sig):
            raise TypeError(f"{self.prefix}{name} takes (materials, which, {', '.join(sig)})")
        materials = np.ascontiguousarray(materials, dtype=dtype)
        assert self.material is not None  # an evaluator belongs to the material
        if materials.ndim != 2 or materials.shape[1] != len(self.material.fields):
            raise ValueError(f"materials must be an array (n, {len(self.material.fields)}) (from a prepare routine)")
        which = np.asarray(which, dtype=np.int64)
        count = materials.shape[0] // 3 if rgb else materials.shape[0]
        if which.size and (which.min() < 0 or which.max() >= count):
            raise IndexError(f"which must index the {count} materials{' (triples)' if rgb else ''}")
        vecs = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n in r.vectors]
        scalars = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n not in r.vectors]
        shape = np.broadcast_shapes(which.shape, *(a.shape for a in scalars), *(v.shape[:-1] for v in vecs))
        arrays, si, vi = [], iter(scalars), iter(vecs)
        for n in sig:
            a = np.broadcast_to(next(vi), (*shape, 3)) if n in r.vectors else np.broadcast_to(next(si), shape)
            arrays.append(np.ascontiguousarray(a))
        which = np.ascontiguousarray(np.broadcast_to(which, shape))
        out = np.empty((*shape, 3) if rgb else (*shape, 4) if r.out else shape, dtype=dtype)
        self.loop(self.prefix + name, dtype)(
            ctypes.c_long(int(np.prod(shape))), self._ptr(materials, dtype),
            which.ctypes.data_as(ctypes.POINTER(ctypes.c_long)), *(self._ptr(a, dtype) for a in arrays),
            self._ptr(out, dtype))  # fmt: skip
        return _outputs(out, r.out)

    def call(self, func, sig, vectors, *args, dtype=np.float64, out=""):
        """``func``'s loop on arrays; a routine with an output vector (``out``) gives (vectors, values)."""
        if len(args) != len(sig):
            raise TypeError(f"{func} takes {sig}")
        scalars = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n not in vectors]
        vecs = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n in vectors]
        shape = np.broadcast_shapes(*(a.shape for a in scalars), *(v.shape[:-1] for v in vecs))
        arrays, si, vi = [], iter(scalars), iter(vecs)
        for n in sig:
            a = np.broadcast_to(next(vi), (*shape, 3)) if n in vectors else np.broadcast_to(next(si), shape)
            arrays.append(np.ascontiguousarray(a))
        result = np.empty((*shape, 4) if out else shape, dtype=dtype)
        ptr = ctypes.c_float if dtype == np.float32 else ctypes.c_double
        self.loop(func, dtype)(
            ctypes.c_long(int(np.prod(shape))), *(a.ctypes.data_as(ctypes.POINTER(ptr)) for a in arrays),
            result.ctypes.data_as(ctypes.POINTER(ptr)),
        )  # fmt: skip
        return _outputs(result, out)


def _outputs(result: np.ndarray, out: str):
    """A loop's results: the values, or for a routine with an output vector (vectors, values) from the
    (value, x, y, z) rows the loops store (:func:`_store`)."""
    return (result[..., 1:], result[..., 0]) if out else result
