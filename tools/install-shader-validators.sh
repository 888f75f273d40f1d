#!/bin/sh
# The shader validators the test suite uses (tests/test_codegen_shaders.py, tests/test_codegen.py):
# glslangValidator (Debian/Ubuntu package glslang-tools) compiles the generated GLSL and HLSL to SPIR-V, and
# spirv-cross (package spirv-cross) turns that SPIR-V into Metal Shading Language.  Installed with apt-get
# where apt-get and root are available; anywhere else this does nothing and the tests that need them skip.
# It never fails, so the README's test command goes on either way.
if command -v glslangValidator >/dev/null 2>&1 && command -v spirv-cross >/dev/null 2>&1; then
    exit 0
fi
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    packages="glslang-tools spirv-cross"
    timeout 180 apt-get install -y --no-install-recommends $packages >/dev/null 2>&1 || {
        timeout 180 apt-get update >/dev/null 2>&1 &&
            timeout 180 apt-get install -y --no-install-recommends $packages >/dev/null 2>&1
    } || echo "install-shader-validators: could not install $packages; the shader validation tests will skip" >&2
fi
exit 0
