r"""Code generation: coefficient JSON in, C / Python / GLSL source of the runtime BRDF out.

``generate("c", fits_dir="fits")`` returns {file name: text}; ``write_generated``
writes them atomically (all or nothing).  The maths comes from
:mod:`fitlab.forms` through :func:`~fitlab.codegen.program.build_program`;
:mod:`.printers` and :mod:`.emit` only print it.  The committed output of the
committed fits lives in fits/generated/ and a test regenerates it.
"""

from __future__ import annotations

from pathlib import Path

from .._io import atomic_write_text
from .emit import BASENAME, LANGUAGES, PREFIX, emit
from .program import POLE_FLOOR, Program, Routine, build_program, parse_terms

__all__ = ["generate", "write_generated", "LANGUAGES", "PREFIX", "BASENAME", "build_program", "parse_terms",
           "Program", "Routine", "POLE_FLOOR"]  # fmt: skip


def generate(lang: str, fits_dir: Path = Path("fits"), terms: str | tuple | None = None) -> dict[str, str]:
    """Source files of the runtime BRDF in ``lang`` from the fits in ``fits_dir``."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    term_tuple = parse_terms(terms) if terms is None or isinstance(terms, str) else parse_terms(",".join(terms))
    return emit(build_program(Path(fits_dir), term_tuple), lang)


def write_generated(files: dict[str, str], out: Path) -> list[Path]:
    """Write every file (each atomically) into ``out``; returns the paths."""
    out = Path(out)
    paths = []
    for name, text in files.items():
        atomic_write_text(out / name, text)
        paths.append(out / name)
    return paths
