r"""The catalogue: every way fitlab can evaluate a family's BRDF and its parts.

The generic part lives here: the method records, the inventory of fit files,
and the loops over the registered families; each family that is a :class:`HasReport`
(for the Lambert sphere :mod:`fitlab.families.lambert_sphere.program.report.methods` is its :class:`Report`)
contributes what only it knows.

Details: docs/accuracy.md, section ``fitlab.report.methods``."""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import sympy as sp

from fitlab.core import Capability, families, get_target, offering, targets
from fitlab.store import FitFileError, load, read_fit

if TYPE_CHECKING:
    from fitlab.codegen.program import Program
    from fitlab.report.settings import Settings

__all__ = ["BrdfMethod", "PartMethod", "CSpec", "FitEntry", "ReportError", "fit_inventory", "brdf_methods",
           "part_methods", "GROUPS", "brdf_inputs", "preset_records", "origin_kind", "fit_group", "best_forms",
           "positional", "family_reports", "brdf_report", "required_fits", "report_parts", "preset_variants",
           "Report", "BrdfReport", "HasReport", "HasBrdfReport"]  # fmt: skip


def brdf_inputs() -> tuple[str, ...]:
    """The BRDF's signature: its inputs, in the order every BRDF method's ``evaluate`` takes them (the report
    report's ``BRDF_INPUTS``, of the family whose BRDF the report measures: :func:`brdf_report`)."""
    return tuple(brdf_report().BRDF_INPUTS)


#: groups in the order the report lists them
GROUPS = ("exact", "tables", "published", "refit", "refit, richer", "discovered", "fast", "baseline", "monte carlo")


class ReportError(Exception):
    """Bad input to the report (a missing or unreadable fits folder or fit file, an unwritable output)."""


@dataclass(frozen=True)
class CSpec:
    """Where a method's generated C comes from: a fits folder, the non-default forms, the routine.

    ``fits_dir`` None means the baselines' program (:meth:`BrdfReport.baseline_program`);
    ``preset`` names a published preset set written to a temporary fits folder (see
    :func:`preset_records`); ``build``, a program that is not made from fits (the exported tables):
    ``build() -> (Program, {C file name: text})``."""

    routine: str
    fits_dir: Path | None = None
    forms: tuple = ()
    preset: str | None = None
    build: Callable | None = None

    @property
    def program_key(self) -> tuple:
        return (None if self.fits_dir is None else str(self.fits_dir), self.forms, self.preset, self.build)


@dataclass(frozen=True, eq=False)
class BrdfMethod:
    name: str
    group: str
    source: str
    evaluate: Callable  # f(mu_i, mu_o, phi, c, kd) on numpy arrays
    expr: sp.Expr | None = None  # in brdf_inputs(), for the JAX path
    c: CSpec | None = None
    bytes: float = math.nan  # the data it reads besides its code: table values, spline or fitted coefficients
    timed: bool = True  # False: no numpy cost (an exact engine that solves per distinct c)


@dataclass(frozen=True, eq=False)
class PartMethod:
    target: str
    name: str
    group: str
    source: str
    evaluate: Callable  # f(**inputs) on numpy arrays (the target's inputs by name)
    domain: dict = field(default_factory=dict)  # inputs restricted to these ranges (a fit's domain)
    c_key: tuple | None = None  # (target, label) under which its C routine is timed
    preset: tuple | None = None  # (form, preset) of a published preset (measured by fitlab.fit.refit.preset_metrics)
    #: (inputs, expression with its numbers, domain) of a form with its parameters: what its generated routine prints,
    #: timed as a routine of its own (fitlab.report.programs.form_costs) where no program times it
    form_routine: tuple | None = None


@dataclass(frozen=True)
class FitEntry:
    path: Path
    target: str
    form: str
    kind: str  # "refit" or the origin's method ("discover", ...)
    default: bool
    max_rel: float
    record: dict = field(hash=False, compare=False)


# -- the families' report services ------------------------------------------------------------------------
class Report(Protocol):
    """A family's methods in the report's catalogue."""

    @property
    def REQUIRED_FITS(self) -> Sequence[str]:
        """The targets whose default fit the family's BRDF-level methods need."""
        ...

    @property
    def PARTS(self) -> Sequence[str]:
        """The targets measured at part level."""
        ...

    @property
    def PRESET_VARIANTS(self) -> Mapping[str, Any]:
        """Name -> the published runtime presets' parts."""
        ...

    def tables_dir(self, data_dir: Path | None = None, /) -> Path:
        """Where the family reads its tables (``data_dir`` itself when given)."""
        ...

    def brdf_methods(self, fits_dir: Path, entries: list[FitEntry], data_dir: Path, preset_c: tuple, discovered: bool,
                     /) -> list[BrdfMethod]:  # fmt: skip
        """The BRDF-level methods (:func:`brdf_methods`); ``preset_c`` the preset variants whose C is built,
        ``discovered=False`` leaves out the entries of discovered forms."""
        ...

    def part_extras(self, target: str, data_dir: Path, /) -> list[PartMethod]:
        """The part-level methods of ``target`` beyond its presets and fit files."""
        ...

    def preset_records(self, variant: str, /) -> dict:
        """The fit records of a published preset set (:data:`PRESET_VARIANTS`), by target."""
        ...

    def check_tables(self, folder: Path, /) -> None:
        """Refuse (:class:`fitlab.store.TableError`) tables the report cannot read."""
        ...


class BrdfReport(Report, Protocol):
    """The report of the family whose whole BRDF the report measures: the BRDF's signature and material, the
    report's family settings, the measurements of the family's own engines and report.md's words on them."""

    @property
    def BRDF_INPUTS(self) -> Sequence[str]:
        """The BRDF's inputs, in the order every method's ``evaluate`` takes them: the incident and outgoing
        cosines, the azimuth, the material, and the material's second parameter (0 where a method ignores it)."""
        ...

    @property
    def BRDF_POINT(self) -> Sequence[str]:
        """The inputs that name a point of the validation set (the second parameter follows from the material)."""
        ...

    @property
    def BRDF_MATERIAL(self) -> Sequence[str]:
        """The material's inputs: all 0 is the black material, whose BRDF is exactly 0."""
        ...

    @property
    def BRDF_TITLE(self) -> str:
        """The BRDF's name in report.md's title and the plot's."""
        ...

    @property
    def REPORT_TEXT(self) -> Mapping[str, str]:
        """report.md's sentences on the material ("material": how the second parameter is set; "black": what the
        black material's column measures) and on the parts ("parts": what they are measured on)."""
        ...

    @property
    def REPORT_SETTINGS(self) -> Mapping[str, Any]:
        """The family's settings of the report, by the generic settings' name ("full", "quick")."""
        ...

    @property
    def SOURCES(self) -> Mapping[str, str]:
        """What each engine measurement measured ("exact": the exact engine)."""
        ...

    @property
    def EXACT_SOURCES(self) -> Path:
        """The folder of the exact engine's sources (hashed into the validation set's cache key)."""
        ...

    def exact_brdf(self, mu_i: np.ndarray, mu_o: np.ndarray, phi: np.ndarray, material: float, /) -> np.ndarray:
        """The exact BRDF at points, at one material."""
        ...

    def exact_kd(self, material: np.ndarray, /) -> np.ndarray:
        """The material's second parameter (the Lambert sphere's kd) of each material."""
        ...

    def exact_albedo(self, mu: np.ndarray, material: float, /) -> np.ndarray:
        """The exact directional albedo at incident cosines ``mu``, one material."""
        ...

    def directional_albedo(self, f: Callable[..., np.ndarray], mu: np.ndarray, material: float, /) -> np.ndarray:
        """The directional albedo of a BRDF ``f`` (a method's evaluate) at incident cosines ``mu``."""
        ...

    def validation_materials(self, family_settings: Any, /) -> tuple[np.ndarray, str]:
        """(materials, what they are) of the validation and grazing sets."""
        ...

    def fresh_materials(self, rng: np.random.Generator, family_settings: Any, /) -> tuple[np.ndarray, str]:
        """(materials, what they are) of the independent set: the first draws of its generator ``rng``."""
        ...

    def energy_materials(self, family_settings: Any, /) -> tuple[np.ndarray, str]:
        """(materials, what they are) where the directional albedo is checked."""
        ...

    def measure_engines(self, settings: Settings, family_settings: Any, inputs: dict, progress: Any,
                        /) -> tuple[list[dict], dict]:  # fmt: skip
        """(rows, context) of the family's own engines (exact, Monte Carlo), as the report's rows and what its
        sections read; ``inputs`` the numpy timing inputs by name; ``progress.stage(name, steps)`` and
        ``progress.tick()`` show the stages."""
        ...

    def timing_inputs(self, n: int, data_dir: Path, /) -> dict:
        """Seeded random inputs by argument name: what the timings evaluate."""
        ...

    def baseline_program(self) -> Program:
        """The program of the baselines whose C the report times beside the family's."""
        ...

    def engine_sections(self, report: dict, /) -> list[str]:
        """report.md's sections on the family's own engines: markdown lines."""
        ...


class HasReport(Capability):
    """A family with methods in the report's catalogue."""

    noun = "report"

    @abc.abstractmethod
    def report(self) -> Report: ...


class HasBrdfReport(HasReport):
    """The family whose whole BRDF the report measures (``fitlab report`` needs exactly one)."""

    noun = "BRDF the report measures"

    @abc.abstractmethod
    def report(self) -> BrdfReport: ...


def family_reports() -> dict[str, Report]:
    """family name -> its :class:`Report`, of every family that is a :class:`HasReport`."""
    return {name: f.report() for name, f in offering(HasReport).items()}


def brdf_report() -> BrdfReport:
    """The :class:`BrdfReport` of the family whose whole BRDF the report measures (its exact engine, Monte Carlo
    and validation set): the one :class:`HasBrdfReport`."""
    having = offering(HasBrdfReport)
    if len(having) != 1:
        raise ReportError(f"the report measures one family's BRDF; {len(having)} families have an exact BRDF")
    return next(iter(having.values())).report()


def required_fits() -> list[str]:
    """The targets whose default fit the families' BRDF-level methods need, in the families' order."""
    return [t for hook in family_reports().values() for t in hook.REQUIRED_FITS]


def report_parts() -> tuple:
    """The targets measured at part level: a family's ``PARTS`` where its report names them, else
    every target of the family."""
    out = []
    for family in families().values():
        out += list(family.report().PARTS if isinstance(family, HasReport) else family.target_names)
    return tuple(out)


def preset_variants() -> tuple:
    """The published preset sets of every family's runtime model."""
    return tuple(v for hook in family_reports().values() for v in hook.PRESET_VARIANTS)


# -- fits ------------------------------------------------------------------------------------------
def origin_kind(record: dict) -> str:
    """How a fit was made: "refit" when its record has no ``origin``; "discover" when the origin (a dict's
    ``method``, or a string) names discover ("fitlab discover"); else that method as written."""
    origin = record.get("origin")
    method = str(origin.get("method", "other")) if isinstance(origin, dict) else (str(origin) if origin else "refit")
    return "discover" if "discover" in method else method


def fit_inventory(fits_dir: Path) -> list[FitEntry]:
    """Every fits_dir/*.json, read and checked, sorted by file name; a bad file is a ReportError; fits of a
    user's own table (``user_data``, ``fitlab fit``) are left out."""
    fits_dir = Path(fits_dir)
    if not fits_dir.is_dir():
        raise ReportError(f"{fits_dir}: no such fits folder; run `fitlab refit --all` or pass --fits")
    entries = []
    for path in sorted(fits_dir.glob("*.json")):
        try:
            rec = read_fit(path)
        except FitFileError as exc:
            raise ReportError(str(exc)) from None
        if "user_data" in rec:  # a fit of a user's own table (fitlab fit): no method of a family
            continue
        if rec["target"] not in targets():
            raise ReportError(f"{path}: unknown target {rec['target']!r}")
        val = rec.get("validation", {}).get("max_rel", math.inf)
        default = rec["form"] == get_target(rec["target"]).default_form
        entries.append(FitEntry(path, rec["target"], rec["form"], origin_kind(rec), default, float(val), rec))
    if not entries:
        raise ReportError(f"{fits_dir}: no fit files (*.json); run `fitlab refit --all`")
    # the families' BRDF-level methods (for the Lambert sphere the refitted runtime model, its generated
    # program, which carries both albedo maps, and the fast variant) need every default fit they name:
    # a gap must fail here, before the validation sets are computed
    have = {e.target for e in entries if e.default}
    missing = [t for t in required_fits() if t not in have]
    if missing:
        raise ReportError(f"{fits_dir}: no default fit of {', '.join(missing)}; run `fitlab refit --all` "
                          "or pass --fits")  # fmt: skip
    return entries


def fit_group(e: FitEntry) -> str:
    """The report group of a fit file: refit (default form), refit, richer, discovered, or its origin."""
    if e.kind == "refit":
        return "refit" if e.default else "refit, richer"
    return "discovered" if e.kind == "discover" else e.kind


def best_forms(entries, kinds, parts) -> dict:
    """Per part, the form with the lowest recorded validation max error among fits of ``kinds``
    (ties: the default form, then the name); only non-default choices are returned."""
    out = {}
    for part in parts:
        cands = [e for e in entries if e.target == part and e.kind in kinds]
        if not cands:
            continue
        best = min(cands, key=lambda e: (e.max_rel, not e.default, e.form))
        if not best.default:
            out[part] = best.form
    return out


# -- presets as fit records (for codegen) -------------------------------------------------------------
def preset_records(variant: str) -> dict:
    """{(target, form): fit record} of a published preset set of a family's runtime model (the family's
    ``preset_records``), so that codegen can print the published model like any fit."""
    for hook in family_reports().values():
        if variant in hook.PRESET_VARIANTS:
            return hook.preset_records(variant)
    raise KeyError(f"no family has a preset set {variant!r}; sets: {', '.join(preset_variants())}")


# -- BRDF level ------------------------------------------------------------------------------------
def brdf_methods(fits_dir: Path, entries: list[FitEntry], data_dir: Path | None = None, preset_c: tuple = (),
                 discovered: bool = True) -> list[BrdfMethod]:  # fmt: skip
    """The BRDF-level catalogue of every family (see docs/accuracy.md); ``data_dir``: the tables (None:
    each family's own); ``preset_c``: the preset variants whose C is built; ``discovered=False`` leaves out
    the entries of discovered forms."""
    out = []
    for hook in family_reports().values():
        out += hook.brdf_methods(Path(fits_dir), entries, hook.tables_dir(data_dir), preset_c, discovered)
    return out


# -- part level ----------------------------------------------------------------------------------------
def positional(f, inputs):
    """``f`` of positional inputs as a function of the same inputs by name."""
    return lambda **x: f(*(x[n] for n in inputs))


def part_methods(target_name: str, entries: list[FitEntry], data_dir: Path | None = None) -> list[PartMethod]:
    """The part-level catalogue of one target (see docs/accuracy.md)."""
    t = get_target(target_name)
    hook = family_reports().get(t.family)
    out = [] if hook is None else list(hook.part_extras(target_name, hook.tables_dir(data_dir)))
    for form_name, preset in t.published:
        form = t.forms[form_name]
        theta = form.vector(preset)
        out.append(PartMethod(target_name, f"{form_name} / {preset}", "published", "fitlab.forms preset",
                              positional(lambda *x, form=form, theta=theta: form.numpy_function(theta, *x),
                                         form.inputs),
                              c_key=(target_name, f"{form_name} / {preset}"), preset=(form_name, preset),
                              form_routine=(form.inputs, form.substituted(preset),
                                            {a: t.domain[a] for a in form.inputs})))  # fmt: skip
    for e in entries:
        if e.target == target_name:
            fit = load(e.path)
            out.append(PartMethod(target_name, e.form, fit_group(e), str(e.path),
                                  lambda fit=fit, **x: fit(**{k: x[k] for k in fit.inputs}), fit.domain,
                                  (target_name, e.form),
                                  form_routine=(fit.inputs, fit.expression, fit.domain)))  # fmt: skip
    return out
