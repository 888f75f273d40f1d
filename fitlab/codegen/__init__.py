r"""Code generation: fit records in, C / Python / GLSL source out.

:func:`build_program` takes data (fit records by target) and returns a
:class:`Program`; :func:`emit` prints it in one language.  What a family prints
is its ``program()`` where it is a :class:`HasProgram` (a :class:`ProgramSpec`; the Lambert sphere's runtime
BRDF is :mod:`fitlab.families.lambert_sphere.program.spec`), or one routine per target
that names a ``routine`` when it has none.  :mod:`.printers` and :mod:`.languages`
only print.  The names below come from the modules of one job each: the program's data (``_model``:
:class:`Routine`, :class:`Program`, :class:`ProgramSpec`, ...), its building and the family capability
:class:`HasProgram` (:mod:`.program`), the cancellation-free rewrites (``_rewrites``), the NaN and domain policy
(``_policy``) and the per-material set-up (``_material``).

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
    ),
    **dict.fromkeys(
        (
            "LANGUAGES",
            "emit",
        ),
        "fitlab.codegen.languages",
    ),
    **dict.fromkeys(
        (
            "build_program",
            "parse_terms",
            "program_spec",
            "default_program_family",
            "family_programs",
            "model_form",
            "part_routine",
            "call",
            "reproducible_sympy",
            "HasProgram",
        ),
        "fitlab.codegen.program",
    ),
    **dict.fromkeys(
        (
            "Program",
            "ProgramSpec",
            "Routine",
            "Model",
            "Claim",
            "MaterialSpec",
            "Material",
            "DEFAULT_FORMS",
            "outputs",
        ),
        "fitlab.codegen._model",
    ),
    **dict.fromkeys(
        (
            "stable",
            "STABLE",
            "ONE_MINUS_SQUARES",
            "ONE_MINUS_POW",
            "SumSubsOptim",
            "rebuilt",
        ),
        "fitlab.codegen._rewrites",
    ),
    **dict.fromkeys(
        (
            "clamp",
            "clamped",
            "minmax_piecewise",
            "with_domain",
            "SAFE_POW",
            "unused_inputs",
        ),
        "fitlab.codegen._policy",
    ),
    **dict.fromkeys(
        (
            "material_of",
            "inline_calls",
            "hoist_params",
            "merge_exp_products",
            "field_symbol",
        ),
        "fitlab.codegen._material",
    ),
}

__all__ = [
    "LANGUAGE_NAMES",
    "LOOKUPS",
    "generate",
    "codegen_command",
    "load_program",
    "load_steps",
    "unused_fits",
    "parse_forms",
    "write_generated",
    "check_physics",
    "LANGUAGES",
    "emit",
    "build_program",
    "parse_terms",
    "program_spec",
    "default_program_family",
    "family_programs",
    "model_form",
    "part_routine",
    "call",
    "reproducible_sympy",
    "HasProgram",
    "Program",
    "ProgramSpec",
    "Routine",
    "Model",
    "Claim",
    "MaterialSpec",
    "Material",
    "DEFAULT_FORMS",
    "outputs",
    "stable",
    "STABLE",
    "ONE_MINUS_SQUARES",
    "ONE_MINUS_POW",
    "SumSubsOptim",
    "rebuilt",
    "clamp",
    "clamped",
    "minmax_piecewise",
    "with_domain",
    "SAFE_POW",
    "unused_inputs",
    "material_of",
    "inline_calls",
    "hoist_params",
    "merge_exp_products",
    "field_symbol",
]

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
    from fitlab.codegen._material import (
        field_symbol,
        hoist_params,
        inline_calls,
        material_of,
        merge_exp_products,
    )
    from fitlab.codegen._model import (
        DEFAULT_FORMS,
        Claim,
        Material,
        MaterialSpec,
        Model,
        Program,
        ProgramSpec,
        Routine,
        outputs,
    )
    from fitlab.codegen._policy import (
        SAFE_POW,
        clamp,
        clamped,
        minmax_piecewise,
        unused_inputs,
        with_domain,
    )
    from fitlab.codegen._rewrites import (
        ONE_MINUS_POW,
        ONE_MINUS_SQUARES,
        STABLE,
        SumSubsOptim,
        rebuilt,
        stable,
    )
    from fitlab.codegen.languages import (
        LANGUAGES,
        emit,
    )
    from fitlab.codegen.program import (
        HasProgram,
        build_program,
        call,
        default_program_family,
        family_programs,
        model_form,
        parse_terms,
        part_routine,
        program_spec,
        reproducible_sympy,
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
