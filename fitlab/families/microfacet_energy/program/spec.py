r"""The microfacet_energy family's program (:data:`PROGRAM`, its ``codegen``): the fitted albedos a renderer
needs for Kulla-Conti energy compensation and the fitted multiple-scattering lobes, printed in Python, C and
the shading languages from the same symbolic definitions (:mod:`..lobes.shapes`, :mod:`.runtime`) and the fits,
through fitlab.codegen.

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.program.spec``."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import sympy as sp

from fitlab.codegen import Model, Program, ProgramSpec, Routine, build_program, call, part_routine, stable
from fitlab.families.microfacet_energy.lobes.tables import KINDS
from fitlab.families.microfacet_energy.program.runtime import MODELS, model_forms, multiple_scattering, order_lobes
from fitlab.families.microfacet_energy.targets import TARGETS
from fitlab.families.microfacet_energy.targets.lobe_parts import lobe_target_names
from fitlab.forms.symbolic import symbols
from fitlab.store import FitFunction, fit_path, fits_folder

__all__ = [
    "NAME",
    "PROGRAM",
    "PARTS",
    "PROGRAM_MODELS",
    "DEFAULT_MODEL",
    "KULLA_CONTI_PARTS",
    "KULLA_CONTI_FLOOR",
    "LANGUAGES",
    "fit_files",
    "lobe_program",
]

#: the generated files' base name and the functions' prefix: the family's name
NAME = "microfacet_energy"
#: every target with a generated routine, printed as its fit as it stands, in the family's order
PARTS = tuple(name for name, t in TARGETS.items() if t.routine is not None)
#: the lobe of each composed routine and the runtime model (:data:`.runtime.MODELS`) of its default forms
PROGRAM_MODELS = {"blog": "blog_refit", "tilt": "tilted"}
#: the model ``fitlab codegen --family microfacet_energy`` prints when none is named
DEFAULT_MODEL = PROGRAM_MODELS["blog"]
#: the fits Kulla-Conti's routine reads: E and E_avg of height-correlated GGX
KULLA_CONTI_PARTS = ("E_ggx_cor", "E_avg_ggx_cor")
#: the floor of 1 - E_avg in Kulla-Conti's routine: 2^-126, the smallest normal float32 (_kulla_conti says why)
KULLA_CONTI_FLOOR = sp.Float(2.0**-126)
#: the languages committed in fitlab/fits/generated (those the tests compile, validate and compare)
LANGUAGES = ("python", "c", "glsl")

mu_i, mu_o, cos_phi, alpha, rho, order = symbols(("mu_i", "mu_o", "cos_phi", "alpha", "rho", "order"))
_DOMAIN = {"mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "cos_phi": (-1.0, 1.0), "alpha": (0.0, 1.0), "rho": (0.0, 1.0)}


def _model_forms(model: str) -> dict[str, str]:
    """{target: form} of a lobe model's parameters (:data:`.runtime.MODELS`), both kinds of facets: the forms
    :func:`.runtime.model_forms` gives, read from this family's targets (the registry is not complete while the
    family registers)."""
    lobe, forms = MODELS[model][:2]
    return {name: forms.get(name.removeprefix(f"ms_{lobe}_").removesuffix(f"_{kind}"), TARGETS[name].default_form)
            for kind in KINDS for name in lobe_target_names(lobe, kind)}  # fmt: skip


def fit_files(fits_dir: Path | None = None, model: str | None = None) -> dict[str, Path]:
    """{target: fit file} of every fit the program of ``model`` (None: its default) reads in ``fits_dir`` (None:
    the packaged fits), in banner order: what ``fitlab codegen --family microfacet_energy`` reads."""
    folder = fits_folder(fits_dir)
    forms = PROGRAM.model(model).forms
    return {t: fit_path(folder, t, forms.get(t, TARGETS[t].default_form)) for t in PARTS}


def _blog_description(fits: Mapping[str, FitFunction], kind: str) -> str:
    """What the blog lobe's routine is: named by the runtime model whose forms its parameters' fits have."""
    lobe = "the blog's final lobe (undeviated, isotropic: no azimuth)"
    forms = {t: fits[t].form for t in model_forms("blog_refit", kind)}
    if forms == model_forms("blog_refit", kind):
        return lobe + " with its own forms refitted"
    if forms == model_forms("blog_rich", kind):
        return lobe + ", parameters in the targets' richer default forms"
    return lobe + ", parameters in the forms " + ", ".join(f"{t}.{f}" for t, f in forms.items())


def _composed(lobe: str, kind: str, fits: Mapping[str, FitFunction]) -> Routine:
    model = PROGRAM_MODELS[lobe]
    targets = tuple(model_forms(model, kind))
    parts = {t: call(TARGETS[t].routine, alpha, mu_i, *((order,) if "order" in TARGETS[t].inputs else ()))
             for t in targets}  # fmt: skip
    expr = multiple_scattering(kind, order_lobes(model, kind, parts))
    args = ["mu_i", "mu_o", *(["cos_phi"] if lobe == "tilt" else []), "alpha", *(["rho"] if kind == "diffuse" else [])]
    what = _blog_description(fits, kind) if lobe == "blog" else "the tilted lobe, every parameter per order"
    facets = (
        "diffuse (Lambertian) facets of albedo rho, order S weighted by rho^S (the tail above 4 by rho^5)"
        if kind == "diffuse"
        else "conductor facets with F = 1"
    )
    doc = (f"Multiple scattering (orders 2..4 and the tail above 4, summed) of {facets} on a GGX microsurface of "
           f"roughness alpha, for light from mu_i: {what}, fitted to the microsurface random walk "
           "(docs/microsurface_lobes.md). The BRDF (1/sr) to add to the single-scattering one. mu_i, mu_o in [0, 1]"
           + (", cos_phi in [-1, 1] (cos of the azimuth between w_o and w_i; 1: back-scattering)" if lobe == "tilt" else "")
           + "; the parameters are fitted for alpha, mu_i in [0.05, 1] and clamped there; inputs outside their "
           "domain are clamped, NaN gives NaN.")  # fmt: skip
    return Routine(f"ms_{lobe}_{kind}", tuple(args), expr, doc, domain={a: _DOMAIN[a] for a in args})


def _one_minus(fit: FitFunction, **inputs) -> sp.Expr:
    """1 - (the fit's expression) with its inputs replaced by name (``inputs``): the forms of E and E_avg are
    written 1 - (...), and sympy cancels the 1, so that 1 - E keeps every digit as it goes to 0 (1 minus a call
    of the fit's routine would lose them in float)."""
    expr = 1 - fit.expression
    if any(term.is_number and term != 0 for term in sp.Add.make_args(sp.expand(expr, deep=False, mul=False))):
        raise ValueError(f"Kulla-Conti's 1 - {fit.target}: its form {fit.form} is not written 1 - (...)")
    return stable(expr.xreplace({s: inputs[s.name] for s in expr.free_symbols if s.name in inputs}))


def _kulla_conti(fits: Mapping[str, FitFunction]) -> Routine:
    e, e_avg = (fits[t] for t in KULLA_CONTI_PARTS)
    # 1 - E_avg -> 0 as alpha -> 0 where 1 - E -> 0 too; the floor keeps 0/0 out at alpha = 0 (the lobe is 0 there)
    # and is reached only where 1 - E_avg is no normal float32 (alpha below about 1e-20)
    expr = (
        _one_minus(e, mu=mu_o, alpha=alpha)
        * _one_minus(e, mu=mu_i, alpha=alpha)
        / (sp.pi * sp.Max(_one_minus(e_avg, alpha=alpha), KULLA_CONTI_FLOOR))
    )
    doc = (
        "Kulla-Conti's compensation lobe (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)) of height-correlated GGX "
        "with F = 1, from the fits of E_ggx_cor and E_avg_ggx_cor (1 - E and 1 - E_avg written out, never formed "
        "by subtraction): the multiple scattering it assumes, for comparison with the fitted lobes. "
        "mu_i, mu_o, alpha in [0, 1]."
    )
    return Routine(
        "ms_kulla_conti",
        ("mu_i", "mu_o", "alpha"),
        expr,
        doc,
        domain={a: _DOMAIN[a] for a in ("mu_i", "mu_o", "alpha")},
    )


def routines(fits: Mapping[str, FitFunction], terms: tuple[str, ...] = ()) -> list[Routine]:
    """Every routine of the program, in file order, from the fits ({target: FitFunction}, every one of
    :data:`PARTS`); the program has no optional terms."""
    out = [part_routine(fits[t]) for t in PARTS]
    for kind in KINDS:
        for lobe in PROGRAM_MODELS:
            out.append(_composed(lobe, kind, fits))
    out.append(_kulla_conti(fits))
    return out


PROGRAM = ProgramSpec(
    name=NAME,
    fits=PARTS,
    parts=PARTS,
    routines=routines,
    models=(Model(DEFAULT_MODEL, _model_forms(DEFAULT_MODEL),
                  "ms_blog_* in the blog's own forms, refitted (the lobe model blog_refit); "
                  "every other target in its default form"),),
    default_model=DEFAULT_MODEL,
    about="Kulla-Conti energy compensation and multiple-scattering lobes of microfacet BRDFs: the fitted albedos E,\n"
          "1 - E and E_avg (GGX, separable and height-correlated Smith; Oren-Nayar), and the multiple scattering of\n"
          "GGX microsurfaces (diffuse facets, F = 1 conductors) fitted by order to the microsurface random walk: the\n"
          "blog's final lobe and the tilted lobe; Kulla-Conti's f_ms.",
    doc="Kulla-Conti energy compensation and multiple-scattering lobes of microfacet BRDFs, generated by fitlab:\n"
        "numpy only.\n\n"
        "Every function takes numpy arrays (any broadcastable shapes) and returns an array of float64.\n"
        "E_ggx_cor(mu, alpha), E_avg_ggx_cor(alpha) and the other albedos: docs/energy_compensation.md;\n"
        "ms_tilt_diffuse(mu_i, mu_o, cos_phi, alpha, rho) and the other lobes: docs/microsurface_lobes.md.\n",
)  # fmt: skip


def lobe_program(fits: Mapping[str, FitFunction], sources=()) -> Program:
    """The program of the fit records ``fits`` ({target: FitFunction}: every target of :data:`PARTS`), as
    ``fitlab codegen --family microfacet_energy`` builds it from files (:func:`fitlab.codegen.load_program`)."""
    return build_program(fits, sources=sources, family="microfacet_energy")
