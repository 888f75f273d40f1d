"""``fitlab codegen``: generate C, Python or GLSL source of the runtime BRDF from the fits.

What a run prints is kept in fitlab's cache (:func:`fitlab.cache.cached_files`), keyed by the options, the bytes of
the ``--fits`` folder's fit files and of fitlab itself, and by the families there are: a second run of unchanged
inputs reads it back without re-measuring or printing anything.  The key imports the families' classes (which of
them have a program), none of their targets, fits or tables.
"""

from __future__ import annotations

import os
import stat
import sys
from pathlib import Path

from fitlab.cli._common import (
    RunFailure,
    UsageError,
    add_data,
    add_fits,
    add_quiet,
    describe,
    family_with,
    fits_input,
    integer,
    one_line,
    output_folder,
    use_data,
    write_files,
)
from fitlab.codegen import LANGUAGE_NAMES, LOOKUPS

__all__ = ["add_arguments", "run"]


def add_arguments(p) -> None:
    describe(p, "Read the fits a runtime program needs (each from --fits when that folder has it, else the fit "
                "packaged with fitlab: `fitlab refit --target H1` then `fitlab codegen --fits fits` prints that "
                "refit), re-measure each on its target's validation set over the target's whole domain (a fit not "
                "finite there, or more than 10 %% worse than its file states, is refused), and write the "
                "program's source files in one language into --out, all as one unit (nothing is written on a "
                "failure). The banner lists every fit's file, sha256, origin and re-measured error.",
             "fitlab codegen --fits fits --lang c --out /tmp/generated (after fitlab refit --target H1)")  # fmt: skip
    p.add_argument(
        "--lang", required=True, choices=list(LANGUAGE_NAMES), help=f"target language: {', '.join(LANGUAGE_NAMES)}"
    )
    add_fits(
        p,
        "folder of fits JSON, read in place of the packaged fits of the same names (the packaged fits fill "
        "in the rest)",
    )
    p.add_argument(
        "--allow-partial-domain",
        action="store_true",
        help="print a fit made on part of its target's domain (refit --domain): it is measured on that "
        "part only, and its routine states that domain and clamps its inputs to it",
    )
    p.add_argument("--out", default="generated", help="output folder (default: generated)")
    p.add_argument("--terms", help="terms of brdf to keep, comma-separated subset of single,m0,m1,m2 (default: all)")
    p.add_argument(
        "--model",
        metavar="NAME",
        default=None,
        help="the fits to print: a model of the family's program (Lambert sphere: true, the default, "
        "every part fitted to the true BRDF; three-term, every part fitted to its own three-term "
        "target; microfacet_energy: blog_refit, the default; every program: default-forms, each "
        "target's default form); --form overrides a part",
    )
    p.add_argument(
        "--allow-mixed-physics",
        action="store_true",
        help="print a model whose parts were fitted to different physics (a --fits refit of a three-term "
        "target with the parts fitted to the true BRDF, say), which is refused otherwise",
    )
    p.add_argument(
        "--form",
        action="append",
        metavar="TARGET=FORM",
        help="use the fit TARGET.FORM.json of --fits for a part, e.g. H0=hapke_rational (repeatable)",
    )
    p.add_argument(
        "--single-header",
        action="store_true",
        help="C: one stb-style header (define PREFIX_IMPLEMENTATION in one file before including it)",
    )
    p.add_argument(
        "--fit",
        metavar="FILE.json",
        default=None,
        help="print one fit of a table of your own (`fitlab fit`) instead of a family's program: its "
        "function, clamped to its domain, with the held-out error measured again on its table",
    )
    p.add_argument(
        "--family",
        metavar="NAME",
        default=None,
        help="the family whose program to generate (default: the family of the --form targets, else the "
        "family that declares the default program, lambert_sphere; microfacet_energy prints the "
        "energy-compensation albedos and the multiple-scattering lobes)",
    )
    p.add_argument(
        "--tables",
        action="store_true",
        help="print the family's exact tables as engines ship them instead of its fits: one float32 texture "
        "(C arrays, a raw .f32 file) and the BRDF read from it (c, glsl or python; docs/codegen.md)",
    )
    p.add_argument(
        "--nodes",
        type=integer(2),
        default=None,
        metavar="N",
        help="--tables: nodes per axis of the texture (Lambert sphere: 5, 9, 17, 33 (default) or 65)",
    )
    p.add_argument(
        "--lookup",
        choices=list(LOOKUPS),
        default=None,
        help="--tables: how the texture is read, cubic (bicubic, the default) or linear (bilinear)",
    )
    add_data(p)
    add_quiet(p)


def _run_tables(args) -> int:
    """``--tables``: the family's table export (:class:`fitlab.core.HasTableExport`): its files, written as one
    unit."""
    given = [
        flag
        for flag, value in (
            ("--terms", args.terms),
            ("--model", args.model),
            ("--form", args.form),
            ("--single-header", args.single_header),
            ("--fits", args.fits),
        )
        if value
    ]
    if given:
        raise UsageError(f"{given[0]} is not a --tables option (the tables print no fits)")
    from fitlab.core import HasTableExport

    exporter = family_with(HasTableExport, args.family).table_export()
    if args.lang not in exporter.LANGUAGES:
        raise UsageError(f"--tables prints {', '.join(exporter.LANGUAGES)}, not {args.lang}")
    nodes = exporter.DEFAULT_NODES if args.nodes is None else args.nodes
    if nodes not in exporter.NODES:
        raise UsageError(
            f"--nodes {nodes}: one of {', '.join(map(str, exporter.NODES))} (every node a node of the exact tables)"
        )
    lookup = exporter.DEFAULT_LOOKUP if args.lookup is None else args.lookup
    use_data(args, required=True)
    out = output_folder(args.out, "--out")
    from fitlab.store import TableError

    try:
        exporter.check_tables(exporter.tables_dir())
    except TableError as exc:
        raise UsageError(one_line(exc)) from None
    from tqdm import tqdm

    with tqdm(total=exporter.GENERATE_STEPS, desc="tables", unit="step", disable=args.quiet) as bar:
        files = exporter.generate(args.lang, nodes, lookup, tick=lambda: bar.update(1))
    return _write(args, out, files)


def _run_fit(args) -> int:
    """``--fit FILE.json``: one fit of a user's table as a program of its own (:mod:`fitlab.codegen.single`)."""
    from fitlab.cli._common import input_file
    from fitlab.codegen.single import generate_fit_file
    from fitlab.store import FitFileError

    others = (("--fits", "fits"), ("--model", "model"), ("--form", "form"), ("--tables", "tables"),
              ("--family", "family"), ("--terms", "terms"), ("--nodes", "nodes"), ("--lookup", "lookup"),
              ("--data", "data"), ("--allow-partial-domain", "allow_partial_domain"))  # fmt: skip
    given = [flag for flag, name in others if getattr(args, name, None)]
    if given:
        raise UsageError(f"{given[0]} goes with a family's program, not with --fit (one fit of a table of your own)")
    if args.single_header and args.lang != "c":
        raise UsageError("--single-header is a C option (--lang c)")
    path = input_file(args.fit, "--fit")
    out = output_folder(args.out, "--out")
    try:
        files = generate_fit_file(path, args.lang, args.single_header)
    except (ValueError, KeyError, FitFileError) as exc:  # the fit or its table missing, damaged or disagreeing
        raise UsageError(one_line(exc)) from None
    except ArithmeticError as exc:
        raise RunFailure(f"code generation failed: {one_line(exc)}") from None
    return _write(args, out, {name: text.encode() for name, text in files.items()})


def run(args) -> int:
    if args.fit is not None:
        return _run_fit(args)
    if args.tables:
        return _run_tables(args)
    given = [f for f, value in (("--nodes", args.nodes), ("--lookup", args.lookup), ("--data", args.data)) if value]
    if given:
        raise UsageError(f"{given[0]} is a --tables option")
    if args.single_header and args.lang != "c":
        raise UsageError("--single-header is a C option (--lang c)")
    fits = fits_input(args, required=True)  # a folder that is not there is a typo, not "use the packaged fits"
    out = output_folder(args.out, "--out")
    sources = _fit_files(fits)
    if sources is None:  # a --fits folder the key cannot read safely: the run reads it as the store reads fits
        printed = _generate(args, fits)
    else:
        from fitlab.cache import cached_files, package_sources

        printed = cached_files("codegen", _key(args, fits), lambda: _generate(args, fits),
                               [*package_sources(), *sources])  # fmt: skip
    files = {name: data for name, data in printed.items() if name != _NOTES}
    notes = printed.get(_NOTES, b"").decode()
    if notes and not args.quiet:
        print(notes, end="", file=sys.stderr)
    return _write(args, out, files)


#: the name under which a run's lines on stderr are kept with its files (no file is named so)
_NOTES = ":stderr"
#: a --fits folder whose fit files are more or larger than this is not keyed (its run is not kept)
_KEYED_FILES, _KEYED_BYTES = 10_000, 64_000_000


def _fit_files(fits: Path | None) -> list[Path] | None:
    """The fit files (``*.json``) of the ``--fits`` folder, which the cache key reads: [] for the packaged fits,
    None where one is not a regular file or there are too many or too large to read (such a run is not kept)."""
    if fits is None:
        return []
    files, size = [], 0
    for path in sorted(Path(fits).glob("*.json")):
        try:
            info = os.stat(path)
        except OSError:
            return None
        size += info.st_size
        if not stat.S_ISREG(info.st_mode) or len(files) >= _KEYED_FILES or size > _KEYED_BYTES:
            return None
        files.append(path)
    return files


def _key(args, fits: Path | None) -> dict:
    """Every option that changes what a run prints (the fits' bytes and fitlab's own are the key's sources), the
    families there are (:func:`fitlab.cache.family_entry_points`) and which of them have a program and declare the
    default (:func:`fitlab.codegen.family_programs`: they choose the default and are named on stderr), read from
    the families' classes."""
    from importlib.metadata import version

    import numpy as np

    from fitlab.cache import family_entry_points
    from fitlab.codegen import family_programs

    return {"families": family_entry_points(), "programs": family_programs(), "lang": args.lang, "terms": args.terms,
            "model": args.model, "form": args.form, "family": args.family, "single_header": args.single_header,
            "allow_partial_domain": args.allow_partial_domain, "allow_mixed_physics": args.allow_mixed_physics,
            "fits": None if fits is None else str(fits.resolve()), "numpy": np.__version__,
            "sympy": version("sympy")}  # fmt: skip


def _generate(args, fits: Path | None) -> dict[str, bytes]:
    """The files of the run ({name: bytes}) and its lines on stderr (under :data:`_NOTES`): the inputs checked,
    the fits read, measured and printed, with a progress bar on stderr."""
    import fitlab.codegen as codegen
    from fitlab.codegen import parse_terms
    from fitlab.store import FitFileError, TableError

    try:
        parse_terms(args.terms, args.family)
        forms = codegen.parse_forms(args.form)
        if args.model is not None:
            codegen.program_spec(args.family, tuple(forms)).model(args.model)
    except (ValueError, KeyError) as exc:
        raise UsageError(one_line(exc)) from None
    from tqdm import tqdm

    # a bar where stderr is a terminal (tqdm's disable=None), none with --quiet
    with tqdm(total=codegen.load_steps(args.family, forms) + 1, desc="codegen", unit="step", leave=False,
              disable=True if args.quiet else None) as bar:  # fmt: skip

        def tick(next_step: str) -> None:
            bar.set_postfix_str(next_step, refresh=False)
            bar.update(1)

        try:
            files = codegen.generate(args.lang, fits, args.terms, forms, args.family, args.single_header, args.model,
                                     allow_partial_domain=args.allow_partial_domain,
                                     allow_mixed_physics=args.allow_mixed_physics, tick=tick)  # fmt: skip
        except (ValueError, KeyError, FitFileError, TableError) as exc:  # a fit missing, damaged, not what it says
            raise UsageError(one_line(exc)) from None
        except ArithmeticError as exc:
            raise RunFailure(f"code generation failed: {one_line(exc)}") from None
    notes = [*_the_default(args, forms), *_the_unused(args, fits, forms)]
    return {**{name: text.encode() for name, text in files.items()}, _NOTES: "".join(n + "\n" for n in notes).encode()}


def _the_default(args, forms: dict) -> list[str]:
    """Without --family (nor --form), a line naming the family whose program is printed and the others that have
    one (the rule: fitlab.codegen.default_program_family)."""
    if args.family is not None or forms:
        return []
    from fitlab.codegen import HasProgram, default_program_family
    from fitlab.core import offering

    having = list(offering(HasProgram))
    if len(having) > 1:
        default = default_program_family()
        others = ", ".join(sorted(n for n in having if n != default))
        return [f"fitlab codegen: family {default} (also {others}: choose with --family)"]
    return []


def _the_unused(args, fits, forms: dict) -> list[str]:
    """A line naming the fits of --fits that the program's model leaves out (a refit of a part in another form than
    the model's), and how to print them."""
    if fits is None:
        return []
    from fitlab.codegen import unused_fits

    unused = unused_fits(fits, forms=forms, family=args.family, model=args.model)
    if not unused:
        return []
    names = ", ".join(p.name for p, _, _ in unused)
    picks = " ".join(f"--form {t}={f}" for _, t, f in unused)
    return [f"fitlab codegen: {names} in {fits} not printed: the model uses other forms of "
            f"{'that part' if len(unused) == 1 else 'those parts'} (to print {'it' if len(unused) == 1 else 'them'}: "
            f"{picks})"]  # fmt: skip


def _write(args, out, files: dict[str, bytes]) -> int:
    """Every file ({name: bytes}) into ``out`` as one unit: all new, or all as they were (no stray temporary)."""
    return write_files(args, out, files)
