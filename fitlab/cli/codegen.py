"""``fitlab codegen``: generate C, Python or GLSL source of the runtime BRDF from the fits."""

from __future__ import annotations

import sys
from pathlib import Path

from fitlab.codegen import generate, parse_forms, write_generated
from fitlab.store import FitFileError

__all__ = ["HELP", "add_arguments", "run"]

HELP = "generate C, Python or GLSL source of the runtime BRDF from the fits"


def add_arguments(p) -> None:
    p.add_argument("--lang", required=True, choices=["c", "python", "glsl"], help="target language")
    p.add_argument("--fits", default="fits", help="folder of the fits JSON (default: fits)")
    p.add_argument("--out", default="fits/generated", help="output folder (default: fits/generated)")
    p.add_argument("--terms", help="terms of brdf to keep, comma-separated subset of single,m0,m1 (default: all)")
    p.add_argument("--form", action="append", metavar="TARGET=FORM",
                   help="use fits/TARGET.FORM.json for a part, e.g. H0=hapke_rational (repeatable)")


def run(args) -> int:
    try:
        files = generate(args.lang, Path(args.fits), args.terms, parse_forms(args.form))
    except (ValueError, KeyError, FitFileError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
        print(f"fitlab codegen: error: {msg}", file=sys.stderr)
        return 2
    for path in write_generated(files, Path(args.out)):
        print(f"wrote {path}")
    return 0
