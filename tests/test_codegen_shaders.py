"""Shading-language drop-ins: GLSL (desktop and ES), HLSL and Metal, printed from the one program.

Each is checked by a real validator where one is installed (Debian: glslang-tools, spirv-cross; see
docs/codegen.md): glslangValidator compiles the GLSL (3.30 and ES 3.00, the file's own precision line
serving ES) and the HLSL (to SPIR-V), spirv-cross turns that SPIR-V into Metal Shading Language.  Without a
GPU, the values are checked through shims: GLSL and HLSL compiled as C, Metal as C++
(:func:`fitlab.codegen.native.build_glsl`), against the generated C in float on shared inputs.
"""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest

from fitlab.codegen import emit, load_program
from fitlab.codegen.native import build, build_glsl, compiler, cxx_compiler

SHADERS = ("glsl", "hlsl", "metal")
needs_glslang = pytest.mark.skipif(
    shutil.which("glslangValidator") is None, reason="glslangValidator not installed (Debian: glslang-tools)"
)


@pytest.fixture(scope="module")
def program():
    return load_program()


@pytest.fixture(scope="module")
def sources(program):
    return {lang: emit(program, lang) for lang in SHADERS}


def _text(sources, lang):
    (text,) = sources[lang].values()
    return text


GLSL_MAIN = """
uniform vec3 wi; uniform vec3 wo; uniform float kd; out vec4 color;
void main() {
    lambert_sphere_material m = lambert_sphere_prepare(kd);
    vec3 rgb = lambert_sphere_eval_rgb(m, m, m, wi.z, wo.z, 0.5);
    color = vec4(rgb + lambert_sphere_eval_local(m, wi, wo) + lambert_sphere_brdf_local(wi, wo, kd), 1.0);
}
"""

HLSL_MAIN = """
cbuffer Inputs { float3 wi; float3 wo; float kd; };
float4 main(float4 position : SV_Position) : SV_Target {
    lambert_sphere_material m = lambert_sphere_prepare(kd);
    float3 rgb = lambert_sphere_eval_rgb(m, m, m, wi.z, wo.z, 0.5);
    return float4(rgb + lambert_sphere_eval_local(m, wi, wo) + lambert_sphere_brdf_local(wi, wo, kd), 1.0);
}
"""


@needs_glslang
@pytest.mark.parametrize("version", ["#version 330", "#version 300 es"])
def test_glsl_validates_desktop_and_es(sources, tmp_path, version):
    """ES 3.00 with no precision statement of the caller's: the file's own `precision highp float` serves."""
    shader = tmp_path / "test.frag"
    shader.write_text(version + "\n" + _text(sources, "glsl") + GLSL_MAIN)
    res = subprocess.run(["glslangValidator", str(shader)], capture_output=True, text=True)
    assert res.returncode == 0, res.stdout + res.stderr


@needs_glslang
def test_hlsl_compiles_to_spirv_and_spirv_cross_writes_metal(sources, tmp_path):
    shader = tmp_path / "test.hlsl"
    shader.write_text(_text(sources, "hlsl") + HLSL_MAIN)
    spv = tmp_path / "test.spv"
    res = subprocess.run(
        ["glslangValidator", "-D", "-V", "-S", "frag", "-e", "main", "-o", str(spv), str(shader)],
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stdout + res.stderr
    if shutil.which("spirv-cross") is None:
        pytest.skip("spirv-cross not installed (Debian: spirv-cross)")
    res = subprocess.run(["spirv-cross", "--msl", str(spv)], capture_output=True, text=True)
    assert res.returncode == 0 and "metal_stdlib" in res.stdout, res.stderr


def test_every_shader_has_the_same_routines(sources, program):
    names = [r.name for r in program.routines] + [r.name for r in program.material.evaluators]
    for lang in SHADERS:
        text = _text(sources, lang)
        for name in (*names, "prepare_c", "prepare", "eval_rgb"):
            assert f" lambert_sphere_{name}(" in text, (lang, name)
    assert "precision highp float;" in _text(sources, "glsl")
    assert "#include <metal_stdlib>" in _text(sources, "metal")
    assert "vec3" not in _text(sources, "hlsl") and "vec3" not in _text(sources, "metal")


@pytest.mark.skipif(compiler() is None or cxx_compiler() is None, reason="no C or C++ compiler on PATH")
@pytest.mark.parametrize("lang", SHADERS)
def test_shader_values_agree_with_c_float(program, sources, tmp_path, lang):
    ref = build(emit(program, "c"), program, tmp_path / "c")
    shader = build_glsl(sources[lang], program, tmp_path / lang, lang=lang)
    rng = np.random.default_rng(11)
    n = 4000
    c = np.concatenate(([0.0, 1e-6, 1.0], rng.random(17))).astype(np.float32)
    which = rng.integers(0, c.size, n)
    mu_i, mu_o = rng.uniform(0.01, 1, (2, n)).astype(np.float32)
    cos_phi = rng.uniform(-1, 1, n).astype(np.float32)
    want = ref("eval", ref("prepare_c", c, dtype=np.float32), which, mu_i, mu_o, cos_phi, dtype=np.float32)
    got = shader("eval", shader("prepare_c", c, dtype=np.float32), which, mu_i, mu_o, cos_phi, dtype=np.float32)
    assert np.all(np.abs(got - want) <= 1e-4 * np.abs(want) + 1e-7)
    per_call = shader("brdf", mu_i, mu_o, cos_phi, c[which], dtype=np.float32)
    assert np.all(np.abs(per_call - want) <= 1e-4 * np.abs(want) + 1e-7)
    assert np.all(got[c[which] == 0] == 0)
