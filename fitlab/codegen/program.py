r"""The language-neutral program that every back end prints.

A :class:`Routine` is one generated function: scalar arguments, one sympy
expression, a docstring.  Expressions call other routines through undefined
sympy functions (``h0(mu_i, c)``), so that the runtime BRDF reads as the sum
of its terms and each part is evaluated once per call.  Everything here comes
from the saved fits (fits/*.json: the numbers) and from :mod:`fitlab.forms`
(the maths): no formula is written per language.

Routines (args; domain):

* ``h0, h1 (mu, c)``, ``const_l, const_m, const_b, const_c, const_d, const_f (c)``,
  ``c_of_kd (kd)``, ``kd_of_c (c)``: the fitted parts on their own; mu, c, kd in [0, 1].
* ``single, fm0, fm1`` and ``brdf (mu_i, mu_o, cos_phi, c)``: the runtime model of
  SPEC 5, f_r = max(0, f_1 + fm0 + fm1 cos phi) (only the terms asked for).
* ``brdf_fast (mu_i, mu_o, cos_phi, c, kd)``: the fast variant, eq. 41.
* ``brdf_local, brdf_fast_local (wi, wo, c[, kd])``: the same for unit vectors in the
  local frame (z the normal, both pointing away from the surface); 0 when either
  points below the surface.

Robustness (every value finite for finite inputs): the entry points clamp
mu, c, kd into [0, 1] and cos_phi into [-1, 1]; every pole 1/(mu_i + mu_o) is
evaluated as 1/max(mu_i + mu_o, POLE_FLOOR).  The exact BRDF is infinite at
mu_i = mu_o = 0; with the floor the model there is large and finite
(c p(u) / POLE_FLOOR at most 2.1e5 c, representable in float).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import sympy as sp

from fitlab.families.lambert_sphere.forms import RUNTIME_PARTS, RUNTIME_TERMS, runtime_terms
from fitlab.families.lambert_sphere.forms.brdf import SINGLE
from fitlab.forms.symbolic import safe_pow, symbols
from sympy.codegen.cfunctions import expm1, log1p

__all__ = ["Routine", "Program", "build_program", "POLE_FLOOR", "parse_terms"]

#: mu_i + mu_o is floored at this value wherever it divides
POLE_FLOOR = sp.Rational(1, 10**6)

mu_i, mu_o, phi, c, kd, mu, cos_phi = symbols(("mu_i", "mu_o", "phi", "c", "kd", "mu", "cos_phi"))
_VEC = {v: symbols(tuple(f"{v}_{k}" for k in "xyz")) for v in ("wi", "wo")}

#: routine name of each fitted part
PART_ROUTINES = {"H0": "h0", "H1": "h1", "l": "const_l", "m": "const_m", "B": "const_b", "C": "const_c",
                 "D": "const_d", "F": "const_f", "c_of_kd": "c_of_kd", "kd_of_c": "kd_of_c"}  # fmt: skip


@dataclass(frozen=True)
class Routine:
    """One generated function: ``name(args) = expr``.

    args: scalar argument names, in order; ``vectors`` groups consecutive ones
    into a 3-vector argument (name -> its three component names).
    """

    name: str
    args: tuple[str, ...]
    expr: sp.Expr
    doc: str
    vectors: dict = field(default_factory=dict)

    def signature(self) -> tuple[str, ...]:
        """Arguments as the caller passes them: vectors as one argument."""
        out, seen = [], set()
        for a in self.args:
            owner = next((v for v, comps in self.vectors.items() if a in comps), None)
            if owner is None:
                out.append(a)
            elif owner not in seen:
                seen.add(owner)
                out.append(owner)
        return tuple(out)


@dataclass(frozen=True)
class Program:
    routines: tuple[Routine, ...]
    sources: tuple[tuple[str, str], ...]  # (fit file, sha256 of its bytes)
    terms: tuple[str, ...]

    def routine(self, name: str) -> Routine:
        return next(r for r in self.routines if r.name == name)


def call(name: str, *args) -> sp.Expr:
    return sp.Function(name)(*args)


def _floor_poles(expr: sp.Expr) -> sp.Expr:
    """1/(mu_i + mu_o)^k -> 1/max(mu_i + mu_o, POLE_FLOOR)^k."""
    pole = mu_i + mu_o
    return expr.replace(
        lambda e: e.is_Pow and e.base == pole and e.exp.is_negative,
        lambda e: sp.Pow(sp.Max(pole, POLE_FLOOR), e.exp),
    )


def _azimuth_to_cosine(expr: sp.Expr) -> sp.Expr:
    """Forms take phi in [-pi, pi]; routines take cos(phi): |phi| = acos(cos phi)."""
    out = expr.subs({sp.cos(phi): cos_phi, sp.Abs(phi): sp.acos(cos_phi)})
    if phi in out.free_symbols:
        raise ValueError(f"cannot express {expr} through cos(phi) alone")
    return out


def _stable(expr: sp.Expr) -> sp.Expr:
    """Rewrite the cancellations the forms contain into forms that keep every digit.

    * 1 - sqrt(1 - c) -> c / (1 + sqrt(1 - c)): the exact zero at c = 0 of B-F and
      kd(c); written directly it loses all relative accuracy as c -> 0 (float:
      1 % at c = 1e-5).
    * 1 - (1 - x)^p -> -expm1(p log1p(-x)) for x < 1/2 (the exact zero of c(kd)
      at kd = 0); for x >= 1/2 there is no cancellation and (1 - x)^p stays.
    """
    s = sp.sqrt(1 - c)
    expr = expr.subs(1 - s, c / (1 + s))

    def is_one_minus_pow(e):
        if not (e.is_Add and len(e.args) == 2 and sp.S.One in e.args):
            return False
        other = next(a for a in e.args if a != sp.S.One)
        coeff, rest = other.as_coeff_Mul()
        return float(coeff) == -1.0 and isinstance(rest, safe_pow) and rest.args[0].is_Add and sp.S.One in rest.args[0].args

    def rewrite(e):
        other = next(a for a in e.args if a != sp.S.One)
        base, p = other.as_coeff_Mul()[1].args
        x = 1 - base
        small = -expm1(p * log1p(-sp.Min(x, sp.Rational(1, 2))))
        return sp.Piecewise((small, x < sp.Rational(1, 2)), (e, True))

    return expr.replace(is_one_minus_pow, rewrite)


def _clamped(*names_and_bounds):
    return {s: sp.Min(hi, sp.Max(lo, s)) for s, lo, hi in names_and_bounds}


def parse_terms(text: str | None) -> tuple[str, ...]:
    """'single,m0' -> ('single', 'm0'), in model order; None -> all terms."""
    if text is None:
        return RUNTIME_TERMS
    asked = [t.strip() for t in text.split(",") if t.strip()]
    unknown = [t for t in asked if t not in RUNTIME_TERMS]
    if unknown or not asked:
        raise ValueError(f"--terms takes a comma-separated subset of {', '.join(RUNTIME_TERMS)}; got {text!r}")
    return tuple(t for t in RUNTIME_TERMS if t in asked)


def _sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def build_program(fits_dir: Path, terms: tuple[str, ...] = RUNTIME_TERMS, forms: dict | None = None) -> Program:
    """Routines of the runtime BRDF from the fits in ``fits_dir``.

    ``forms`` picks a non-default form per target (as ``fitlab refit --form``);
    each file must exist (FitFileError otherwise).
    """
    from fitlab.store import fit_path
    from fitlab.core import get_target
    from fitlab.store import load

    fits_dir = Path(fits_dir)
    routines, sources = [], []

    def fitted(target):
        form = (forms or {}).get(target, get_target(target).default_form)
        path = fit_path(fits_dir, target, form)
        fit = load(path)
        sources.append((path.as_posix(), _sha256(path)))
        return fit

    for target, name in PART_ROUTINES.items():
        fit = fitted(target)
        desc = fit.record.get("target_description", target)
        val = fit.record["validation"]
        doc = (f"{desc}; form {fit.form}: {fit.record.get('form_description', '')} "
               f"Validation: max relative error {val['max_rel']:.2e}, RMS {val['rms_rel']:.2e}.")  # fmt: skip
        routines.append(Routine(name, fit.inputs, _stable(fit.expression), doc))

    clamp4 = _clamped((mu_i, 0, 1), (mu_o, 0, 1), (cos_phi, -1, 1), (c, 0, 1))
    parts = {p: call(PART_ROUTINES[p], mu, c) if p in ("H0", "H1") else call(PART_ROUTINES[p], c) for p in RUNTIME_PARTS}
    term_exprs = runtime_terms(parts)
    term_docs = {
        "single": "Single scattering with the true phase function, c p(u)/(mu_i + mu_o), u = -(mu_i mu_o + S cos phi) (eq. 10).",
        "m0": "Multiple scattering, Fourier order 0: fm0 = (H0 H0 Q/(2 pi) - n0_ss)/(mu_i + mu_o) (eqs. 30, 38).",
        "m1": "Multiple scattering, Fourier order 1 (coefficient of cos phi): fm1 of eq. 22 minus its single "
              "scattering, exact normalisations 3 pi and 192 pi (docs/errata.md).",
    }  # fmt: skip
    term_args = {"single": ("mu_i", "mu_o", "cos_phi", "c"), "m0": ("mu_i", "mu_o", "c"), "m1": ("mu_i", "mu_o", "c")}
    term_names = {"single": "single", "m0": "fm0", "m1": "fm1"}
    total = sp.S.Zero
    for t in terms:
        expr = _floor_poles(_azimuth_to_cosine(term_exprs[t]))
        routines.append(Routine(term_names[t], term_args[t], expr, term_docs[t] + " Pole floored at 1e-6."))
        args = [clamp4.get(s, s) for s in symbols(term_args[t])]
        total += call(term_names[t], *args) * (clamp4[cos_phi] if t == "m1" else 1)
    routines.append(Routine(
        "brdf", ("mu_i", "mu_o", "cos_phi", "c"), sp.Max(0, total),
        f"The runtime Lambert-sphere BRDF (1/sr), max(0, {' + '.join(term_names[t] + (' cos phi' if t == 'm1' else '') for t in terms)}) "
        "(SPEC 5). mu_i, mu_o in [0, 1], cos_phi in [-1, 1] (phi = 0 back-scattering), c the particle "
        "albedo in [0, 1]; inputs outside are clamped.",
    ))  # fmt: skip

    fast = fitted("fast_brdf")
    single_call = call("single", mu_i, mu_o, cos_phi, c) if "single" in terms else None
    fast_expr = _floor_poles(_azimuth_to_cosine(fast.expression))
    if single_call is not None:
        fast_expr = fast_expr.subs(_floor_poles(_azimuth_to_cosine(SINGLE)), single_call)
    clamp5 = {**clamp4, **_clamped((kd, 0, 1))}
    routines.append(Routine(
        "brdf_fast", ("mu_i", "mu_o", "cos_phi", "c", "kd"), fast_expr.xreplace(clamp5),
        ("The fast variant of the Lambert-sphere BRDF (eq. 41, refitted): max(0, f_1 + lobe(|phi|) + p4 kd^p5); "
         if fast.form == get_target("fast_brdf").default_form else
         f"A fast model of the Lambert-sphere BRDF, form {fast.form}: {fast.record.get('form_description', '')} ")
        + "kd = kd_of_c(c). Same domain as brdf, kd in [0, 1].",
    ))  # fmt: skip

    # local frame: u = -wi.wo, mu = z, S cos phi = x_i x_o + y_i y_o
    (xi, yi, zi), (xo, yo, zo) = _VEC["wi"], _VEC["wo"]
    ring = (xi**2 + yi**2) * (xo**2 + yo**2)
    local_cos = (xi * xo + yi * yo) / sp.sqrt(sp.Max(ring, sp.Rational(1, 10**30)))
    below = sp.Or(zi < 0, zo < 0)
    vec_args = tuple(str(s) for s in (*_VEC["wi"], *_VEC["wo"]))
    vectors = {"wi": tuple(str(s) for s in _VEC["wi"]), "wo": tuple(str(s) for s in _VEC["wo"])}
    for name, extra in (("brdf", ()), ("brdf_fast", ("kd",))):
        inner = call(name, zi, zo, local_cos, c, *symbols(extra))
        routines.append(Routine(
            f"{name}_local", (*vec_args, "c", *extra), sp.Piecewise((0, below), (inner, True)),
            f"{name} for unit vectors wi, wo in the local frame (z along the normal, both pointing away "
            "from the surface); 0 if either is below the surface.",
            vectors,
        ))  # fmt: skip
    return Program(tuple(routines), tuple(sources), tuple(terms))
