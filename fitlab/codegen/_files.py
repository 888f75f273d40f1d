"""The file edge of code generation: the fits a program needs read from folders (:func:`load_program`), measured,
built and printed (:func:`generate`), and the files written (:func:`write_generated`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path

from fitlab._io import atomic_write_text
from fitlab.codegen._model import Model, Program, ProgramSpec
from fitlab.codegen.languages import LANGUAGES, emit
from fitlab.codegen.program import build_program, parse_terms, program_spec
from fitlab.core import did_you_mean, targets
from fitlab.store import FitFileError, FitFunction, fit_files, fit_origin, fit_path, fit_sha256, fit_source, load

__all__ = [
    "generate",
    "codegen_command",
    "load_program",
    "load_steps",
    "unused_fits",
    "parse_forms",
    "write_generated",
    "check_physics",
]


def _terms(terms: str | tuple | None, family: str | None) -> tuple[str, ...]:
    if terms is None or isinstance(terms, str):
        return parse_terms(terms, family)
    return parse_terms(",".join(terms), family)


def load_program(fits_dir: Path | None = None, terms: str | tuple | None = None, forms: dict | None = None,
                 family: str | None = None, model: str | None = None, *,
                 allow_partial_domain: bool = False, allow_mixed_physics: bool = False,
                 tick: Callable[[str], None] | None = None) -> Program:  # fmt: skip
    """The program of the fits in ``fits_dir`` overlaid on the packaged fits (None: the packaged fits alone).

    Each target's form is the one ``forms`` picks ({"H0": "sr_7_6808f1"}: H0.sr_7_6808f1.json), else
    the one the ``model`` picks (:attr:`ProgramSpec.models`; None: the program's default model), else the
    target's default form.  Each fit is read from ``fits_dir`` when that folder has its file, else from the
    packaged fits (the model's subfolder of them, :attr:`Model.folder`; :func:`fitlab.store.fit_source`); each
    must exist (FitFileError otherwise), but those of the program's optional parts (:attr:`ProgramSpec.optional`).
    ``family``: whose program (default: the family of the targets in ``forms``, else
    :func:`default_program_family`).

    The parts that make the model (:attr:`ProgramSpec.physics_parts`) must have been fitted to the model's physics
    (:attr:`Model.physics`): one that was not is refused (FitFileError, one line naming it and the way out) unless
    ``allow_mixed_physics``.  Every fit is re-measured on its target's validation set over the target's whole
    domain (:func:`fitlab.fit.verify.verify_fit`, kept in fitlab's cache by the file's digest) and refused
    (FitFileError, one line naming the file) when it is not finite there or more than 10 % worse than its record
    states; ``allow_partial_domain`` measures a fit made on part of the domain over that part, and its routine
    clamps its inputs to it.  The model as a whole is measured by the family's :attr:`ProgramSpec.claim`.  The
    banner lists, fit by fit, the file, its sha256, where it was read, its physics and the figures measured here.
    ``tick(next stage)`` is called after each of the :func:`load_steps` steps (a progress bar's)."""
    from fitlab.fit.verify import describe_measured, verify_fit

    def step(done: str) -> None:
        if tick is not None:
            tick(done)

    forms = dict(forms or {})
    spec = program_spec(family, tuple(forms))
    family = family or next(t.family for t in targets().values() if t.name in spec.fits)
    term_tuple = _terms(terms, family)
    chosen_model = spec.model(model)
    chosen = {**chosen_model.forms, **forms}
    paths = {t: fit_source(fits_dir, t, chosen.get(t, targets()[t].default_form), chosen_model.folder)
             for t in spec.fits}  # fmt: skip
    # an optional part (ProgramSpec.optional) the folders lack leaves its routines out
    paths = {t: p for t, p in paths.items() if t not in spec.optional or t in chosen or p.is_file()}
    for p in paths.values():
        if not p.is_file():
            load(p)  # the store's own error for a missing fit ("no such fit file", naming it)
    # the file name and its digest name a fit wherever its folder is, so regenerated code is byte-identical
    sources = tuple((p.name, fit_sha256(p)) for p in paths.values())
    # the same files (by digest) make the same program: built once per process (inlining and hoisting the
    # model takes seconds; a Program is immutable).  Where each was read changes the banner's notes alone, so a
    # folder holding copies of the packaged fits reuses their program and re-measures only
    built_key = (sources, term_tuple, family, chosen_model.name, allow_partial_domain, allow_mixed_physics)
    key = (built_key, tuple(fit_origin(p) for p in paths.values()))
    if key not in _PROGRAMS:
        records = {t: load(p) for t, p in paths.items()}
        model_line = (chosen_model.name, chosen_model.description)
        try:
            check_physics(spec, chosen_model, records)
        except FitFileError:
            if not allow_mixed_physics:
                raise
            model_line = (f"{chosen_model.name}, parts of mixed physics (--allow-mixed-physics)", model_line[1])
        notes = []
        for t, fit in records.items():
            step(f"measuring {paths[t].name}")
            measured = verify_fit(fit, allow_partial_domain=allow_partial_domain)
            notes.append(f"{fit_origin(paths[t])}; physics {fit.physics}; against {t} "
                         f"({targets()[t].physics}): {describe_measured(measured)}")  # fmt: skip
        step("measuring the model")
        claim = spec.claim(records, term_tuple) if spec.claim is not None else None
        step("building the program")
        if built_key not in _BUILT:
            _BUILT[built_key] = build_program(records, term_tuple, sources, family, model_line, claim)
        for memo in (_PROGRAMS, _BUILT):
            while len(memo) > 16:
                memo.pop(next(iter(memo)))
        _PROGRAMS[key] = replace(_BUILT[built_key], source_notes=tuple(notes))
    return _PROGRAMS[key]


def load_steps(family: str | None = None, forms: dict | None = None) -> int:
    """How many times :func:`load_program` calls its ``tick``: one per fit, then the model's claim and the build."""
    return len(program_spec(family, tuple(forms or {})).fits) + 2


def check_physics(spec: ProgramSpec, model: Model, records: Mapping[str, FitFunction]) -> None:
    """Refuse (FitFileError, one line) a part of ``model`` (:attr:`ProgramSpec.physics_parts`) fitted to other physics
    than the model's (:attr:`Model.physics`), naming it and the ways out."""
    if model.physics is None:
        return
    for t in spec.physics_parts:
        fit = records.get(t)
        if fit is not None and fit.physics != model.physics:
            where = fit.path.name if fit.path is not None else f"{t}/{fit.form}"
            others = [m.name for m in spec.models if m.physics == fit.physics]
            hint = f"--model {others[0]} (every part fitted to {fit.physics})" if others else "another model"
            raise FitFileError(
                f"{where} was fitted to physics {fit.physics}, but model {model.name}'s parts are fitted to "
                f"{model.physics}: print it with {hint}, or mix them with --allow-mixed-physics"
            )


def unused_fits(
    fits_dir: Path,
    program: Program | None = None,
    forms: dict | None = None,
    family: str | None = None,
    model: str | None = None,
) -> list[tuple[Path, str, str]]:
    """The fits of ``fits_dir`` (a user's folder) of the targets a program prints that the program does not use,
    as (path, target, form): each a fit of one of its targets in a form other than the one its model (or
    ``forms``) picks.  What
    ``fitlab codegen --fits`` names in one line, so that a refit left out of the code is never a surprise."""
    forms = dict(forms or {})
    spec = program_spec(family, tuple(forms))
    chosen = {**spec.model(model).forms, **forms}
    folder = Path(fits_dir)
    unused = []
    for t in spec.fits:
        used = fit_path(folder, t, chosen.get(t, targets()[t].default_form))
        for p in fit_files(folder, t):
            if p.parent == folder and p != used:
                words = p.name.split(".")
                unused.append((p, t, words[1] if len(words) == 3 else targets()[t].default_form))
    return unused


#: load_program's programs by (the files' names and digests, terms, family, model, partial domain) and where each
#: file was read (:func:`fitlab.store.fit_origin`, which the banner's notes name)
_PROGRAMS: dict = {}
#: the programs as build_program returns them (no notes), by the first part of _PROGRAMS's key alone
_BUILT: dict = {}


def generate(lang: str, fits_dir: Path | None = None, terms: str | tuple | None = None,
             forms: dict | None = None, family: str | None = None, single_header: bool = False,
             model: str | None = None, *, allow_partial_domain: bool = False, allow_mixed_physics: bool = False,
             tick: Callable[[str], None] | None = None) -> dict[str, str]:  # fmt: skip
    """Source files ({name: text}) in ``lang`` of the program of the fits in ``fits_dir`` (:func:`load_program`);
    their banner names the command that makes them (:func:`codegen_command`).  ``tick``: as load_program's, and
    once more when the files are printed (:func:`load_steps` + 1 calls)."""
    if lang not in LANGUAGES:
        raise ValueError(f"unknown language {lang!r}; choose one of {', '.join(LANGUAGES)}")
    command = codegen_command(lang, terms, forms, family, single_header, model, allow_partial_domain,
                              allow_mixed_physics)  # fmt: skip
    program = load_program(fits_dir, terms, forms, family, model, allow_partial_domain=allow_partial_domain,
                           allow_mixed_physics=allow_mixed_physics, tick=tick)  # fmt: skip
    if tick is not None:
        tick(f"printing {lang}")
    return emit(program, lang, command, single_header)


def codegen_command(lang: str, terms=None, forms: dict | None = None, family: str | None = None,
                    single_header: bool = False, model: str | None = None,
                    allow_partial_domain: bool = False, allow_mixed_physics: bool = False) -> str:  # fmt: skip
    """The ``fitlab codegen`` command that makes these files, with every option that changes their content
    (not --fits or --out: the banner's digests name the fits, and the files are the same wherever written)."""
    words = ["fitlab codegen", f"--lang {lang}"]
    if family is not None:
        words.append(f"--family {family}")
    if model is not None:
        words.append(f"--model {model}")
    if terms is not None:
        words.append(f"--terms {terms if isinstance(terms, str) else ','.join(terms)}")
    words += [f"--form {t}={f}" for t, f in (forms or {}).items()]
    if single_header:
        words.append("--single-header")
    if allow_partial_domain:
        words.append("--allow-partial-domain")
    if allow_mixed_physics:
        words.append("--allow-mixed-physics")
    return " ".join(words)


def parse_forms(items) -> dict[str, str]:
    """``["H0=sr_7_6808f1", ...]`` -> {"H0": "sr_7_6808f1"}; each target must have a generated routine."""
    known = [t.name for t in targets().values() if t.routine is not None]
    out = {}
    for item in items or ():
        target, sep, form = item.partition("=")
        if not sep or not form:
            raise ValueError(f"--form {item!r}: write TARGET=FORM, e.g. H0=hapke_rational")
        if target not in known:
            raise ValueError(f"--form {item!r}: no target {target!r}{did_you_mean(target, known)}")
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
