r"""Code generation: coefficient JSON in, C / Python / GLSL source of the runtime BRDF out.

``generate("c", fits_dir="fits")`` returns {file name: text}; ``write_generated``
writes them atomically (all or nothing).  The maths comes from
:mod:`fitlab.forms` through :func:`~fitlab.codegen.program.build_program`;
:mod:`.printers` and :mod:`.emit` only print it.  The committed output of the
committed fits lives in fits/generated/ and a test regenerates it.
"""

from __future__ import annotations

from pathlib import Path

from fitlab._io import atomic_write_text
from fitlab.codegen.emit import BASENAME, LANGUAGES, PREFIX, emit
from fitlab.codegen.program import POLE_FLOOR, Program, Routine, build_program, parse_terms

__all__ = ["generate", "parse_forms", "write_generated", "LANGUAGES", "PREFIX", "BASENAME", "build_program", "parse_terms",
           "Program", "Routine", "POLE_FLOOR"]  # fmt: skip


def generate(lang: str, fits_dir: Path = Path("fits"), terms: str | tuple | None = None,
             forms: dict | None = None) -> dict[str, str]:
    """Source files of the runtime BRDF in ``lang`` from the fits in ``fits_dir``; ``forms`` picks a
    fit other than the default form per target ({"H0": "sr_7_6808f1"}: fits/H0.sr_7_6808f1.json)."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    term_tuple = parse_terms(terms) if terms is None or isinstance(terms, str) else parse_terms(",".join(terms))
    return emit(build_program(Path(fits_dir), term_tuple, forms), lang)


def parse_forms(items) -> dict[str, str]:
    """``["H0=sr_7_6808f1", ...]`` -> {"H0": "sr_7_6808f1"}; targets must be parts codegen uses."""
    from fitlab.codegen.program import PART_ROUTINES

    known = (*PART_ROUTINES, "fast_brdf")
    out = {}
    for item in items or ():
        target, sep, form = item.partition("=")
        if not sep or not form:
            raise ValueError(f"--form {item!r}: write TARGET=FORM, e.g. H0=hapke_rational")
        if target not in known:
            raise ValueError(f"--form {item!r}: TARGET is one of {', '.join(known)}")
        if target in out:
            raise ValueError(f"--form: {target} given twice")
        out[target] = form
    return out


def write_generated(files: dict[str, str], out: Path) -> list[Path]:
    """Write every file (each atomically) into ``out``; returns the paths."""
    out = Path(out)
    paths = []
    for name, text in files.items():
        atomic_write_text(out / name, text)
        paths.append(out / name)
    return paths
