"""The generated C as C++ and CUDA take it in: a C++17 program links the gcc-built object (extern "C"), the
qualifier macro becomes __host__ __device__ under nvcc, and the stb-style single header compiles and agrees
with the two-file C.  The files are the committed ones (fitlab/fits/generated), or generated here."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from fitlab.codegen import generate

ROOT = Path(__file__).resolve().parents[1]
GENERATED = ROOT / "fitlab" / "fits" / "generated"
CC, CXX, NVCC = shutil.which("gcc") or shutil.which("cc"), shutil.which("g++"), shutil.which("nvcc")
needs_cxx = pytest.mark.skipif(CC is None or CXX is None, reason="needs gcc and g++")

CALLER = r"""
#include <cstdio>
#include "lambert_sphere.h"
int main() {
    const double wi[3] = {0.3, 0.0, 0.8}, wo[3] = {-0.2, 0.4, 0.7};
    std::printf("%.17g %.9g %.17g\n", lambert_sphere_brdf(0.3, 0.6, 0.25, 0.9), (double)lambert_sphere_brdf_f(0.3f, 0.6f, 0.25f, 0.9f),
                lambert_sphere_brdf_local(wi, wo, 0.7));
    return 0;
}
"""


def _run(args, cwd):
    done = subprocess.run(args, cwd=cwd, capture_output=True, text=True)
    assert done.returncode == 0, (args, done.stderr[-3000:])
    return done.stdout


@needs_cxx
def test_a_cxx17_program_links_the_c_object(tmp_path):
    for name in ("lambert_sphere.h", "lambert_sphere.c"):
        shutil.copy(GENERATED / name, tmp_path / name)
    (tmp_path / "main.cpp").write_text(CALLER)
    _run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-c", "lambert_sphere.c"], tmp_path)
    _run([CXX, "-std=c++17", "-Wall", "-Wextra", "-Werror", "-c", "main.cpp"], tmp_path)
    _run([CXX, "main.o", "lambert_sphere.o", "-lm", "-o", "caller"], tmp_path)
    values = [float(x) for x in _run([str(tmp_path / "caller")], tmp_path).split()]
    assert all(v > 0.0 for v in values)


@needs_cxx
def test_the_c_compiles_as_cxx17(tmp_path):
    shutil.copy(GENERATED / "lambert_sphere.h", tmp_path)
    shutil.copy(GENERATED / "lambert_sphere.c", tmp_path / "lambert_sphere.cpp")
    _run([CXX, "-std=c++17", "-O2", "-Wall", "-Wextra", "-Werror", "-c", "lambert_sphere.cpp"], tmp_path)


@needs_cxx
def test_the_qualifier_macro_expands_to_host_device_under_nvcc(tmp_path):
    shutil.copy(GENERATED / "lambert_sphere.h", tmp_path)
    (tmp_path / "use.c").write_text('#include "lambert_sphere.h"\n')
    plain = _run([CC, "-E", "-P", "use.c"], tmp_path)
    cuda = _run([CC, "-E", "-P", "-D__CUDACC__", "use.c"], tmp_path)
    assert "__host__ __device__ double lambert_sphere_brdf(" in cuda
    assert "__host__" not in plain and "double lambert_sphere_brdf(" in plain
    own = _run([CC, "-E", "-P", "-DLAMBERT_SPHERE_FN=static inline", "use.c"], tmp_path)
    assert "static inline double lambert_sphere_brdf(" in own


@pytest.mark.skipif(NVCC is None, reason="no nvcc on PATH")
def test_nvcc_compiles_a_kernel_that_calls_the_float_brdf(tmp_path):
    """Device code compiles without a GPU (nvcc -c); running it needs one."""
    shutil.copy(GENERATED / "lambert_sphere.h", tmp_path)
    shutil.copy(GENERATED / "lambert_sphere.c", tmp_path / "lambert_sphere.cu")
    (tmp_path / "kernel.cu").write_text(
        '#include "lambert_sphere.h"\n'
        "__global__ void eval(const float *c, float *out) {\n"
        "    int i = threadIdx.x;\n"
        "    out[i] = lambert_sphere_brdf_f(0.3f, 0.6f, 0.25f, c[i]);\n"
        "}\n")  # fmt: skip
    done = subprocess.run([NVCC, "-rdc=true", "-c", "kernel.cu", "lambert_sphere.cu"], cwd=tmp_path,
                          capture_output=True, text=True)  # fmt: skip
    if done.returncode != 0 and "No such file" in done.stderr:
        pytest.skip(f"nvcc cannot run here: {done.stderr.strip()[:200]}")
    assert done.returncode == 0, done.stderr[-3000:]


@needs_cxx
def test_single_header_matches_the_two_files(tmp_path):
    (single,) = generate("c", single_header=True).values()
    assert "--single-header" in single.splitlines()[2]
    (tmp_path / "single").mkdir()
    (tmp_path / "single" / "lambert_sphere.h").write_text(single)
    (tmp_path / "single" / "main.cpp").write_text("#define LAMBERT_SPHERE_IMPLEMENTATION\n" + CALLER)
    # a second translation unit includes it without the implementation: no duplicate symbols
    (tmp_path / "single" / "other.cpp").write_text(
        '#include "lambert_sphere.h"\ndouble other(void) { return lambert_sphere_h0(0.5, 0.5); }\n'
    )
    _run([CXX, "-std=c++17", "-Wall", "-Werror", "main.cpp", "other.cpp", "-o", "caller"], tmp_path / "single")
    (tmp_path / "two").mkdir()
    for name in ("lambert_sphere.h", "lambert_sphere.c"):
        shutil.copy(GENERATED / name, tmp_path / "two" / name)
    (tmp_path / "two" / "main.cpp").write_text(CALLER)
    _run([CC, "-std=c99", "-O2", "-c", "lambert_sphere.c"], tmp_path / "two")
    _run([CXX, "-std=c++17", "-O2", "main.cpp", "lambert_sphere.o", "-lm", "-o", "caller"], tmp_path / "two")
    single_out = _run([str(tmp_path / "single" / "caller")], tmp_path)
    two_out = _run([str(tmp_path / "two" / "caller")], tmp_path)
    assert [float(x) for x in single_out.split()] == pytest.approx([float(x) for x in two_out.split()], rel=1e-15)


@pytest.mark.e2e
def test_banner_names_the_command_with_the_options_that_change_the_files():
    files = generate("c", forms={"H0": "hapke_rational"}, model="three-term")
    assert (
        "(fitlab codegen --lang c --model three-term --form H0=hapke_rational)"
        in files["lambert_sphere.h"].splitlines()[2]
    )
    assert "(fitlab codegen --lang python)" in generate("python")["lambert_sphere.py"].splitlines()[1]
