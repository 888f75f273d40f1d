r"""The Lambert-sphere family's generated program: the runtime BRDF assembled from its fitted parts.

Registered as the family's ``codegen`` (:data:`PROGRAM`, a
:class:`fitlab.codegen.ProgramSpec`); :func:`fitlab.codegen.build_program` calls
it with the fits ({target: FitFunction}) and the terms kept.  docs/model.md
states the model.

Routines (args; domain), named by the targets' ``routine``:

* ``h0, h1, h2 (mu, c)``, ``const_l, const_m, const_b, const_c, const_d, const_f (c)``,
  ``c_of_kd (kd)``, ``kd_of_c (c)``: the fitted parts on their own; mu, c, kd in [0, 1].
* ``single, fm0, fm1, fm2`` and ``brdf (mu_i, mu_o, cos_phi, c)``: the runtime model
  (docs/model.md), f_r = max(0, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi) (only the terms asked for;
  ``--terms single,m0,m1`` is the paper's model).
* ``brdf_fast (mu_i, mu_o, cos_phi, c, kd)``: the fast variant, eq. 41 (the fit of ``fast_brdf``).
* ``brdf_local, brdf_fast_local (wi, wo, c[, kd])``: the same for unit vectors in the
  local frame (z the normal, both pointing away from the surface); 0 when either
  points below the surface.

Details: docs/codegen.md, section ``fitlab.families.lambert_sphere.program.spec``."""

from __future__ import annotations

from collections.abc import Mapping

import sympy as sp

from fitlab.codegen import Claim, MaterialSpec, Model, ProgramSpec, Routine, call, part_routine
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, RUNTIME_TERMS, SINGLE, runtime_terms
from fitlab.families.lambert_sphere.forms.brdf import parts_in_algebra
from fitlab.families.lambert_sphere.program.rewrites import REWRITES, azimuth_to_cosine, floor_poles, stable
from fitlab.families.lambert_sphere.program.runtime import (
    ALBEDOS,
    ORDER2_FORMS,
    TRUE_FORMS,
    energy_scale,
    model_accuracy,
)
from fitlab.families.lambert_sphere.targets import TARGETS, THREE_TERM, TRUE
from fitlab.forms.symbolic import safe_pow, symbols
from fitlab.store import FitFunction

__all__ = [
    "PROGRAM",
    "PARTS",
    "FAST",
    "SAMPLER",
    "DOMAIN",
    "MODEL_PARTS",
    "TRUE_MODEL",
    "THREE_TERM_MODEL",
    "routines",
    "brdf_routines",
    "local_routine",
    "claim",
]

mu_i, mu_o, c, kd, cos_phi = symbols(("mu_i", "mu_o", "c", "kd", "cos_phi"))
_VEC = {v: symbols(tuple(f"{v}_{k}" for k in "xyz")) for v in ("wi", "wo")}

#: the target whose fit is the fast variant (routine brdf_fast)
FAST = "fast_brdf"

#: the sampler's parts: a program without them (a published preset's) has no sample and pdf routines
SAMPLER = ("sample_weight", "sample_exponent")

#: the targets printed as routines of their own, in the order of the generated files
PARTS = ("H0", "H1", "H2", "l", "m", "B", "C", "D", "F", "c_of_kd", "kd_of_c", "sample_weight", "sample_exponent")

_TERM_DOCS = {
    "single": "Single scattering with the true phase function, c p(u)/(mu_i + mu_o), u = -(mu_i mu_o + S cos phi) (eq. 10), "
              "p evaluated from 1 - u = (1 - S^2)/(1 + S) + mu_i mu_o + S (1 + cos phi) and x = acos(u) = 2 asin(sqrt((1 - u)/2)), "
              "sin x - x cos x by its series below x = 0.505, (1 - u)/2 < 1/16 (full accuracy in forward scattering at grazing, float included).",
    "m0": "Multiple scattering, Fourier order 0: fm0 = (H0 H0 Q/(2 pi) - n0_ss)/(mu_i + mu_o) (eqs. 30, 38), "
          "evaluated as ((H0 H0 - 1) Q + (Q - Q_ss))/(2 pi (mu_i + mu_o)), Q_ss = 2 pi n0_ss, without cancellation "
          "at grazing and small c.",
    "m1": "Multiple scattering, Fourier order 1 (coefficient of cos phi): fm1 of eq. 22 minus its single "
          "scattering, exact normalisations 3 pi and 192 pi (docs/errata.md), evaluated as "
          "c S ((H1 H1 - 1) G + (G - G_ss))/(3 pi (mu_i + mu_o)) without cancellation at grazing and small c.",
    "m2": "Multiple scattering, Fourier order 2 (coefficient of cos 2phi), which the paper drops (eq. 21): "
          "fm2 = 15 c S^2 (H2(mu_i) H2(mu_o) - 1)/(256 pi (mu_i + mu_o)) (docs/model.md, 'Order 2').",
}  # fmt: skip
_TERM_ARGS = {"single": ("mu_i", "mu_o", "cos_phi", "c"), "m0": ("mu_i", "mu_o", "c"), "m1": ("mu_i", "mu_o", "c"),
              "m2": ("mu_i", "mu_o", "c")}  # fmt: skip
_TERM_NAMES = {"single": "single", "m0": "fm0", "m1": "fm1", "m2": "fm2"}
#: each term's azimuthal factor in terms of cos phi (cos 2phi = 2 cos^2 phi - 1)
_TERM_AZIMUTH = {"single": sp.S.One, "m0": sp.S.One, "m1": cos_phi, "m2": 2 * cos_phi**2 - 1}
_AZIMUTH_TEXT = {"single": "", "m0": "", "m1": " cos phi", "m2": " cos 2phi"}


#: the domain of every scalar input of the composed routines (the parts take their targets' domains)
DOMAIN = {"mu_i": (0.0, 1.0), "mu_o": (0.0, 1.0), "cos_phi": (-1.0, 1.0), "c": (0.0, 1.0), "kd": (0.0, 1.0)}


def _domain(names) -> dict:
    return {n: DOMAIN[n] for n in names}


def routines(fits: Mapping[str, FitFunction], terms: tuple[str, ...]) -> list[Routine]:
    """Every routine of the generated Lambert-sphere files, in file order."""
    out = [part_routine(fits[t], REWRITES) for t in PARTS if t in fits]

    parts = {p: fits[p].expression for p in (*RUNTIME_PARTS, ORDER2_PART)}
    out += brdf_routines(terms, energy_scale(parts, terms), parts=parts)

    fast = fits[FAST]
    fast_expr = floor_poles(azimuth_to_cosine(fast.expression))
    if "single" in terms:
        fast_expr = fast_expr.subs(floor_poles(azimuth_to_cosine(SINGLE)), call("single", mu_i, mu_o, cos_phi, c))
    out.append(Routine(
        TARGETS[FAST].routine, ("mu_i", "mu_o", "cos_phi", "c", "kd"), stable(fast_expr),
        ("The fast variant of the Lambert-sphere BRDF (eq. 41, refitted): max(0, f_1 + lobe(|phi|) + p4 kd^p5); "
         if fast.form == TARGETS[FAST].default_form else
         f"A fast model of the Lambert-sphere BRDF, form {fast.form}: {fast.record.get('form_description', '')} ")
        + f"kd = {TARGETS['kd_of_c'].routine}(c). Same domain and policy as brdf, kd in [0, 1].",
        domain=_domain(("mu_i", "mu_o", "cos_phi", "c", "kd")),
    ))  # fmt: skip

    out += [local_routine(name, extra) for name, extra in (("brdf", ()), (TARGETS[FAST].routine, ("kd",)))]
    vec_args = tuple(str(s) for s in (*_VEC["wi"], *_VEC["wo"]))
    vectors = {"wi": tuple(str(s) for s in _VEC["wi"]), "wo": tuple(str(s) for s in _VEC["wo"])}
    if all(t in fits for t in SAMPLER):
        out += _sampling_routines(vectors, vec_args)
    return out


def brdf_routines(terms: tuple[str, ...], scale=1, what: str = "The runtime Lambert-sphere BRDF",
                  parts: Mapping[str, sp.Expr] | None = None,
                  correction: sp.Expr | None = None) -> list[Routine]:  # fmt: skip
    """The routines of the terms kept (single, fm0, fm1, fm2: :data:`RUNTIME_TERMS` order) and ``brdf``, their
    sum clamped at 0 (times the energy ``scale`` unless it is 1), each term calling the parts' routines by
    the targets' routine names (h0, ..., const_f); ``what`` opens brdf's documentation.

    ``parts``: the parts' expressions (in their targets' inputs), where the caller has them: those whose form
    lets the terms subtract without cancellation (:func:`~fitlab.families.lambert_sphere.forms.brdf.parts_in_algebra`:
    H_i H_o - 1 as expm1 of the sum of the exponents, X - X1 c in the algebra) are inlined in the terms, the
    others called.

    ``correction``: a call Q(mu_i, mu_o, cos_phi, c) of a routine that corrects the orders to another phase
    function relative to fm0, Q = sum_m Q_m cos(m phi): brdf adds fm0 Q to the sum (the exported tables' orders
    fm_m + Q_m fm0); fm0 must be among the terms."""
    calls = {p: call(TARGETS[p].routine, *symbols(TARGETS[p].inputs)) for p in (*RUNTIME_PARTS, ORDER2_PART)}
    inlined = {} if parts is None else {p: parts[p] for p in parts_in_algebra(parts)}
    term_exprs = runtime_terms({**calls, **inlined})
    out, total = [], sp.S.Zero
    for t in terms:
        expr = stable(floor_poles(azimuth_to_cosine(term_exprs[t])))
        out.append(Routine(_TERM_NAMES[t], _TERM_ARGS[t], expr, _TERM_DOCS[t] + " Pole floored at 1e-6.",
                           domain=_domain(_TERM_ARGS[t])))  # fmt: skip
        total += call(_TERM_NAMES[t], *symbols(_TERM_ARGS[t])) * _TERM_AZIMUTH[t]
    sum_text = " + ".join(_TERM_NAMES[t] + _AZIMUTH_TEXT[t] for t in terms)
    if correction is not None:
        if "m0" not in terms:
            raise ValueError("a correction relative to fm0 needs the term m0")
        total += call(_TERM_NAMES["m0"], *symbols(_TERM_ARGS["m0"])) * correction
        sum_text += f" + fm0 {correction.func.__name__}"
    out.append(Routine(
        "brdf", ("mu_i", "mu_o", "cos_phi", "c"), sp.Max(0, total if scale == 1 else sp.Mul(scale, total, evaluate=False)),
        f"{what} (1/sr), max(0, {sum_text if scale == 1 else f's ({sum_text})'}) "
        + ("" if scale == 1 else f"with the energy scale s = {float(scale)!r}, which keeps the directional albedo "
           "at c = 1 below 1 ") + "(docs/model.md). mu_i, mu_o in [0, 1], cos_phi in [-1, 1] (phi = 0 back-scattering), c the particle "
        "albedo in [0, 1]; inputs outside (+-inf included) are clamped, NaN in any input gives NaN.",
        domain=_domain(("mu_i", "mu_o", "cos_phi", "c")),
        # the terms in its body: they share the clamped inputs, each direction's log(1 + 1/mu) and sqrt(1 - c)
        inline=True,
    ))  # fmt: skip
    return out


def local_routine(name: str, extra: tuple[str, ...] = ()) -> Routine:
    """``NAME_local(wi, wo, c, *extra)``: the routine ``name(mu_i, mu_o, cos_phi, c, *extra)`` for unit vectors in
    the local frame (u = -wi.wo, mu = z, S cos phi = x_i x_o + y_i y_o), 0 below the surface."""
    (xi, yi, zi), (xo, yo, zo) = _VEC["wi"], _VEC["wo"]
    ring = (xi**2 + yi**2) * (xo**2 + yo**2)
    local_cos = (xi * xo + yi * yo) / sp.sqrt(sp.Max(ring, sp.Rational(1, 10**30)))
    # 0 below the surface as a factor, not a branch: a NaN anywhere still reaches the result
    above = sp.Piecewise((0, zi < 0), (1, True)) * sp.Piecewise((0, zo < 0), (1, True))
    vec_args = tuple(str(s) for s in (*_VEC["wi"], *_VEC["wo"]))
    vectors = {"wi": tuple(str(s) for s in _VEC["wi"]), "wo": tuple(str(s) for s in _VEC["wo"])}
    inner = call(name, zi, zo, local_cos, c, *symbols(extra))
    return Routine(
        f"{name}_local", (*vec_args, "c", *extra), above * inner,
        f"{name} for unit vectors wi, wo in the local frame (z along the normal, both pointing away "
        "from the surface); 0 if either is below the surface. Components are clamped to [-1, 1] "
        "(not normalised); NaN in any input gives NaN.",
        vectors, domain={**{a: (-1.0, 1.0) for a in vec_args}, **_domain(("c", *extra))},
    )  # fmt: skip


def _sampling_routines(vectors: dict, vec_args: tuple) -> list[Routine]:
    r"""pdf_local(wi, wo, c) and sample_local(wi, u1, u2, c): the mixture of
    :mod:`fitlab.families.lambert_sphere.exact.sampling` with its fitted weight and exponent,
    p = (1 - w) mu_o/pi + w (n + 1)/(2 pi) max(0, wi.wo)^n above the surface.

    sample_local draws the lobe when u1 < w (u1/w reused as its uniform number), the cosine lobe
    otherwise ((u1 - w)/(1 - w)); the back-scatter lobe is drawn about wi in the frame of Duff et al.
    (2017), cos theta = v^(1/(n+1)); a direction below the surface has pdf 0 (a lost sample)."""
    (xi, yi, zi), (xo, yo, zo) = _VEC["wi"], _VEC["wo"]
    u1, u2 = symbols(("u1", "u2"))
    w, n = call("sample_weight", zi, c), call("sample_exponent", zi, c)
    above_i = sp.Piecewise((0, zi < 0), (1, True))

    def density(ox, oy, oz, below):
        dot = xi * ox + yi * oy + zi * oz
        mixture = (1 - w) * sp.Max(oz, 0) / sp.pi + w * (n + 1) / (2 * sp.pi) * safe_pow(dot, n)
        return above_i * sp.Piecewise((0, below), (1, True)) * mixture

    out = [Routine(
        "pdf_local", (*vec_args, "c"), density(xo, yo, zo, zo < 0),
        "The density (1/sr) with which sample_local draws wo given wi, for unit vectors in the local frame: "
        "(1 - w) mu_o/pi + w (n + 1)/(2 pi) max(0, wi.wo)^n, w = sample_weight(mu_i, c), n = sample_exponent(mu_i, c), "
        "a cosine lobe mixed with a back-scatter lobe fitted to f_r cos(theta_o) (docs/model.md, 'Importance sampling'); "
        "0 if either vector is below the surface. Components are clamped to [-1, 1]; NaN in any input gives NaN.",
        vectors, domain={**{a: (-1.0, 1.0) for a in vec_args}, **_domain(("c",))},
    )]  # fmt: skip
    # the back-scatter lobe about wi, in the frame (t, b, wi) of Duff et al. 2017 (wi above the surface)
    z = sp.Max(zi, 0)
    a = -1 / (1 + z)
    t = (1 + xi**2 * a, xi * yi * a, -xi)
    b = (xi * yi * a, 1 + yi**2 * a, -yi)
    angle = 2 * sp.pi * u2
    v = u1 / w
    cos_t = safe_pow(v, 1 / (n + 1))
    sin_t = sp.sqrt(sp.Max(1 - cos_t**2, 0))
    lobe = [
        sin_t * sp.cos(angle) * tk + sin_t * sp.sin(angle) * bk + cos_t * wk for tk, bk, wk in zip(t, b, (xi, yi, zi))
    ]
    # the cosine lobe about the normal (Malley's method)
    v = sp.Max((u1 - w) / (1 - w), 0)
    r = sp.sqrt(v)
    cosine = [r * sp.cos(angle), r * sp.sin(angle), sp.sqrt(sp.Max(1 - v, 0))]
    wo = [sp.Piecewise((lk, u1 < w), (ck, True)) for lk, ck in zip(lobe, cosine)]
    out.append(Routine(
        "sample_local", (*(str(x) for x in _VEC["wi"]), "u1", "u2", "c"),
        # below the surface only from the back-scatter lobe (the condition on the branch, not on wo: sympy
        # would fold a condition on a conditional into an if-then-else of conditions)
        sp.Tuple(density(*wo, sp.And(u1 < w, lobe[2] < 0)), *wo),
        "Importance sampling of brdf_local: draws wo (written to wo) for the unit vector wi in the local frame and two "
        "uniform numbers u1, u2 in [0, 1), and returns its density pdf_local(wi, wo) (1/sr); the sample weight is "
        "brdf_local(wi, wo, c) wo.z / pdf. pdf 0 marks a lost sample (wo below the surface, or wi below it). "
        "Components of wi are clamped to [-1, 1], u1, u2 to [0, 1]; NaN in any input gives NaN.",
        {"wi": vectors["wi"]}, domain={**{str(x): (-1.0, 1.0) for x in _VEC["wi"]}, "u1": (0.0, 1.0), "u2": (0.0, 1.0),
                                       **_domain(("c",))}, out="wo",
    ))  # fmt: skip
    return out


#: the parts that make the runtime model together: one model's are fitted to one physics
MODEL_PARTS = (*RUNTIME_PARTS, ORDER2_PART)
#: the program's models (:data:`PROGRAM`): every part fitted to the true BRDF (the default), or to its own
#: three-term target
TRUE_MODEL, THREE_TERM_MODEL = "true", "three-term"


def claim(fits: Mapping[str, FitFunction], terms: tuple[str, ...]) -> Claim:
    """The runtime model of ``fits`` and ``terms`` measured against the true BRDF
    (:func:`.runtime.model_accuracy`: :func:`.runtime.accuracy`'s sets), stated in the banner and in the
    documentation of brdf and brdf_local."""
    a = model_accuracy({p: fits[p].expression for p in MODEL_PARTS}, terms)
    c_lo = min(ALBEDOS)
    main = (
        f"max {a['max']:.2e}, RMS {a['rms']:.2e} relative over mu_i, mu_o in [0.01, 1], c in [{c_lo:g}, 1], "
        f"every phi ({a['points']} points)"
    )
    grazing = f"max {a['max_grazing']:.2e} down to mu_i, mu_o = 1e-6 ({a['grazing_points']} points)"
    zero = "exactly 0 at c = 0" if a["max_c0"] == 0.0 else f"at most {a['max_c0']:.2e} at c = 0"
    albedo = f"directional albedo at c = 1 from {a['albedo_c1_min']:.6f} to {a['albedo_c1_max']:.6f}"
    worst = ", ".join(f"{k} = {v:.4g}" for k, v in a["worst"].items())
    sentence = (
        f"Against the true BRDF (the whole phase function), as fitlab codegen measured it: {main}; "
        f"{grazing}; {zero}; {albedo}."
    )
    lines = (
        "Accuracy of brdf against the true BRDF (exact.brdf, phase 'true': the whole phase function in every "
        "collision), measured by fitlab codegen:",
        f"  {main}, worst at {worst};",
        f"  {grazing}; {zero};",
        f"  {albedo}.",
    )
    return Claim(lines, {"brdf": sentence, "brdf_local": sentence})


PROGRAM = ProgramSpec(
    name="lambert_sphere",
    fits=(*PARTS, FAST),
    parts=PARTS,
    routines=routines,
    terms=RUNTIME_TERMS,
    models=(
        Model(TRUE_MODEL, TRUE_FORMS, "the most accurate model at its cost: orders 0, 1 and 2 of multiple scattering, "
                                    "every part fitted to the true BRDF", folder="true", physics=TRUE),
        Model(THREE_TERM_MODEL, ORDER2_FORMS, "the same structure and forms, each part fitted to its own target, the "
                                          "three-term half space's quantity", physics=THREE_TERM),
    ),
    default_model=TRUE_MODEL,
    physics_parts=MODEL_PARTS,
    claim=claim,
    optional=SAMPLER,
    rewrites=REWRITES,
    material=MaterialSpec(("c",), {"eval": "brdf", "eval_local": "brdf_local", "pdf": "pdf_local", "sample": "sample_local"},
                          {"prepare": ("kd", "c_of_kd")}),
    about="The Lambert-sphere BRDF (d'Eon, EGSR 2021): the runtime model of docs/model.md and its fitted parts.\n"
          "Terms of brdf: {terms}",
    doc="The Lambert-sphere BRDF (d'Eon, EGSR 2021), generated by fitlab: numpy only.\n\n"
        "Every function takes numpy arrays (any broadcastable shapes; vectors have a\n"
        "last axis of 3) and returns an array of float64.  brdf(mu_i, mu_o, cos_phi, c)\n"
        "is the runtime model; brdf_local(wi, wo, c) the same for local-frame vectors.\n",
)  # fmt: skip
