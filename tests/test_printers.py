"""The C printer against sympy on expressions whose shape once printed wrong: a small power in a
denominator (x**3/y**3 printed as x*x*x/y*y*y, which is x^3 y); powers up to 6 print as products (Schlick's
(1 - mu)^5, F82-tint's (1 - mu)^6), never as pow()."""

from __future__ import annotations

import ctypes
import shutil
import subprocess

import pytest
import sympy as sp

from fitlab.codegen.printers import CPrinter

x, y, z = sp.symbols("x y z")
CASES = [x**3 / y**3, x / (y**2 * z), x ** sp.Rational(3, 2) / y**4, (x + y) ** 2 / z**3, 1 / (y**2) - x / z**4,
         x * y**-3 * z**2, sp.sqrt(x) ** 5 / (y * z) ** 2, (1 - x) ** 5 / y**6, 2 - x**6 / (x + y) ** 5]  # fmt: skip
POINT = {x: 0.7, y: 1.9, z: 0.45}


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler")
def test_c_printer_agrees_with_sympy_on_powers_in_denominators(tmp_path):
    printer = CPrinter("double", str)
    body = "\n".join(
        f"double f{k}(double x, double y, double z) {{ return {printer.doprint(e)}; }}" for k, e in enumerate(CASES)
    )
    (tmp_path / "f.c").write_text("#include <math.h>\n" + body + "\n")
    subprocess.run(["cc", "-std=c99", "-O0", "-shared", "-fPIC", str(tmp_path / "f.c"), "-o", str(tmp_path / "f.so"), "-lm"],
                   check=True, capture_output=True)  # fmt: skip
    lib = ctypes.CDLL(str(tmp_path / "f.so"))
    for k, e in enumerate(CASES):
        f = getattr(lib, f"f{k}")
        f.restype, f.argtypes = ctypes.c_double, [ctypes.c_double] * 3
        assert f(POINT[x], POINT[y], POINT[z]) == pytest.approx(float(e.subs(POINT)), rel=1e-14), (
            e,
            printer.doprint(e),
        )
        if k >= len(CASES) - 2:  # the powers 5 and 6
            assert "pow(" not in printer.doprint(e), printer.doprint(e)
