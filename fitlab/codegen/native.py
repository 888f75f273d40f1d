r"""Compile the generated C and call it from numpy (ctypes): for tests and benchmarks.

``build(files, workdir)`` compiles the generated source plus a loop wrapper
per routine, ``NAME_loop(n, in0, in1, ..., out)`` in double and
``NAME_f_loop`` in float, into a shared library; :class:`NativeModel` calls
those loops on numpy arrays.  The wrapper only loops: the per-element work
is the generated function, so timings of a loop are timings of the function.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np

from fitlab.codegen.program import Program

__all__ = ["compiler", "STRICT_FLAGS", "build", "NativeModel", "CompileError"]

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


def _loop_source(program: Program) -> str:
    lines = [f'#include "{program.name}.h"', ""]
    for func, sig, vectors in ((program.prefix + r.name, r.signature(), r.vectors) for r in program.routines):
        for scalar, suffix in (("double", ""), ("float", "_f")):
            params = ", ".join(f"const {scalar} *{a}" for a in sig)
            args = ", ".join(f"{a} + 3 * i" if a in vectors else f"{a}[i]" for a in sig)
            lines.append(f"void {func}{suffix}_loop(long n, {params}, {scalar} *out)")
            lines.append(f"{{ long i; for (i = 0; i < n; ++i) out[i] = {func}{suffix}({args}); }}")
    return "\n".join(lines) + "\n"


def build(files: dict[str, str], program: Program, workdir: Path, flags=STRICT_FLAGS) -> "NativeModel":
    """Write ``files`` (the generated C) to ``workdir``, compile with ``flags``
    (and -shared -fPIC) and load."""
    cc = compiler()
    if cc is None:
        raise CompileError("no C compiler found (cc, gcc or clang)")
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (workdir / name).write_text(text)
    (workdir / "loops.c").write_text(_loop_source(program))
    sources = [workdir / f"{program.name}.c", workdir / "loops.c"]
    lib = workdir / f"lib{program.name}.so"
    cmd = [cc, *flags, "-shared", "-fPIC", "-o", str(lib), *map(str, sources), "-lm"]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        raise CompileError(f"{' '.join(cmd)} failed:\n{res.stderr}")
    return NativeModel(ctypes.CDLL(str(lib)), {r.name: r for r in program.routines}, program.prefix)


class NativeModel:
    """Call a compiled routine on arrays: ``m("brdf", mu_i, mu_o, cos_phi, c, dtype=np.float32)``."""

    def __init__(self, lib, routines, prefix: str):
        self.lib = lib
        self.routines = routines
        self.prefix = prefix

    def loop(self, func: str, dtype=np.float64):
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
