#!/bin/sh
# The system packages the test suite uses, installed with apt-get where apt-get and root are available;
# anywhere else this does nothing and the tests that need them skip.  It never fails, so the README's
# test command goes on either way.
# * glslangValidator (Debian/Ubuntu package glslang-tools) compiles the generated GLSL and HLSL to SPIR-V,
#   and spirv-cross (package spirv-cross) turns that SPIR-V into Metal Shading Language
#   (tests/test_codegen_shaders.py, tests/test_codegen.py).
# * libLLVM 17 or later (package libllvm19, else libllvm18 or libllvm17) for Mitsuba's llvm variants
#   (tests/test_sampling.py, tests/test_codegen_drjit.py, tests/test_mitsuba_plugin.py, fitlab render and
#   fitlab bench render): Dr.Jit loads the system's libLLVM, and LLVM 15 (Debian 12's default)
#   aborts on the float maximum Dr.Jit emits.
# * Chromium (package chromium) for the documentation site's browser test (tests/test_site.py, driven by
#   playwright, which downloads no browser of its own).
# * ktx-parse (npm; the version pinned in tests/ktx2_reader/package-lock.json) reads back the KTX2 files of
#   fitlab export (tests/test_export.py), installed into tests/ktx2_reader/node_modules where npm is on the
#   PATH (Debian's package: npm), with npm ci: the locked version and its checksum, nothing else.
reader="$(dirname "$0")/../tests/ktx2_reader"
if [ ! -f "$reader/node_modules/ktx-parse/package.json" ]; then
    if command -v npm >/dev/null 2>&1; then
        (cd "$reader" && timeout 300 npm ci --no-audit --no-fund --ignore-scripts >/dev/null 2>&1) ||
            echo "install-system-packages: npm could not install ktx-parse; the KTX2 read-back tests will skip" >&2
    else
        echo "install-system-packages: no npm; the KTX2 read-back tests will skip" >&2
    fi
fi
have_llvm() {
    for v in 19 18 17; do
        for f in /usr/lib/*/libLLVM-$v.so* /usr/lib/libLLVM-$v.so*; do
            [ -e "$f" ] && return 0
        done
    done
    return 1
}
if command -v glslangValidator >/dev/null 2>&1 && command -v spirv-cross >/dev/null 2>&1 && have_llvm &&
    command -v chromium >/dev/null 2>&1; then
    exit 0
fi
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    install() {
        timeout 300 apt-get install -y --no-install-recommends "$@" >/dev/null 2>&1
    }
    updated=0
    for p in glslang-tools spirv-cross "libllvm19 libllvm18 libllvm17" chromium; do
        for candidate in $p; do  # the first of the alternatives that installs
            install $candidate && break
            if [ $updated = 0 ]; then
                timeout 180 apt-get update >/dev/null 2>&1
                updated=1
                install $candidate && break
            fi
        done || true
    done
    command -v glslangValidator >/dev/null 2>&1 && command -v spirv-cross >/dev/null 2>&1 ||
        echo "install-system-packages: no glslang-tools or spirv-cross; the shader validation tests will skip" >&2
    have_llvm || echo "install-system-packages: no libLLVM 17 or later; the Mitsuba llvm tests will skip" >&2
    command -v chromium >/dev/null 2>&1 || echo "install-system-packages: no chromium; the site's browser test will skip" >&2
fi
exit 0
