"""``fitlab codegen``: generate C, Python or GLSL source of the runtime BRDF from the fits."""

from __future__ import annotations


import fitlab.codegen as codegen
from fitlab._io import atomic_write_many
from fitlab.cli._common import (
    fits_input,
    add_fits,
    RunFailure,
    UsageError,
    add_quiet,
    describe,
    one_line,
    output_folder,
    say,
    write_failure,
)
from fitlab.codegen.emit import LANGUAGES
from fitlab.codegen.program import parse_terms
from fitlab.store import FitFileError

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Read the fits a runtime program needs from --fits, check them, and write the program's source "
                "files in one language into --out, all as one unit (nothing is written on a failure).",
             "fitlab codegen --lang c --out /tmp/generated")  # fmt: skip
    p.add_argument("--lang", required=True, choices=list(LANGUAGES), help=f"target language: {', '.join(LANGUAGES)}")
    add_fits(p)
    p.add_argument("--out", default="generated", help="output folder (default: generated)")
    p.add_argument("--terms", help="terms of brdf to keep, comma-separated subset of single,m0,m1,m2 (default: all)")
    p.add_argument("--model", metavar="NAME", default=None,
                   help="the forms to print: a model of the family's program (Lambert sphere: order2, the report's "
                        "real-time recommendation and the default; default-forms, each target's default form); "
                        "--form overrides a part")
    p.add_argument("--form", action="append", metavar="TARGET=FORM",
                   help="use the fit TARGET.FORM.json of --fits for a part, e.g. H0=hapke_rational (repeatable)")
    p.add_argument("--single-header", action="store_true",
                   help="C: one stb-style header (define PREFIX_IMPLEMENTATION in one file before including it)")
    p.add_argument("--family", metavar="NAME", default=None,
                   help="the family whose program to generate (default: the family of the --form targets, else the "
                        "one family with a program of its own)")
    add_quiet(p)


def run(args) -> int:

    if args.single_header and args.lang != "c":
        raise UsageError("--single-header is a C option (--lang c)")
    try:
        parse_terms(args.terms, args.family)
        forms = codegen.parse_forms(args.form)
        if args.model is not None:
            codegen.program_spec(args.family, tuple(forms)).model(args.model)
    except (ValueError, KeyError) as exc:
        raise UsageError(one_line(exc)) from None
    fits = fits_input(args, required=False)  # a missing one: "no such fit file" names the fit
    out = output_folder(args.out, "--out")
    try:
        files = codegen.generate(args.lang, fits, args.terms, forms, args.family, args.single_header, args.model)
    except (ValueError, KeyError, FitFileError) as exc:  # a fit that is missing, damaged or not what it should be
        raise UsageError(one_line(exc)) from None
    except ArithmeticError as exc:
        raise RunFailure(f"code generation failed: {one_line(exc)}") from None
    # every file of the program as one unit: all new, or all as they were (no stray temporary)
    paths = {out / name: text.encode() for name, text in files.items()}
    try:
        atomic_write_many(paths)
    except OSError as exc:
        raise write_failure(out, exc) from None
    for path in paths:
        say(args, f"wrote {path}")
    return 0
