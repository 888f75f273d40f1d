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
import shutil
import subprocess
from pathlib import Path

import numpy as np

from fitlab.codegen.program import Program

__all__ = ["compiler", "STRICT_FLAGS", "GLSL_FLAGS", "GLSL_SHIM", "build", "build_glsl", "NativeModel", "CompileError"]

#: the issue's standard: the generated C must compile clean under these
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
static vec3 glsl_vec3(const float *p) { vec3 v; v.x = p[0]; v.y = p[1]; v.z = p[2]; return v; }
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
"""


def _loop_source(program: Program) -> str:
    lines = [f'#include "{program.name}.h"', ""]
    for func, sig, vectors in ((program.prefix + r.name, r.signature(), r.vectors) for r in program.routines):
        for scalar, suffix in (("double", ""), ("float", "_f")):
            params = ", ".join(f"const {scalar} *{a}" for a in sig)
            args = ", ".join(f"{a} + 3 * i" if a in vectors else f"{a}[i]" for a in sig)
            lines.append(f"void {func}{suffix}_loop(long n, {params}, {scalar} *out)")
            lines.append(f"{{ long i; for (i = 0; i < n; ++i) out[i] = {func}{suffix}({args}); }}")
    return "\n".join(lines) + "\n"


def _glsl_loop_source(program: Program) -> str:
    lines = [GLSL_SHIM, f'#include "{program.name}.glsl"', ""]
    for func, sig, vectors in ((program.prefix + r.name, r.signature(), r.vectors) for r in program.routines):
        params = ", ".join(f"const float *{a}" for a in sig)
        args = ", ".join(f"glsl_vec3({a} + 3 * i)" if a in vectors else f"{a}[i]" for a in sig)
        lines.append(f"void {func}_f_loop(long n, {params}, float *out)")
        lines.append(f"{{ long i; for (i = 0; i < n; ++i) out[i] = {func}({args}); }}")
    return "\n".join(lines) + "\n"


def _compile(workdir: Path, sources: list[Path], lib: Path, flags) -> list[str]:
    cc = compiler()
    if cc is None:
        raise CompileError("no C compiler found (cc, gcc or clang)")
    cmd = [cc, *flags, "-shared", "-fPIC", "-o", str(lib), *map(str, sources), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise CompileError(f"{' '.join(cmd)} failed:\n{res.stderr}")
    return cmd


def _written(files: dict[str, str], workdir: Path, loops: dict[str, str]) -> Path:
    """``workdir`` (created) holding the generated ``files`` and the timing ``loops``."""
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for name, text in {**files, **loops}.items():
        (workdir / name).write_text(text)
    return workdir


def build(files: dict[str, str], program: Program, workdir: Path, flags=STRICT_FLAGS) -> "NativeModel":
    """Write ``files`` (the generated C) to ``workdir``, compile with ``flags``
    (and -shared -fPIC) and load; the model's ``command`` is the compiler's command line."""
    workdir = _written(files, workdir, {"loops.c": _loop_source(program)})
    lib = workdir / f"lib{program.name}.so"
    cmd = _compile(workdir, [workdir / f"{program.name}.c", workdir / "loops.c"], lib, flags)
    return NativeModel(ctypes.CDLL(str(lib)), {r.name: r for r in program.routines}, program.prefix, cmd)


def build_glsl(files: dict[str, str], program: Program, workdir: Path, flags=GLSL_FLAGS) -> "NativeModel":
    """Write ``files`` (the generated GLSL) to ``workdir``, compile it as C against :data:`GLSL_SHIM` and load:
    a model of the shader functions, callable in float only (``dtype=np.float32``)."""
    workdir = _written(files, workdir, {"glsl_loops.c": _glsl_loop_source(program)})
    lib = workdir / f"lib{program.name}_glsl.so"
    cmd = _compile(workdir, [workdir / "glsl_loops.c"], lib, flags)
    return NativeModel(ctypes.CDLL(str(lib)), {r.name: r for r in program.routines}, program.prefix, cmd,
                       dtypes=(np.float32,))  # fmt: skip


class NativeModel:
    """Call a compiled routine on arrays: ``m("brdf", mu_i, mu_o, cos_phi, c, dtype=np.float32)``.

    command: the compiler command line the library was built with (None when not built here).
    dtypes: the scalar types its loops exist in.
    """

    def __init__(self, lib, routines, prefix: str, command=None, dtypes=(np.float64, np.float32)):
        self.lib = lib
        self.routines = routines
        self.prefix = prefix
        self.command = None if command is None else tuple(command)
        self.dtypes = tuple(dtypes)

    def loop(self, func: str, dtype=np.float64):
        if np.dtype(dtype) not in [np.dtype(d) for d in self.dtypes]:
            raise TypeError(f"this model has no {np.dtype(dtype)} loops (it has {[np.dtype(d).name for d in self.dtypes]})")
        f = getattr(self.lib, func + ("_f" if dtype == np.float32 else "") + "_loop")
        f.restype = None
        return f

    def __call__(self, name: str, *args, dtype=np.float64):
        r = self.routines[name]
        return self.call(self.prefix + name, r.signature(), r.vectors, *args, dtype=dtype)

    def call(self, func, sig, vectors, *args, dtype=np.float64):
        if len(args) != len(sig):
            raise TypeError(f"{func} takes {sig}")
        scalars = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n not in vectors]
        vecs = [np.asarray(a, dtype=dtype) for a, n in zip(args, sig) if n in vectors]
        shape = np.broadcast_shapes(*(a.shape for a in scalars), *(v.shape[:-1] for v in vecs))
        arrays, si, vi = [], iter(scalars), iter(vecs)
        for n in sig:
            a = np.broadcast_to(next(vi), (*shape, 3)) if n in vectors else np.broadcast_to(next(si), shape)
            arrays.append(np.ascontiguousarray(a))
        out = np.empty(shape, dtype=dtype)
        ptr = ctypes.c_float if dtype == np.float32 else ctypes.c_double
        self.loop(func, dtype)(
            ctypes.c_long(out.size), *(a.ctypes.data_as(ctypes.POINTER(ptr)) for a in arrays),
            out.ctypes.data_as(ctypes.POINTER(ptr)),
        )  # fmt: skip
        return out
