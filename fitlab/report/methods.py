r"""The catalogue: every way fitlab can evaluate a family's BRDF and its parts.

The generic part lives here: the method records, the inventory of fit files,
and the loops over the registered families; each family's ``report`` hook
(for the Lambert sphere :mod:`fitlab.families.lambert_sphere.report.methods`)
contributes what only it knows.

BRDF level (:func:`brdf_methods`), each a numpy function of (mu_i, mu_o, phi, c, kd),
with, where it exists, the sympy expression (for the JAX path) and how to get
its generated C (:class:`CSpec`); for the Lambert sphere:

* ``tables``: the runtime model with H0, H1 and the constants interpolated from
  data/, and all three orders with H2 too;
* ``published``: the runtime model with the published coefficients
  (:data:`fitlab.families.lambert_sphere.program.runtime.PRESET_VARIANTS`);
* ``refit``: the runtime model from fits/ (default forms); ``refit, richer``:
  each part's most accurate refit form (lowest validation max error recorded
  in its fit file), when that differs from the default;
* ``discovered``: every fit whose record says ``origin: {"method": "discover"}``,
  each swapped into the default refit (or, for fast_brdf, on its own), plus
  the best fit of every part among all fits when any is discovered;
* ``fast``: the fast variant (eq. 41), its published preset and every other
  fits/fast_brdf*.json;
* ``baseline``: Lambert kd/pi and Oren-Nayar (sigma = 0.5) at kd = kd_true(c):
  not models of this material, the yardsticks of cost and of error.

The family's own engines (the exact engine, Monte Carlo) are measured apart, by the family
(:func:`brdf_hook`'s ``measure_engines``; for the Lambert sphere
:mod:`fitlab.families.lambert_sphere.report.engine_rows`).  Part level (:func:`part_methods`): the
family's own methods of a target (for the Lambert sphere the tables and, for
H0 and H1, the Fock method of the exact engine), then the target's published
presets and every fit file, all measured on the target's validation set.

Fit files are found by globbing fits/*.json, so new ones (refits of new forms,
discovered forms) join the report without any change here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import sympy as sp

from fitlab.core import families, get_target, resolve_hook, targets
from fitlab.store import FitFileError, load, read_fit

__all__ = ["BrdfMethod", "PartMethod", "CSpec", "FitEntry", "ReportError", "fit_inventory", "brdf_methods",
           "part_methods", "GROUPS", "brdf_inputs", "preset_records", "origin_kind", "fit_group", "best_forms",
           "positional", "report_hooks", "brdf_hook", "required_fits", "report_parts", "preset_variants"]  # fmt: skip


def brdf_inputs() -> tuple[str, ...]:
    """The BRDF's signature: its inputs, in the order every BRDF method's ``evaluate`` takes them (the report
    hook's ``BRDF_INPUTS``, of the family whose BRDF the report measures: :func:`brdf_hook`)."""
    return tuple(brdf_hook().BRDF_INPUTS)

#: groups in the order the report lists them
GROUPS = ("exact", "tables", "published", "refit", "refit, richer", "discovered", "fast", "baseline", "monte carlo")


class ReportError(Exception):
    """Bad input to the report (a missing or unreadable fits folder or fit file, an unwritable output)."""


@dataclass(frozen=True)
class CSpec:
    """Where a method's generated C comes from: a fits folder, the non-default forms, the routine.

    ``fits_dir`` None means the baselines' program (the family report hook's ``baseline_program``);
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


# -- the families' report hooks -------------------------------------------------------------------------
def report_hooks() -> dict:
    """family name -> what its ``report`` hook returns: an object (a module) with REQUIRED_FITS, PARTS,
    PRESET_VARIANTS, tables_dir, brdf_methods, part_extras, preset_records and check_tables, and, for the
    family whose BRDF the report measures, exact_brdf, exact_kd, EXACT_SOURCES, SOURCES and the exact engine's
    and Monte Carlo's measurements (:mod:`fitlab.families.lambert_sphere.report.methods` lists them)."""
    return {name: resolve_hook(name, "report") for name, f in families().items() if "report" in f.hooks}


def brdf_hook():
    """The report hook of the family whose whole BRDF the report measures (its exact engine, Monte Carlo
    and validation set): the one family whose hook has ``exact_brdf``."""
    hooks = [h for h in report_hooks().values() if hasattr(h, "exact_brdf")]
    if len(hooks) != 1:
        raise ReportError(f"the report measures one family's BRDF; {len(hooks)} families have an exact BRDF")
    return hooks[0]


def required_fits() -> list[str]:
    """The targets whose default fit the families' BRDF-level methods need, in the families' order."""
    return [t for hook in report_hooks().values() for t in hook.REQUIRED_FITS]


def report_parts() -> tuple:
    """The targets measured at part level: a family's ``PARTS`` where its report hook names them, else
    every target of the family."""
    hooks = report_hooks()
    out = []
    for name, family in families().items():
        parts = getattr(hooks.get(name), "PARTS", None)
        out += list(parts) if parts is not None else [t.name for t in family.targets]
    return tuple(out)


def preset_variants() -> tuple:
    """The published preset sets of every family's runtime model."""
    return tuple(v for hook in report_hooks().values() for v in hook.PRESET_VARIANTS)


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
    for hook in report_hooks().values():
        if variant in hook.PRESET_VARIANTS:
            return hook.preset_records(variant)
    raise KeyError(f"no family has a preset set {variant!r}; sets: {', '.join(preset_variants())}")


# -- BRDF level ------------------------------------------------------------------------------------
def brdf_methods(fits_dir: Path, entries: list[FitEntry], data_dir: Path | None = None, preset_c: tuple = (),
                 discovered: bool = True) -> list[BrdfMethod]:  # fmt: skip
    """The BRDF-level catalogue of every family (see the module docstring); ``data_dir``: the tables (None:
    each family's own); ``preset_c``: the preset variants whose C is built; ``discovered=False`` leaves out
    the entries of discovered forms."""
    out = []
    for hook in report_hooks().values():
        out += hook.brdf_methods(Path(fits_dir), entries, hook.tables_dir(data_dir), preset_c, discovered)
    return out


# -- part level ----------------------------------------------------------------------------------------
def positional(f, inputs):
    """``f`` of positional inputs as a function of the same inputs by name."""
    return lambda **x: f(*(x[n] for n in inputs))


def part_methods(target_name: str, entries: list[FitEntry], data_dir: Path | None = None) -> list[PartMethod]:
    """The part-level catalogue of one target (see the module docstring)."""
    t = get_target(target_name)
    hook = report_hooks().get(t.family)
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
