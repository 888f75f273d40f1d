r"""Code generation: fit records in, C / Python / GLSL source out.

:func:`build_program` takes data (fit records by target) and returns a
:class:`Program`; :func:`emit` prints it in one language.  What a family prints
is its ``codegen`` (a :class:`ProgramSpec`; the Lambert sphere's runtime BRDF
is :mod:`fitlab.families.lambert_sphere.program.spec`), or one routine per target
that names a ``routine`` when it has none.  :mod:`.printers` and :mod:`.languages`
only print.

The file edge: ``generate("c", fits_dir="fits")`` reads the fits a program
needs through :mod:`fitlab.store` (:func:`load_program`) and returns
{file name: text}; ``write_generated`` writes them atomically.  The committed
output of the committed fits lives in fits/generated/ and a test regenerates it.

The names below are imported on first use (sympy and the families with them), so that the command line can
read :data:`LANGUAGE_NAMES` and :data:`LOOKUPS` without that cost.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from fitlab.codegen.names import LANGUAGE_NAMES, LOOKUPS

#: every other public name, by the module that defines it (imported on first use)
_LAZY = {
    **dict.fromkeys(
        (
            "generate",
            "codegen_command",
            "load_program",
            "load_steps",
            "unused_fits",
            "parse_forms",
            "write_generated",
            "check_physics",
        ),
        "fitlab.codegen._files",
    ),  # fmt: skip
    **dict.fromkeys(("LANGUAGES", "emit"), "fitlab.codegen.languages"),
    **dict.fromkeys(
        (
            "build_program",
            "parse_terms",
            "program_spec",
            "default_program_family",
            "model_form",
            "part_routine",
            "Program",
            "ProgramSpec",
            "HasProgram",
            "Routine",
            "Model",
            "Claim",
            "call",
            "stable",
            "STABLE",
            "clamp",
            "clamped",
            "minmax_piecewise",
            "with_domain",
            "SAFE_POW",
            "DEFAULT_FORMS",
        ),
        "fitlab.codegen.program",
    ),  # fmt: skip
}

__all__ = ["LANGUAGE_NAMES", "LOOKUPS", "generate", "codegen_command", "load_program", "load_steps", "unused_fits",
           "parse_forms", "write_generated", "check_physics", "LANGUAGES", "emit", "build_program", "parse_terms",
           "program_spec", "default_program_family", "model_form", "part_routine", "Program", "ProgramSpec",
           "HasProgram", "Routine", "Model", "Claim", "call", "stable", "STABLE", "clamp", "clamped",
           "minmax_piecewise", "with_domain", "SAFE_POW", "DEFAULT_FORMS"]  # fmt: skip

if TYPE_CHECKING:  # what type checkers see of the names imported on first use
    from fitlab.codegen._files import (
        check_physics,
        codegen_command,
        generate,
        load_program,
        load_steps,
        parse_forms,
        unused_fits,
        write_generated,
    )
    from fitlab.codegen.languages import LANGUAGES, emit
    from fitlab.codegen.program import (
        DEFAULT_FORMS,
        SAFE_POW,
        STABLE,
        Claim,
        HasProgram,
        Model,
        Program,
        ProgramSpec,
        Routine,
        build_program,
        call,
        clamp,
        clamped,
        default_program_family,
        minmax_piecewise,
        model_form,
        parse_terms,
        part_routine,
        program_spec,
        stable,
        with_domain,
    )


def __getattr__(name: str):
    """The public names of :data:`_LAZY`, imported on first use."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'fitlab.codegen' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted([*globals(), *_LAZY])
