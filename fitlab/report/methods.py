r"""The catalogue: every way fitlab can evaluate the Lambert-sphere BRDF and its parts.

BRDF level (:func:`brdf_methods`), each a numpy function of (mu_i, mu_o, phi, c, kd),
with, where it exists, the sympy expression (for the JAX path) and how to get
its generated C (:class:`CSpec`):

* ``tables``: the runtime model with H0, H1 and the constants interpolated from
  data/, and all three orders with H2 too (:mod:`fitlab.report.tables`);
* ``published``: the runtime model of SPEC 5 with the published coefficients
  (:data:`fitlab.families.lambert_sphere.runtime.PRESET_VARIANTS`);
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

The exact engine and Monte Carlo are measured apart (:mod:`fitlab.report.exact`,
:mod:`fitlab.report.montecarlo`).  Part level (:func:`part_methods`): each
target's published presets, every fit file, the tables and (H0, H1) the Fock
method of the exact engine, all measured on the target's validation set.

Fit files are found by globbing fits/*.json, so new ones (refits of new forms,
discovered forms) join the report without any change here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import sympy as sp

from fitlab.store import FitFileError, FitFunction, read_fit
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.report.tables import c_of_kd_interpolant, constant_interpolant, h_interpolant, kd_interpolant, table_brdf

__all__ = ["BrdfMethod", "PartMethod", "CSpec", "FitEntry", "ReportError", "fit_inventory", "brdf_methods",
           "part_methods", "GROUPS", "BRDF_INPUTS", "preset_records", "origin_kind"]  # fmt: skip

BRDF_INPUTS = ("mu_i", "mu_o", "phi", "c", "kd")
#: groups in the order the report lists them
GROUPS = ("exact", "tables", "published", "refit", "refit, richer", "discovered", "fast", "baseline", "monte carlo")


class ReportError(Exception):
    """Bad input to the report (a missing or unreadable fits folder or fit file, an unwritable output)."""


@dataclass(frozen=True)
class CSpec:
    """Where a method's generated C comes from: a fits folder, the non-default forms, the routine.

    ``fits_dir`` None means the baselines' program (:func:`fitlab.codegen.bench.baseline_program`);
    ``preset`` names a published preset set written to a temporary fits folder (see
    :func:`preset_records`)."""

    routine: str
    fits_dir: Path | None = None
    forms: tuple = ()
    preset: str | None = None

    @property
    def program_key(self) -> tuple:
        return (None if self.fits_dir is None else str(self.fits_dir), self.forms, self.preset)


@dataclass(frozen=True, eq=False)
class BrdfMethod:
    name: str
    group: str
    source: str
    evaluate: Callable  # f(mu_i, mu_o, phi, c, kd) on numpy arrays
    expr: sp.Expr | None = None  # in BRDF_INPUTS, for the JAX path
    c: CSpec | None = None


@dataclass(frozen=True, eq=False)
class PartMethod:
    target: str
    name: str
    group: str
    source: str
    evaluate: Callable  # f(**inputs) on numpy arrays (the target's inputs by name)
    domain: dict = field(default_factory=dict)  # inputs restricted to these ranges (a fit's domain)
    c_key: tuple | None = None  # (target, label) under which its C routine is timed


@dataclass(frozen=True)
class FitEntry:
    path: Path
    target: str
    form: str
    kind: str  # "refit" or the origin's method ("discover", ...)
    default: bool
    max_rel: float
    record: dict = field(hash=False, compare=False)


# -- fits ------------------------------------------------------------------------------------------
def origin_kind(record: dict) -> str:
    """How a fit was made: "refit" when its record has no ``origin``; "discover" when the origin (a dict's
    ``method``, or a string) names discover ("fitlab discover"); else that method as written."""
    origin = record.get("origin")
    method = str(origin.get("method", "other")) if isinstance(origin, dict) else (str(origin) if origin else "refit")
    return "discover" if "discover" in method else method


def fit_inventory(fits_dir: Path) -> list[FitEntry]:
    """Every fits_dir/*.json, read and checked, sorted by file name; a bad file is a ReportError."""
    from fitlab.core import targets

    fits_dir = Path(fits_dir)
    if not fits_dir.is_dir():
        raise ReportError(f"{fits_dir}: no such fits folder; run `fitlab refit --all` or pass --fits")
    entries = []
    for path in sorted(fits_dir.glob("*.json")):
        try:
            rec = read_fit(path)
        except FitFileError as exc:
            raise ReportError(str(exc)) from None
        if rec["target"] not in targets():
            raise ReportError(f"{path}: unknown target {rec['target']!r}")
        val = rec.get("validation", {}).get("max_rel", math.inf)
        default = rec["form"] == get_target(rec["target"]).default_form
        entries.append(FitEntry(path, rec["target"], rec["form"], origin_kind(rec), default, float(val), rec))
    if not entries:
        raise ReportError(f"{fits_dir}: no fit files (*.json); run `fitlab refit --all`")
    from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS

    # the refitted runtime model, its generated program (which carries both albedo maps) and the
    # fast variant need every default fit: a gap must fail here, before the validation sets are computed
    have = {e.target for e in entries if e.default}
    missing = [t for t in (*RUNTIME_PARTS, "kd_of_c", "c_of_kd", "fast_brdf") if t not in have]
    if missing:
        raise ReportError(f"{fits_dir}: no default fit of {', '.join(missing)}; run `fitlab refit --all` "
                          "or pass --fits")  # fmt: skip
    return entries


def _fit_group(e: FitEntry) -> str:
    """The report group of a fit file: refit (default form), refit, richer, discovered, or its origin."""
    if e.kind == "refit":
        return "refit" if e.default else "refit, richer"
    return "discovered" if e.kind == "discover" else e.kind


def _best_forms(entries, kinds, parts) -> dict:
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
    """{(target, form): fit record} of a published preset set: the runtime parts of
    :data:`fitlab.families.lambert_sphere.runtime.PRESET_VARIANTS` plus the published eq. 41 and albedo maps, so that
    :func:`fitlab.codegen.build_program` can print the published model like any fit.
    (codegen always uses the exact normalisations; ``paper_printed``'s C differs from its
    printed normalisation only in two constants, which cost nothing.)"""
    from fitlab.store import DEFAULT_DOMAINS, FORMAT
    from fitlab.core import get_target
    from fitlab.families.lambert_sphere.runtime import PRESET_VARIANTS

    choice = dict(PRESET_VARIANTS[variant][0])
    choice["fast_brdf"] = ("paper", "paper")
    choice["kd_of_c"] = ("printed", "paper")
    choice["c_of_kd"] = ("rational_power", "renderer" if variant == "renderer" else "paper")
    out = {}
    for target, (form_name, preset) in choice.items():
        form = get_target(target).forms[form_name]
        out[(target, form_name)] = {
            "format": FORMAT, "target": target, "form": form_name, "inputs": list(form.inputs),
            "expression": form.expression, "params": dict(zip(form.params, form.vector(preset).tolist())),
            "domain": {k: list(DEFAULT_DOMAINS[k]) for k in form.inputs},
            "form_description": f"{form.description} Published preset {preset!r}.",
            "validation": {"max_rel": math.nan, "rms_rel": math.nan}, "origin": {"method": "preset", "preset": preset},
        }  # fmt: skip
    return out


# -- BRDF level ------------------------------------------------------------------------------------
def _runtime(model, name, group, source, cspec) -> BrdfMethod:
    return BrdfMethod(name, group, source, lambda mi, mo, ph, c, kd: model(mi, mo, ph, c), model.expr, cspec)


def _fit_brdf(fit: FitFunction, name, group, cspec) -> BrdfMethod:
    """A whole-BRDF fit (fast_brdf): inputs by name; kd clipped to [0, 1] as the generated code does
    (kd_true(1) = 1 + 1.0e-5)."""

    def f(mi, mo, ph, c, kd):
        values = {"mu_i": mi, "mu_o": mo, "phi": ph, "c": c, "kd": np.minimum(kd, 1.0)}
        return fit(**{k: values[k] for k in fit.inputs})

    return BrdfMethod(name, group, str(fit.path), f, fit.expression, cspec)


def _baselines() -> list[BrdfMethod]:
    from fitlab.families.lambert_sphere.forms.baselines import BASELINE_INPUTS, LAMBERT, oren_nayar

    out = []
    for name, expr, routine in (("Lambert kd/pi", LAMBERT, "baseline_lambert"),
                                ("Oren-Nayar sigma 0.5", oren_nayar(), "baseline_oren_nayar")):  # fmt: skip
        raw = lambdify_numpy(symbols(BASELINE_INPUTS), expr)

        def f(mi, mo, ph, c, kd, raw=raw):
            return np.broadcast_to(np.asarray(raw(mi, mo, np.cos(ph), kd), dtype=float), np.shape(mi)).copy()

        (phi,) = symbols(("phi",))
        e = expr.subs(symbols(("cos_phi",))[0], sp.cos(phi))
        out.append(BrdfMethod(name, "baseline", "fitlab.families.lambert_sphere.forms.baselines, kd = kd_true(c)", f, e, CSpec(routine)))
    return out


def _label(forms: dict) -> str:
    return ", ".join(f"{k}: {v}" for k, v in forms.items())


def brdf_methods(fits_dir: Path, entries: list[FitEntry], data_dir: Path, preset_c: tuple = (),
                 discovered: bool = True) -> list[BrdfMethod]:  # fmt: skip
    """The BRDF-level catalogue (see the module docstring); ``preset_c``: the preset variants whose C
    is built (from temporary fits folders, see :func:`preset_records`); ``discovered=False`` leaves out
    the entries of discovered forms."""
    from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS
    from fitlab.store import load
    from fitlab.core import get_target
    from fitlab.families.lambert_sphere.runtime import PRESET_VARIANTS, runtime_model

    fits_dir = Path(fits_dir)
    out = []
    for order2, name in ((False, "tables, runtime model"), (True, "tables, three orders")):
        f = table_brdf(data_dir, order2=order2)
        out.append(BrdfMethod(name, "tables", "data/*.csv with splines (fitlab.report.tables)",
                              lambda mi, mo, ph, c, kd, f=f: f(mi, mo, ph, c)))  # fmt: skip
    for v in PRESET_VARIANTS:
        m = runtime_model(v)
        spec = CSpec("brdf", preset=v) if v in preset_c else None
        out.append(_runtime(m, f"published: {v}", "published", _label(m.sources), spec))
    out.append(_runtime(runtime_model(fits_dir=fits_dir), "refit", "refit", "default forms in " + str(fits_dir),
                        CSpec("brdf", fits_dir)))  # fmt: skip
    maps = ("kd_of_c", "c_of_kd")  # not in the BRDF, but in its program: their C is timed there
    richer = _best_forms(entries, {"refit"}, RUNTIME_PARTS)
    if richer:
        m = runtime_model(fits_dir=fits_dir, forms=richer)
        c_forms = {**richer, **_best_forms(entries, {"refit"}, maps)}
        out.append(_runtime(m, "refit, richer forms", "refit, richer", _label(richer),
                            CSpec("brdf", fits_dir, tuple(sorted(c_forms.items())))))  # fmt: skip
    found = [e for e in entries if e.kind == "discover"] if discovered else []
    for e in found:
        if e.target in RUNTIME_PARTS:
            forms = {e.target: e.form}
            m = runtime_model(fits_dir=fits_dir, forms=forms)
            out.append(_runtime(m, f"refit + {e.target} {e.form}", "discovered", str(e.path),
                                CSpec("brdf", fits_dir, tuple(forms.items()))))  # fmt: skip
    if any(e.target in RUNTIME_PARTS for e in found):
        kinds = {e.kind for e in entries}
        best = _best_forms(entries, kinds, RUNTIME_PARTS)
        if best and best != richer:
            m = runtime_model(fits_dir=fits_dir, forms=best)
            c_forms = {**best, **_best_forms(entries, kinds, maps)}
            out.append(_runtime(m, "best fits (discovered included)", "discovered", _label(best),
                                CSpec("brdf", fits_dir, tuple(sorted(c_forms.items())))))  # fmt: skip
    fast_form = get_target("fast_brdf").forms["paper"]
    fast_raw = fast_form.numpy_function
    theta = fast_form.vector("paper")
    out.append(BrdfMethod(
        "fast eq. 41: paper", "fast", "fast_brdf/paper preset (eq. 41 as printed)",
        lambda mi, mo, ph, c, kd: np.asarray(fast_raw(theta, mi, mo, ph, c, np.minimum(kd, 1.0)), dtype=float),
        fast_form.substituted("paper"), CSpec("brdf_fast", preset="paper") if "paper" in preset_c else None,
    ))  # fmt: skip
    for e in entries:
        if e.target == "fast_brdf" and (e.kind != "discover" or discovered):
            spec = CSpec("brdf_fast", fits_dir, () if e.default else (("fast_brdf", e.form),))
            group = "discovered" if e.kind == "discover" else "fast"
            out.append(_fit_brdf(load(e.path), f"fast: {e.form} ({_fit_group(e)})", group, spec))
    return out + _baselines()


# -- part level ----------------------------------------------------------------------------------------
def _table_part(target: str, data_dir: Path):
    if target in ("H0", "H1"):
        return h_interpolant(int(target[1]), data_dir), "data/h%s.csv, spline of log(H)/mu in (s, log mu)" % target[1]
    if target in ("l", "m", "B", "C", "D", "F"):
        return constant_interpolant(target, data_dir), "data/constants.csv, cubic spline in s"
    if target == "kd_of_c":
        return kd_interpolant(data_dir), "data/kd.csv (kd_true), cubic spline in s"
    if target == "c_of_kd":
        return c_of_kd_interpolant(data_dir), "data/kd.csv, cubic spline of c against kd_true"
    return None, ""


def _positional(f, inputs):
    return lambda **x: f(*(x[n] for n in inputs))


def part_methods(target_name: str, entries: list[FitEntry], data_dir: Path) -> list[PartMethod]:
    """The part-level catalogue of one target (see the module docstring)."""
    from fitlab.families.lambert_sphere.exact import h_function
    from fitlab.store import load
    from fitlab.core import get_target

    t = get_target(target_name)
    out = []
    if target_name in ("H0", "H1"):
        order = int(target_name[1])
        out.append(PartMethod(target_name, "exact (Fock/Krein)", "exact", "fitlab.families.lambert_sphere.exact.h_function(method='fock'), "
                              "against the validation set's Nystrom values",
                              lambda mu, c: h_function(order, mu, c, method="fock")))  # fmt: skip
    f, src = _table_part(target_name, data_dir)
    if f is not None:
        out.append(PartMethod(target_name, "tables", "tables", src, _positional(f, t.inputs)))
    for form_name, preset in t.published:
        form = t.forms[form_name]
        theta = form.vector(preset)
        out.append(PartMethod(target_name, f"{form_name} / {preset}", "published", "fitlab.forms preset",
                              _positional(lambda *x, form=form, theta=theta: form.numpy_function(theta, *x),
                                          form.inputs),
                              c_key=(target_name, f"{form_name} / {preset}")))  # fmt: skip
    for e in entries:
        if e.target == target_name:
            fit = load(e.path)
            out.append(PartMethod(target_name, e.form, _fit_group(e), str(e.path),
                                  lambda fit=fit, **x: fit(**{k: x[k] for k in fit.inputs}), fit.domain,
                                  (target_name, e.form)))  # fmt: skip
    return out
