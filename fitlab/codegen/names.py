"""The names the command line reads of code generation without importing it (no sympy): the languages and the
texture lookups."""

from __future__ import annotations

__all__ = ["LANGUAGE_NAMES", "LOOKUPS"]

#: the languages fitlab prints (``fitlab codegen --lang``); :data:`fitlab.codegen.languages.LANGUAGES` their printers
LANGUAGE_NAMES = ("c", "python", "glsl", "hlsl", "metal", "drjit")
#: how an exported table's texture is read (``fitlab codegen --tables --lookup``): the name and the taps per axis
LOOKUPS = {"linear": 2, "cubic": 4}
