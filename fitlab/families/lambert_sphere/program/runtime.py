r"""The runtime Lambert-sphere BRDF (docs/model.md, "The runtime BRDF"),
assembled from forms with numbers.

``runtime_model(variant)`` builds f_r(mu_i, mu_o, phi, c) =
max(0, f_1 + fm0 + fm1 cos phi [+ fm2 cos 2phi]) (see
:func:`fitlab.families.lambert_sphere.forms.runtime_brdf`) from

* a published preset set: ``"paper_printed"`` (every coefficient and both
  normalisations as printed, the separable H1 read as printed),
  ``"paper"`` (printed coefficients, the renderer reading of H1, the exact
  3 pi / 192 pi normalisations), ``"renderer"`` (the author's renderer
  coefficients where they differ, exact normalisations); or
* saved fits: ``runtime_model()`` is the model ``fitlab codegen`` prints (the
  program's default model, from the packaged fits); ``fits_dir`` overlays a
  folder of one's own on the packaged fits, ``model="default-forms"`` takes
  fits/H0.json, H1.json, l.json, m.json, B.json ... F.json (the default forms),
  ``forms={"H0": "hapke_rational", ...}`` the files of other forms; fits add the
  second Fourier order fm2 cos 2phi with fits/H2.json unless ``order2=False``.

:func:`accuracy` measures a runtime model against the exact BRDF on the
issue-18 sets (random and edge points over mu >= 0.01 and every c, the grazing
set, c = 0) and its directional albedo against the exact one.

The result is a :class:`RuntimeModel`: the sympy expression (what codegen
consumes) and a numpy callable.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab.codegen import DEFAULT_FORMS
from fitlab.core import get_form, get_target
from fitlab.families.lambert_sphere import exact
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, RUNTIME_TERMS, runtime_brdf, runtime_sum
from fitlab.families.lambert_sphere.program.rewrites import stable
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import fit_source, load

__all__ = [
    "RuntimeModel",
    "runtime_model",
    "PRESET_VARIANTS",
    "accuracy",
    "accuracy_points",
    "directional_albedo",
    "ALBEDOS",
    "ORDER2_FORMS",
    "TRUE_FORMS",
    "energy_scale",
    "assembled",
    "ENERGY_MARGIN",
    "ENERGY_MU",
    "model_accuracy",
]

PRESET_VARIANTS = {
    "paper_printed": ({"H0": ("hapke", "paper"), "H1": ("separable_printed", "paper"), "l": ("quadratic", "paper"),
                       "m": ("linear", "paper"), **{n: ("printed", "paper") for n in "BCDF"}}, "printed"),
    "paper": ({"H0": ("hapke", "paper"), "H1": ("separable", "paper"), "l": ("quadratic", "paper"),
               "m": ("linear", "paper"), **{n: ("printed", "paper") for n in "BCDF"}}, "corrected"),
    "renderer": ({"H0": ("hapke", "paper"), "H1": ("separable", "renderer"), "l": ("quadratic", "renderer"),
                  "m": ("linear", "renderer"), **{n: ("printed", "paper") for n in "BCDF"}}, "corrected"),
}  # fmt: skip

INPUTS = ("mu_i", "mu_o", "phi", "c")

#: the family's name, whose program's models :func:`runtime_model` takes
FAMILY_NAME = "lambert_sphere"

#: the forms of the order-2 runtime model: H0, H1, H2 exact at mu = 0, to first order in c and in
#: their grazing log(1/mu) behaviour (log_exp); B, C, D, F exact to first order in c (c2_rational_4_3), so that
#: fm0 = f0 - f0_ss is O(c^2) like the exact one; l, m the richer polynomials.  With fits_dir and
#: ``forms=ORDER2_FORMS``, :func:`runtime_model` gives f_1 + fm0 + fm1 cos phi + fm2 cos 2phi.
ORDER2_FORMS = {"H0": "log_exp", "H1": "log_exp", "H2": "log_exp", "l": "cubic", "m": "quadratic",
                **{n: "c2_rational_4_3" for n in "BCDF"}}  # fmt: skip
#: the forms of the model whose parts are fitted to the true BRDF (the program's model "true"; program.true_refit): the
#: same structure, with H0, H1, H2 in log_exp_true (the true BRDF's grazing law, and one more power of mu in H1 and H2)
TRUE_FORMS = {**ORDER2_FORMS, "H0": "log_exp_true", "H1": "log_exp_true", "H2": "log_exp_true"}


@dataclass(frozen=True, eq=False)
class RuntimeModel:
    name: str
    expr: sp.Expr
    sources: dict  # part -> "form / preset" or fit file

    def __post_init__(self):
        object.__setattr__(self, "_f", lambdify_numpy(symbols(INPUTS), self.expr))

    def __call__(self, mu_i, mu_o, phi, c):
        arrays = [np.asarray(x, dtype=float) for x in (mu_i, mu_o, phi, c)]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = self._f(*arrays)
        return np.broadcast_to(np.asarray(out, dtype=float), np.broadcast_shapes(*(a.shape for a in arrays))).copy()


def runtime_model(
    variant: str | None = None,
    *,
    fits_dir: Path | None = None,
    forms: dict | None = None,
    model: str | None = None,
    normalisation: str = "corrected",
    order2: bool | None = None,
    allow_mixed_physics: bool = False,
) -> RuntimeModel:
    """The runtime BRDF from a preset ``variant``, else from fits: ``runtime_model()`` is the model ``fitlab codegen``
    prints, from the packaged fits.

    Fits are read from ``fits_dir`` overlaid on the packaged fits of ``model`` (:func:`fitlab.store.fit_source`;
    None: the packaged fits).  Their forms are ``model``'s (a model of the family's program,
    :attr:`fitlab.codegen.ProgramSpec.models`; None: the program's default model, the one place that default is
    chosen, "true": the parts fitted to the true BRDF; "three-term": each part fitted to its own target;
    ``"default-forms"``: each part's default form), with ``forms`` ({part: form}) in place of a part's.  Parts
    fitted to another physics than the model's are refused (FitFileError) unless ``allow_mixed_physics``.
    ``order2``: add fm2 cos(2 phi) with the fit of H2 (docs/model.md, "Order 2"); None means yes for fits (the
    generated program has fm2) and no for the published presets (the paper has no H2; True with a preset is an
    error)."""
    if variant is not None and (fits_dir is not None or forms or model is not None):
        raise ValueError("give a preset variant, or fits (fits_dir, forms, model), not both")
    if order2 is None:
        order2 = variant is None
    if order2 and variant is not None:
        raise ValueError("the published presets have no H2: order2=True needs fits")
    parts, sources = {}, {}
    if variant is not None:
        if variant not in PRESET_VARIANTS:
            raise ValueError(f"unknown runtime variant {variant!r}; choose one of {', '.join(PRESET_VARIANTS)}")
        choice, normalisation = PRESET_VARIANTS[variant]
        for part in RUNTIME_PARTS:
            form_name, preset = choice[part]
            parts[part] = get_form(part, form_name).substituted(preset)
            sources[part] = f"{form_name} / {preset}"
        name = variant
    else:
        from fitlab.codegen import check_physics, program_spec  # imported here: the program imports this module

        spec = program_spec(FAMILY_NAME)
        chosen_model = spec.model(model)
        chosen = {**chosen_model.forms, **(forms or {})}
        fits = {}
        for part in (*RUNTIME_PARTS, *((ORDER2_PART,) if order2 else ())):
            path = fit_source(fits_dir, part, chosen.get(part, get_target(part).default_form), chosen_model.folder)
            fits[part] = load(path)
            parts[part] = fits[part].expression
            sources[part] = path.name  # the file, wherever its folder is (audit.json stays the same)
        if not allow_mixed_physics:
            check_physics(spec, chosen_model, fits)
        model_name = chosen_model.name
        name = "refit" if model_name == DEFAULT_FORMS else f"refit, model {model_name}"
        if forms:
            name += " (" + ", ".join(f"{k}: {v}" for k, v in forms.items()) + ")"
        if not order2:
            name += ", orders 0 and 1"
    return RuntimeModel(
        name, runtime_brdf(parts, normalisation, energy_scale(parts, normalisation=normalisation)), sources
    )


# -- energy ------------------------------------------------------------------------------------------
#: the fitted model's directional albedo at c = 1 is held at or below 1 - ENERGY_MARGIN on ENERGY_MU
ENERGY_MARGIN = 1e-5
#: the incidences where the energy scale is measured: the grazing edge, then every 0.01 up to normal
ENERGY_MU = np.concatenate(([1e-6, 1e-4, 1e-3], np.arange(1, 101) / 100))


def energy_scale(
    parts: dict, terms=RUNTIME_TERMS, normalisation: str = "corrected", use_cache: bool = True
) -> sp.Rational:
    r"""The energy scale s of a fitted runtime model: f_r = max(0, s (f_1 + fm0 + ...)), so that the model
    never creates energy.

    s = min(1, (1 - ENERGY_MARGIN) / max_mu a(mu, c = 1)), rounded down to 6 decimals (so that it prints
    the same on every machine), where a is the directional albedo (:func:`directional_albedo`) of the
    unscaled model built from ``parts`` (expressions with numbers), the ``terms`` kept and
    ``normalisation`` (:func:`runtime_terms`), at the incidences :data:`ENERGY_MU`.  Every runtime model
    has it, the published presets included; theirs is 1 (they lose 1 to 2 % at c = 1), which a test checks.  The exact BRDF itself reaches 1 + 7e-5 at c = 1 (its single
    scattering has the true phase function, its multiple scattering the three-term one), so a model
    close to it overshoots 1 by as much; s < 1 scales it by a few 1e-5, far inside the accuracy goal,
    keeping the exact zero at c = 0, reciprocity and non-negativity.  The albedo is smooth in mu
    (it varies by about 1e-5 over 0.05 near its maximum), so ENERGY_MARGIN covers the incidences
    between the grid's; tests measure the scaled model on a finer grid.

    The scale (a second or so of quadrature) is kept in fitlab's cache (:mod:`fitlab.cache`; ``use_cache``
    False: computed afresh), keyed by the parts' expressions (``sympy.srepr``), ``terms``, ``normalisation``,
    the numpy and sympy versions and the bytes of the code that computes it (:func:`_energy_sources`)."""
    return _energy_scale(tuple(sorted(parts.items())), tuple(terms), normalisation, bool(use_cache))


def _energy_sources() -> list[Path]:
    """The files whose code decides an energy scale: the exact engine's quadrature rules, the family's forms,
    this module, the stable rewrites and the lambdify of the parts."""
    import inspect

    fam = Path(__file__).resolve().parents[1]
    return [*exact.SOURCES, *sorted((fam / "forms").glob("*.py")), Path(__file__).resolve(),
            Path(inspect.getfile(stable)), Path(inspect.getfile(lambdify_numpy))]  # fmt: skip


@functools.lru_cache(maxsize=64)
def _energy_scale(parts: tuple, terms: tuple, normalisation: str, use_cache: bool) -> sp.Rational:
    from fitlab.cache import cached_arrays

    def compute():
        # each part lambdified on its own and the structure over placeholders: one lambdify (with cse) of the
        # whole inlined model costs seconds
        functions = {p: lambdify_numpy(symbols(get_target(p).inputs), e) for p, e in parts}
        model = assembled(functions, terms=terms, normalisation=normalisation)
        peak = float(np.max(directional_albedo(model, ENERGY_MU, 1.0)))
        return {"millionths": np.int64(np.floor((1.0 - ENERGY_MARGIN) / peak * 1e6))}

    key = {"parts": [[p, sp.srepr(e)] for p, e in parts], "terms": list(terms), "normalisation": normalisation,
           "numpy": np.__version__, "sympy": sp.__version__}  # fmt: skip
    scaled = int(cached_arrays(f"{FAMILY_NAME}-energy-scale", key, compute, ("millionths",), _energy_sources(),
                               use_cache)["millionths"])  # fmt: skip
    return sp.S.One if scaled >= 10**6 else sp.Rational(scaled, 10**6)


def assembled(functions: dict, scale=1, terms=RUNTIME_TERMS, normalisation: str = "corrected"):
    """The runtime structure with each part a numpy function ({part: f(mu, c) or f(c)}; H2 optional):
    a model f(mu_i, mu_o, phi, c) = max(0, scale (sum of the ``terms`` kept)), evaluated as the generated
    code evaluates it (:func:`fitlab.families.lambert_sphere.program.rewrites.stable`: single scattering without
    the cancellation of sqrt(1 - u^2) in forward scattering at grazing)."""
    mu, c = symbols(("mu", "c"))
    placeholders = {p: sp.Function(f"part_{p}")(*((mu, c) if get_target(p).inputs == ("mu", "c") else (c,)))
                    for p in functions}  # fmt: skip
    total = stable(runtime_sum(placeholders, normalisation, terms))
    f = sp.lambdify(symbols(INPUTS), total, modules=[{f"part_{p}": g for p, g in functions.items()}, "numpy"])

    def model(mu_i, mu_o, phi, cv):
        arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (mu_i, mu_o, phi, cv)))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = np.maximum(0.0, float(scale) * np.asarray(f(*arrays), dtype=float))
        return np.broadcast_to(out, arrays[0].shape).copy()

    return model


# -- measurement -------------------------------------------------------------------------------------
#: albedos of the accuracy sets: the edges c -> 0 and c = 1 that the report's validation set misses
#: (its smallest c is 0.0503), then random ones (drawn per seed, uniform in c and in s)
ALBEDOS = (1e-6, 1e-4, 1e-3, 0.01, 0.03, 0.05, 1.0)


def accuracy_points(seed: int = 18, n: int = 400, n_random_c: int = 8, mu_min: float = 0.01) -> dict:
    """The point sets of :func:`accuracy`, as arrays by name.

    "main": for every albedo (:data:`ALBEDOS`, ``n_random_c`` uniform in c and as many uniform in
    s = sqrt(1 - c), seeded), ``n`` uniform points (mu_i, mu_o) in [mu_min, 1]^2, phi in [0, pi], plus the
    edge points mu in {mu_min, 1}^2 x phi in {0, pi/2, pi}; "grazing": mu_i, mu_o in {1e-6, 1e-4, 1e-2}
    x phi in {0, pi/2, pi} at the same albedos.  phi and -phi give the same value (every term is even in
    phi), so [0, pi] covers the domain."""
    rng = np.random.default_rng(seed)
    albedos = np.concatenate((ALBEDOS, rng.uniform(0.0, 1.0, n_random_c), 1.0 - rng.uniform(0.0, 1.0, n_random_c) ** 2))
    edge_mu, edge_phi = np.array([mu_min, 1.0]), np.array([0.0, np.pi / 2, np.pi])
    graze_mu = np.array([1e-6, 1e-4, 1e-2])
    sets = {"main": [], "grazing": []}
    for _ in albedos:  # one block of random points per albedo
        mi, mo, ph = rng.uniform(mu_min, 1.0, n), rng.uniform(mu_min, 1.0, n), rng.uniform(0.0, np.pi, n)
        e = np.meshgrid(edge_mu, edge_mu, edge_phi, indexing="ij")
        sets["main"].append(np.stack([np.concatenate((mi, e[0].ravel())), np.concatenate((mo, e[1].ravel())),
                                      np.concatenate((ph, e[2].ravel()))]))  # fmt: skip
        g = np.meshgrid(graze_mu, graze_mu, edge_phi, indexing="ij")
        sets["grazing"].append(np.stack([x.ravel() for x in g]))
    out = {}
    for name, blocks in sets.items():
        cols = np.concatenate(blocks, axis=1)
        reps = [b.shape[1] for b in blocks]
        out[name] = {"mu_i": cols[0], "mu_o": cols[1], "phi": cols[2], "c": np.repeat(albedos, reps)}
    return out


def directional_albedo(f, mu_i, c, n_phi: int = 48, nodes_per_panel: int = 8) -> np.ndarray:
    r"""a(mu_i) = int_0^1 int_0^{2 pi} f(mu_i, mu_o, phi, c) mu_o dphi dmu_o for a BRDF f(mu_i, mu_o, phi, c)
    even in phi: 2 int_0^pi by Gauss-Legendre in phi (``n_phi`` nodes), mu_o by the exact engine's graded
    Gauss rule (panels [4^-(k+1), 4^-k] down to 1e-12: the multiple-scattering terms grow like log(1/mu)
    at grazing).  mu_i in (0, 1] (1-D), c in [0, 1] one albedo."""
    from fitlab.families.lambert_sphere.exact import gauss_legendre, graded_gauss

    mu_o, w_mu = graded_gauss(nodes_per_panel, 0.25, 1e-12)
    x, w_phi = gauss_legendre(n_phi)
    phi, w_phi = np.pi * x, np.pi * w_phi
    mu_i = np.atleast_1d(np.asarray(mu_i, dtype=float))
    mi, mo, ph = np.meshgrid(mu_i, mu_o, phi, indexing="ij")
    vals = np.asarray(f(mi, mo, ph, np.full(mi.shape, float(c))), dtype=float)
    return 2.0 * np.einsum("ijk,j,k->i", vals, w_mu * mu_o, w_phi)


def _rel(f, exact):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(f - exact) / np.abs(exact)


def _albedo_mu(albedo_mu) -> np.ndarray:
    return np.concatenate(([1e-3], np.arange(1, 21) / 20)) if albedo_mu is None else np.asarray(albedo_mu, dtype=float)


def accuracy_reference(
    seed: int = 18, n: int = 400, phase: str | None = None, albedo_c=(1e-3, 0.3, 0.7, 0.95, 1.0), albedo_mu=None
) -> dict:
    """The exact values :func:`accuracy` measures against, through fitlab's persistent cache (keyed by the
    points, the phase and the exact engine's sources): {"main": f, "grazing": f, "albedo": a[c, mu]} with
    f = :func:`fitlab.families.lambert_sphere.exact.brdf` (``phase``, default its default) at
    :func:`accuracy_points` and a = :func:`fitlab.families.lambert_sphere.exact.albedo` (same phase)."""
    from fitlab.cache import cached_arrays
    from fitlab.families.lambert_sphere.exact import albedo, brdf, check_phase

    phase = check_phase(phase)
    pts = accuracy_points(seed, n)
    mu = _albedo_mu(albedo_mu)
    albedo_c = np.asarray(albedo_c, dtype=float)

    def compute():
        # every set at one c before the next c: the true-phase engine keeps the solutions of about one c, so a
        # set after set loop would solve each c once per set
        out = {name: np.empty(p["c"].shape) for name, p in pts.items()}
        for cv in np.unique(np.concatenate([p["c"] for p in pts.values()])):
            for name, p in pts.items():
                sel = p["c"] == cv
                if sel.any():
                    out[name][sel] = brdf(p["mu_i"][sel], p["mu_o"][sel], p["phi"][sel], cv, phase=phase)
        out["albedo"] = np.array([albedo(mu, cv, phase=phase) for cv in albedo_c]).reshape(albedo_c.size, mu.size)
        return out

    key = {
        "family": "lambert_sphere",
        "set": "runtime-accuracy",
        "seed": seed,
        "n": n,
        "phase": phase,
        "albedo_c": albedo_c,
        "albedo_mu": mu,
    }
    return cached_arrays(
        f"lambert_sphere-accuracy-{phase}", key, compute, ("main", "grazing", "albedo"), sources=exact.SOURCES
    )


def accuracy(
    model, seed: int = 18, n: int = 400, albedo_c=(1e-3, 0.3, 0.7, 0.95, 1.0), albedo_mu=None, phase: str | None = None
) -> dict:
    r"""The accuracy figures of a runtime model ``model(mu_i, mu_o, phi, c)``, against
    :func:`fitlab.families.lambert_sphere.exact.brdf` with ``phase`` (default the engine's default, "true": the
    whole phase function; "mixed": the reference the runtime parts were fitted to), relative error
    |f - f_exact| / f_exact:

    * "max", "rms", "worst": on the main set of :func:`accuracy_points` (mu >= 0.01, every c, every phi);
    * "max_grazing", "worst_grazing": on the grazing set (mu down to 1e-6);
    * "max_c0": max |f| at c = 0 on the main set's points (0 for an exact zero);
    * "albedo_err": max |a - a_exact| over ``albedo_c`` x ``albedo_mu`` (:func:`directional_albedo`
      against :func:`fitlab.families.lambert_sphere.exact.albedo`, same phase);
    * "albedo_c1_max", "albedo_c1_min": the model's directional albedo at c = 1, max and min over
      ``albedo_mu`` (default: 1e-3, then 0.05 ... 1 in steps of 0.05).

    The exact values are computed once per machine (:func:`accuracy_reference`).
    """
    pts = accuracy_points(seed, n)
    ref = accuracy_reference(seed, n, phase, albedo_c, albedo_mu)
    out = {}
    for name, p in pts.items():
        rel = _rel(model(p["mu_i"], p["mu_o"], p["phi"], p["c"]), ref[name])
        rel = np.where(np.isnan(rel), np.inf, rel)
        k = int(np.argmax(rel))
        worst = {n_: float(v[k]) for n_, v in p.items()}
        if name == "main":
            out.update(max=float(rel.max()), rms=float(np.sqrt(np.mean(rel**2))), worst=worst)
            zero = model(p["mu_i"], p["mu_o"], p["phi"], np.zeros_like(p["c"]))
            out["max_c0"] = float(np.max(np.abs(zero)))
        else:
            out.update(max_grazing=float(rel.max()), worst_grazing=worst)
    mu = _albedo_mu(albedo_mu)
    err, c1 = 0.0, None
    for k, cv in enumerate(albedo_c):
        a = directional_albedo(model, mu, cv)
        err = max(err, float(np.max(np.abs(a - ref["albedo"][k]))))
        if cv == 1.0:
            c1 = a
    out["albedo_err"] = err
    if c1 is not None:
        out.update(albedo_c1_max=float(c1.max()), albedo_c1_min=float(c1.min()))
    return out


#: the figures of :func:`accuracy` that :func:`model_accuracy` keeps (the worst points by their coordinates)
_KEPT = ("max", "rms", "max_grazing", "max_c0", "albedo_err", "albedo_c1_min", "albedo_c1_max")


def model_accuracy(parts: dict, terms=RUNTIME_TERMS, use_cache: bool = True) -> dict:
    """:func:`accuracy` (against the true BRDF, the default seed and sets) of the fitted runtime model made of
    ``parts`` ({part: expression with numbers}), the ``terms`` kept and its energy scale, as the generated code
    evaluates it (:func:`assembled`), with "points" and "grazing_points" (the sets' sizes) and "worst" (the main
    set's worst point).  Kept in fitlab's cache (``use_cache`` False: measured afresh), keyed by the parts'
    expressions, the terms, the numpy and sympy versions and the code that measures it (the exact engine, the
    family's forms and this module), as :func:`energy_scale` is."""
    from fitlab.cache import cached_arrays

    items = tuple(sorted(parts.items()))
    terms = tuple(terms)

    def compute():
        functions = {p: lambdify_numpy(symbols(get_target(p).inputs), e) for p, e in items}
        model = assembled(functions, energy_scale(dict(items), terms), terms)
        figures = accuracy(model)
        pts = accuracy_points()
        worst = figures["worst"]
        return {**{k: np.float64(figures[k]) for k in _KEPT},
                "points": np.int64(pts["main"]["c"].size), "grazing_points": np.int64(pts["grazing"]["c"].size),
                "worst": np.array([worst[k] for k in INPUTS])}  # fmt: skip

    key = {"parts": [[p, sp.srepr(e)] for p, e in items], "terms": list(terms), "numpy": np.__version__,
           "sympy": sp.__version__}  # fmt: skip
    arrays = cached_arrays(f"{FAMILY_NAME}-model-accuracy", key, compute, (*_KEPT, "points", "grazing_points", "worst"),
                           _energy_sources(), use_cache)  # fmt: skip
    out = {k: float(arrays[k]) for k in _KEPT}
    out.update(points=int(arrays["points"]), grazing_points=int(arrays["grazing_points"]),
               worst=dict(zip(INPUTS, (float(x) for x in arrays["worst"]))))  # fmt: skip
    return out
