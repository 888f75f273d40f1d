r"""The Lambert-sphere family's part of ``fitlab report`` (its :class:`fitlab.report.methods.BrdfReport`).

:mod:`fitlab.report` loops over the families and asks each, through this
module, for what only the family knows:

* :data:`REQUIRED_FITS`: the default fits its BRDF-level methods need (checked
  before any slow work): the runtime parts and H2, both albedo maps (the generated
  program carries them) and the fast variant;
* :data:`PARTS`: the targets measured at part level (every target but the
  whole-BRDF ``fast_brdf``, which is measured as a BRDF);
* :data:`PRESET_VARIANTS`: the published runtime preset sets;
* :func:`brdf_methods`: the BRDF-level catalogue (tables, published presets,
  refits, the order-2 model of :data:`..runtime.ORDER2_FORMS` (its parts fitted to the mixed
  reference, and to the true BRDF: :mod:`..true_refit`), richer and discovered forms, the fast variant,
  the baselines);
* :func:`part_extras`: the part-level methods beyond presets and fit files
  (the exact engine's Fock method for H0 and H1, the tables);
* :func:`preset_records`: a preset set as fit records, for codegen;
* :func:`check_tables`, :func:`tables_dir`, :func:`exact_brdf`, :func:`exact_kd`
  and :data:`EXACT_SOURCES`: the tables, and the exact values of the report's
  BRDF validation set (the material's BRDF: the whole phase function) with the sources its cache key hashes;
* the paper's three-term model and the mixed reference as BRDF methods (:data:`REFERENCES`), measured
  against the material's BRDF like every other method;
* the exact engine and Monte Carlo, measured by :func:`measure_engines` (:mod:`.engine_rows`, from
  :mod:`.exact_engine` and :mod:`.montecarlo`: the rows, and :data:`SOURCES`, what each measured), and their
  sections of report.md with the BRDF's title and sentences (:mod:`.markdown`: :func:`engine_sections`,
  :data:`BRDF_TITLE`, :data:`REPORT_TEXT`).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab.codegen import DEFAULT_FORMS, program_spec
from fitlab.core import get_target
from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.exact import albedo, brdf, h_function, spherical_albedo
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS
from fitlab.families.lambert_sphere.forms.baselines import BASELINE_INPUTS, LAMBERT, oren_nayar
from fitlab.families.lambert_sphere.program import table_export
from fitlab.families.lambert_sphere.program.baselines import baseline_program
from fitlab.families.lambert_sphere.program.bench import random_inputs
from fitlab.families.lambert_sphere.program.report.engine_rows import SOURCES, measure_engines
from fitlab.families.lambert_sphere.program.report.markdown import BRDF_TITLE, REPORT_TEXT, engine_sections
from fitlab.families.lambert_sphere.program.report.materials import (
    energy_materials,
    fresh_materials,
    validation_materials,
)
from fitlab.families.lambert_sphere.program.report.settings import (
    BRDF_INPUTS,
    BRDF_MATERIAL,
    BRDF_POINT,
    REPORT_SETTINGS,
)
from fitlab.families.lambert_sphere.program.report.spline_tables import kd_interpolant, table_brdf, table_part
from fitlab.families.lambert_sphere.program.report.spline_tables import memory_bytes as spline_bytes
from fitlab.families.lambert_sphere.program.runtime import (
    FAMILY_NAME,
    PRESET_VARIANTS,
    directional_albedo,
    runtime_model,
)
from fitlab.families.lambert_sphere.program.spec import THREE_TERM_MODEL, TRUE_MODEL
from fitlab.families.lambert_sphere.program.true_refit import TRUE_FITS, true_runtime_model
from fitlab.families.lambert_sphere.targets import TARGETS
from fitlab.families.lambert_sphere.targets.table_files import check_tables, tables_dir
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.report.methods import BrdfMethod, CSpec, PartMethod, best_forms, fit_group, positional
from fitlab.store import FORMAT, load

__all__ = [
    "REQUIRED_FITS",
    "PARTS",
    "PRESET_VARIANTS",
    "tables_dir",
    "EXACT_SOURCES",
    "SOURCES",
    "brdf_methods",
    "part_extras",
    "preset_records",
    "check_tables",
    "exact_brdf",
    "exact_kd",
    "measure_engines",
    "REFERENCES",
    "exact_albedo",
    "directional_albedo",
    "timing_inputs",
    "baseline_program",
    "validation_materials",
    "fresh_materials",
    "energy_materials",
    "BRDF_INPUTS",
    "BRDF_POINT",
    "BRDF_MATERIAL",
    "REPORT_SETTINGS",
    "BRDF_TITLE",
    "REPORT_TEXT",
    "engine_sections",
]

#: the albedo maps: not in the BRDF, but in its generated program (their C is timed there)
MAPS = ("kd_of_c", "c_of_kd")
FAST = "fast_brdf"
REQUIRED_FITS = (*RUNTIME_PARTS, ORDER2_PART, *MAPS, FAST)
PARTS = tuple(name for name in TARGETS if name != FAST)
#: the exact engine's folder (its sources, :data:`fitlab.families.lambert_sphere.exact.SOURCES`): the report's cache
#: of exact values is keyed on them
EXACT_SOURCES = exact.SOURCES[0].parent


def timing_inputs(n: int, data_dir: Path) -> dict:
    """Seeded random inputs by argument name: mu_i, mu_o, c, cos_phi (as fitlab bench codegen), phi =
    acos(cos_phi), kd = kd_true(c) (tables), mu = mu_i."""
    x = random_inputs(n)
    x["phi"] = np.arccos(x["cos_phi"])
    x["kd"] = np.clip(kd_interpolant(data_dir)(x["c"]), 0.0, 1.0)
    x["mu"] = x["mu_i"]
    return x


def exact_brdf(mu_i, mu_o, phi, c: float) -> np.ndarray:
    """The exact BRDF at points, at one albedo c: the material's, the whole phase function in every collision."""
    return brdf(mu_i, mu_o, phi, c, phase="true")


def exact_albedo(mu, c: float) -> np.ndarray:
    """The exact directional albedo at incident cosines mu, one albedo c (the whole phase function, as exact_brdf)."""
    return np.asarray(albedo(np.asarray(mu, dtype=float), c, phase="true"), dtype=float)


def exact_kd(c) -> np.ndarray:
    """kd = kd_true(c), the spherical albedo of the exact BRDF (the input of the fast variant and the baselines)."""
    return np.asarray(spherical_albedo(c, phase="true"), dtype=float)


#: the approximate references the report measures as BRDF methods: (name, phase of exact.brdf)
REFERENCES = (
    ("mixed reference (true single, three-term multiple scattering)", "mixed"),
    ("three-term half space (the paper's model in every collision)", "three_term"),
)


def _references() -> list[BrdfMethod]:
    """The three-term engine's BRDFs (exact.brdf with phase "mixed" and "three_term") as methods: not timed
    (a solve per distinct c; the timing inputs have a new c at every point)."""

    def method(name, phase):
        def f(mi, mo, ph, c, kd):
            return brdf(mi, mo, ph, c, phase=phase)

        return BrdfMethod(name, "exact", f"fitlab.families.lambert_sphere.exact.brdf(phase={phase!r})", f, timed=False)

    return [method(name, phase) for name, phase in REFERENCES]


# -- presets as fit records (for codegen) -------------------------------------------------------------
def preset_records(variant: str) -> dict:
    """{(target, form): fit record} of a published preset set: the runtime parts of
    :data:`PRESET_VARIANTS`, H2 = 1 (the paper drops fm2), the published eq. 41 and albedo maps, so that codegen can print the
    published model like any fit.  (codegen always uses the exact normalisations; ``paper_printed``'s C
    differs from its printed normalisation only in two constants, which cost nothing.)"""
    choice = dict(PRESET_VARIANTS[variant][0])
    choice[ORDER2_PART] = ("unity", "paper")  # the paper drops fm2 (eq. 21): H2 = 1 makes it 0
    choice[FAST] = ("paper", "paper")
    choice["kd_of_c"] = ("printed", "paper")
    choice["c_of_kd"] = ("rational_power", "renderer" if variant == "renderer" else "paper")
    out = {}
    for target, (form_name, preset) in choice.items():
        t = get_target(target)
        form = t.forms[form_name]
        out[(target, form_name)] = {
            "format": FORMAT, "target": target, "form": form_name, "inputs": list(form.inputs),
            "expression": form.expression, "params": dict(zip(form.params, form.vector(preset).tolist())),
            "domain": {k: list(t.domain[k]) for k in form.inputs},
            "form_description": f"{form.description} Published preset {preset!r}.",
            "validation": {"max_rel": float("nan"), "rms_rel": float("nan")},
            "origin": {"method": "preset", "preset": preset},
        }  # fmt: skip
    return out


# -- BRDF level ------------------------------------------------------------------------------------
def _coefficient_bytes(expr) -> float:
    """8 bytes per floating-point number in a fitted model's expression (its fitted coefficients; the exact
    constants of the maths are rationals)."""
    return 8.0 * len(expr.atoms(sp.Float)) if expr is not None else float("nan")


def _runtime(model, name, group, source, cspec) -> BrdfMethod:
    return BrdfMethod(name, group, source, lambda mi, mo, ph, c, kd: model(mi, mo, ph, c), model.expr, cspec,
                      _coefficient_bytes(model.expr))  # fmt: skip


#: the exported tables the report measures (nodes per axis, lookup): the shipped default, and the other lookup
#: and resolutions of docs/table_export.md that bound it
EXPORTED_TABLES = ((table_export.DEFAULT_NODES, table_export.DEFAULT_LOOKUP), (17, "cubic"), (65, "linear"))


#: the parts the exported tables hold, measured at part level (the shipped default)
EXPORTED_PARTS = ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "c_of_kd")


def _exported_tables(data_dir: Path) -> list[BrdfMethod]:
    out = []
    for nodes, lookup in EXPORTED_TABLES:
        f = table_export.numpy_brdf(nodes, lookup, data_dir)

        @lru_cache(maxsize=1)
        def c_files(nodes=nodes, lookup=lookup):
            prog = table_export.program(nodes, lookup, data_dir)
            files = table_export.generate("c", nodes, lookup, data_dir)
            return prog, {name: data.decode() for name, data in files.items()}

        name = f"exported tables, {'bicubic' if lookup == 'cubic' else 'bilinear'} {nodes} x {nodes}"
        out.append(BrdfMethod(name, "tables", f"fitlab codegen --tables --nodes {nodes} --lookup {lookup} "
                              "(fitlab.families.lambert_sphere.program.table_export)",
                              lambda mi, mo, ph, c, kd, f=f: f(mi, mo, ph, c), None, CSpec("brdf", build=c_files),
                              float(table_export.memory_bytes(nodes))))  # fmt: skip
    return out


def _fit_brdf(fit, name, group, cspec) -> BrdfMethod:
    """A whole-BRDF fit (fast_brdf): inputs by name; kd clipped to [0, 1] as the generated code does."""

    def f(mi, mo, ph, c, kd):
        values = {"mu_i": mi, "mu_o": mo, "phi": ph, "c": c, "kd": np.minimum(kd, 1.0)}
        return fit(**{k: values[k] for k in fit.inputs})

    return BrdfMethod(name, group, str(fit.path), f, fit.expression, cspec, _coefficient_bytes(fit.expression))


def _baselines() -> list[BrdfMethod]:
    out = []
    for name, expr, routine in (("Lambert kd/pi", LAMBERT, "baseline_lambert"),
                                ("Oren-Nayar sigma 0.5", oren_nayar(), "baseline_oren_nayar")):  # fmt: skip
        raw = lambdify_numpy(symbols(BASELINE_INPUTS), expr)

        def f(mi, mo, ph, c, kd, raw=raw):
            return np.broadcast_to(np.asarray(raw(mi, mo, np.cos(ph), kd), dtype=float), np.shape(mi)).copy()

        (phi,) = symbols(("phi",))
        e = expr.subs(symbols(("cos_phi",))[0], sp.cos(phi))
        out.append(BrdfMethod(name, "baseline", "fitlab.families.lambert_sphere.forms.baselines, kd = kd_true(c)", f,
                              e, CSpec(routine), _coefficient_bytes(e)))  # fmt: skip
    return out


def _forms_off_default(model: str) -> dict:
    """{part: form} of the program's ``model`` where the form is not the part's default."""
    return {p: f for p, f in program_spec(FAMILY_NAME).model(model).forms.items() if f != get_target(p).default_form}


def _label(forms: dict) -> str:
    return ", ".join(f"{k}: {v}" for k, v in forms.items())


def brdf_methods(fits_dir: Path, entries: list, data_dir: Path, preset_c: tuple = (),
                 discovered: bool = True) -> list[BrdfMethod]:  # fmt: skip
    """The BRDF-level catalogue (see :mod:`fitlab.report.methods`); ``preset_c``: the preset variants
    whose C is built (see :func:`preset_records`); ``discovered=False`` leaves out the entries of
    discovered forms."""
    fits_dir = Path(fits_dir)
    out = []
    for order2, name in ((False, "tables, runtime model"), (True, "tables, three orders")):
        f = table_brdf(data_dir, order2=order2)
        out.append(BrdfMethod(name, "tables",
                              "data/*.csv with splines (fitlab.families.lambert_sphere.program.report.spline_tables)",
                              lambda mi, mo, ph, c, kd, f=f: f(mi, mo, ph, c),
                              bytes=float(spline_bytes(data_dir, order2))))  # fmt: skip
    out += _exported_tables(data_dir)
    for v in PRESET_VARIANTS:
        m = runtime_model(v)
        spec = CSpec("brdf", preset=v) if v in preset_c else None
        out.append(_runtime(m, f"published: {v}", "published", _label(m.sources), spec))
    out.append(_runtime(runtime_model(fits_dir=fits_dir, model=DEFAULT_FORMS), "refit", "refit", "default forms in " + str(fits_dir),
                        CSpec("brdf", fits_dir)))  # fmt: skip
    # the program's three-term model (each part fitted to its own target), where its forms are in the catalogue
    order2 = _forms_off_default(THREE_TERM_MODEL)
    if not all(any(e.target == p and e.form == f for e in entries) for p, f in order2.items()):
        order2 = None
    if order2:
        m = runtime_model(fits_dir=fits_dir, model=THREE_TERM_MODEL)
        out.append(_runtime(m, "model three-term", "refit, richer",
                            f"fitlab codegen --model {THREE_TERM_MODEL} (parts fitted to their own targets: "
                            f"{_label(order2)})", CSpec("brdf", fits_dir, tuple(sorted(order2.items())))))  # fmt: skip
        # the same structure and forms with the parts fitted to the true BRDF (the packaged ones, whatever fits_dir
        # is): the program's default model, what fitlab codegen and runtime_model() give
        # (in the default model's own forms: its H forms are not the three-term model's)
        m = true_runtime_model()
        true_forms = _forms_off_default(TRUE_MODEL)
        out.append(_runtime(m, "model true (the default)", "refit, richer",
                            f"fitlab codegen (parts fitted to the true BRDF, fitlab/fits/true: {_label(true_forms)})",
                            CSpec("brdf", TRUE_FITS, tuple(sorted(true_forms.items())))))  # fmt: skip
    richer = best_forms(entries, {"refit"}, (*RUNTIME_PARTS, ORDER2_PART))
    if richer and richer != order2:  # the best part fits may be the order-2 model itself
        m = runtime_model(fits_dir=fits_dir, forms=richer, model=DEFAULT_FORMS)
        c_forms = {**richer, **best_forms(entries, {"refit"}, MAPS)}
        out.append(_runtime(m, "refit, richer forms", "refit, richer", _label(richer),
                            CSpec("brdf", fits_dir, tuple(sorted(c_forms.items())))))  # fmt: skip
    found = [e for e in entries if e.kind == "discover"] if discovered else []
    for e in found:
        if e.target in RUNTIME_PARTS:
            forms = {e.target: e.form}
            m = runtime_model(fits_dir=fits_dir, forms=forms, model=DEFAULT_FORMS)
            out.append(_runtime(m, f"refit + {e.target} {e.form}", "discovered", str(e.path),
                                CSpec("brdf", fits_dir, tuple(forms.items()))))  # fmt: skip
    if any(e.target in RUNTIME_PARTS for e in found):
        kinds = {e.kind for e in entries}
        best = best_forms(entries, kinds, RUNTIME_PARTS)
        if best and best != richer:
            m = runtime_model(fits_dir=fits_dir, forms=best, model=DEFAULT_FORMS)
            c_forms = {**best, **best_forms(entries, kinds, MAPS)}
            out.append(_runtime(m, "best fits (discovered included)", "discovered", _label(best),
                                CSpec("brdf", fits_dir, tuple(sorted(c_forms.items())))))  # fmt: skip
    fast_form = get_target(FAST).forms["paper"]
    fast_raw = fast_form.numpy_function
    theta = fast_form.vector("paper")
    out.append(BrdfMethod(
        "fast eq. 41: paper", "fast", "fast_brdf/paper preset (eq. 41 as printed)",
        lambda mi, mo, ph, c, kd: np.asarray(fast_raw(theta, mi, mo, ph, c, np.minimum(kd, 1.0)), dtype=float),
        fast_form.substituted("paper"), CSpec("brdf_fast", preset="paper") if "paper" in preset_c else None,
        _coefficient_bytes(fast_form.substituted("paper")),
    ))  # fmt: skip
    for e in entries:
        if e.target == FAST and (e.kind != "discover" or discovered):
            spec = CSpec("brdf_fast", fits_dir, () if e.default else ((FAST, e.form),))
            group = "discovered" if e.kind == "discover" else "fast"
            out.append(_fit_brdf(load(e.path), f"fast: {e.form} ({fit_group(e)})", group, spec))
    return out + _baselines() + _references()


# -- part level ------------------------------------------------------------------------------------
def part_extras(target_name: str, data_dir: Path) -> list[PartMethod]:
    """The part-level methods of a target beyond its presets and fit files: the Fock method of the
    exact engine (H0, H1), then the tables with interpolation."""
    t = get_target(target_name)
    out = []
    if target_name in ("H0", "H1"):
        order = int(target_name[1])
        out.append(PartMethod(target_name, "exact (Fock/Krein)", "exact",
                              "fitlab.families.lambert_sphere.exact.h_function(method='fock'), "
                              "against the validation set's Nystrom values",
                              lambda mu, c: h_function(order, mu, c, method="fock")))  # fmt: skip
    f, src = table_part(target_name, data_dir)
    if f is not None:
        out.append(PartMethod(target_name, "tables", "tables", src, positional(f, t.inputs)))
    if target_name in EXPORTED_PARTS:
        nodes, lookup = EXPORTED_TABLES[0]
        f = table_export.numpy_part(target_name, nodes, lookup, data_dir)
        out.append(PartMethod(target_name, f"exported tables, {'bicubic' if lookup == 'cubic' else 'bilinear'} "
                              f"{nodes} x {nodes}", "tables", "fitlab codegen --tables (the shipped default)",
                              positional(f, t.inputs)))  # fmt: skip
    return out
