r"""BRDF-level forms: single scattering, the fast fm1 (eq. 29), the fast
variant of the whole BRDF (eq. 41), and the runtime model (docs/model.md,
"The runtime BRDF") assembled
from the forms of H0, H1 and the constants.

Conventions (docs/model.md, "Conventions"): mu_i, mu_o in [0, 1], phi the
relative azimuth with
phi = 0 back-scattering, S = sqrt((1 - mu_i^2)(1 - mu_o^2)), f in 1/sr.  Every
term has the pole 1/(mu_i + mu_o); at mu_i = mu_o = 0 the exact BRDF is
infinite, and these expressions are not meant to be evaluated there.
"""

from __future__ import annotations

from typing import Mapping

import sympy as sp

from fitlab.families.lambert_sphere.forms.constants import A_EXACT, E_EXACT
from fitlab.forms.form import Form
from fitlab.forms.symbolic import safe_pow, symbols

mu_i, mu_o, phi, c, kd, mu = symbols(("mu_i", "mu_o", "phi", "c", "kd", "mu"))
S = sp.sqrt((1 - mu_i**2) * (1 - mu_o**2))
PI = sp.pi

# scattering cosine, clamped so that rounding never takes it outside [-1, 1]
_u = sp.Max(-1, sp.Min(1, -(mu_i * mu_o + S * sp.cos(phi))))
#: Lambert-sphere phase function p(u) (docs/model.md, "Phase function")
PHASE = 2 * (sp.sqrt(sp.Max(0, 1 - _u**2)) - _u * sp.acos(_u)) / (3 * PI**2)
#: exact single scattering with the true phase function (eq. 10)
SINGLE = c * PHASE / (mu_i + mu_o)

#: (mu_i + mu_o) times the three-term single scattering of orders 0 and 1
#: (eq. 38 and eq. 28 with 192 pi; docs/errata.md)
_P, _Q = mu_i * mu_o, mu_i**2 + mu_o**2
SINGLE_NUMERATOR_0 = c * (207 + 256 * _P - 45 * _Q + 135 * _P**2) / (768 * PI)
SINGLE_NUMERATOR_1 = c * S * (64 + 45 * _P) / (192 * PI)

#: normalisations of eqs. 22 and 28: as the exact solution has them, and as printed
NORMALISATIONS = {"corrected": (3, 1), "printed": (6, 2)}


def _fm1_fast() -> Form:
    (k,) = symbols(("k",))
    return Form(
        target="fm1",
        name="fast",
        inputs=("mu_i", "mu_o", "c"),
        params=("k",),
        expr=-k * c * sp.atan(c) * S * sp.sqrt(sp.tanh(mu_i + mu_i * mu_o + mu_o)) / (mu_i + mu_o),
        presets={"paper": dict(k=0.0117)},
        description="fm1 ~ -k c atan(c) S sqrt(tanh(mu_i + mu_i mu_o + mu_o))/(mu_i + mu_o) (eq. 29).",
    )


def _fm1_fast_general() -> Form:
    k1, k2, g, e = symbols(("k1", "k2", "g", "e"))
    return Form(
        target="fm1",
        name="fast_general",
        inputs=("mu_i", "mu_o", "c"),
        params=("k1", "k2", "g", "e"),
        expr=-(k1 + k2 * c) * c * sp.atan(c) * S * safe_pow(sp.tanh(g * (mu_i + mu_i * mu_o + mu_o)), e)
        / (mu_i + mu_o),
        start=dict(k1=0.0117, k2=0.0, g=1.0, e=0.5),
        description=(
            "fm1 ~ -(k1 + k2 c) c atan(c) S tanh(g (mu_i + mu_i mu_o + mu_o))^e/(mu_i + mu_o): eq. 29 with a "
            "linear factor in c, and the steepness and power of the tanh free."
        ),
    )


def _fast_brdf() -> Form:
    p1, p2, p3, p4, p5 = symbols(("p1", "p2", "p3", "p4", "p5"))
    # eq. 41's 1/(acos(S)/S + p3), multiplied through by S: finite at S = 0
    lobe = p1 * (c - p2) * (sp.Abs(phi) + sp.sqrt(mu_i * mu_o)) * S / (sp.acos(S) + p3 * S)
    return Form(
        target="fast_brdf",
        name="paper",
        inputs=("mu_i", "mu_o", "phi", "c", "kd"),
        params=("p1", "p2", "p3", "p4", "p5"),
        expr=sp.Max(0, SINGLE + lobe + p4 * safe_pow(kd, p5)),
        presets={"paper": dict(p1=0.0151829, p2=0.249978, p3=0.113706, p4=0.234459, p5=1.85432)},
        description=(
            "Fast variant (eq. 41): max(0, f_1 + p1 (c - p2)(|phi| + sqrt(mu_i mu_o))/(acos(S)/S + p3) "
            "+ p4 kd^p5), f_1 exact single scattering (true phase function), kd the material's spherical "
            "albedo for c; phi in [-pi, pi]."
        ),
    )


FORMS = (_fm1_fast(), _fm1_fast_general(), _fast_brdf())

#: the parts of the runtime model of orders 0 and 1 (the paper's, eqs. 11, 12, 21)
RUNTIME_PARTS = ("H0", "H1", "l", "m", "B", "C", "D", "F")
#: the part the second Fourier order adds: with it the runtime model is f_1 + fm0 + fm1 cos phi + fm2 cos 2phi
ORDER2_PART = "H2"


#: the terms of the runtime model, in the order they are summed (m2 only where the parts hold H2)
RUNTIME_TERMS = ("single", "m0", "m1", "m2")
#: the azimuthal factor of each term: f_r = max(0, sum_t term_t * AZIMUTH[t])
AZIMUTH = {"single": sp.S.One, "m0": sp.S.One, "m1": sp.cos(phi), "m2": sp.cos(2 * phi)}


def runtime_terms(parts: Mapping[str, sp.Expr], normalisation: str = "corrected") -> dict[str, sp.Expr]:
    r"""The terms of the runtime model, each an expression in (mu_i, mu_o, c) (single: and phi)
    (docs/model.md, "The runtime BRDF").

    Returns {"single": f_1, "m0": fm0, "m1": fm1} and, where ``parts`` holds H2, "m2": fm2, with
    f_r = max(0, f_1 + fm0 + fm1 cos(phi) [+ fm2 cos(2 phi)]):
      f_1 = c p(u) / (mu_i + mu_o)  (true phase function, eq. 10),
      fm0 = (H0(mu_i) H0(mu_o) Q / (2 pi) - n0_ss) / (mu_i + mu_o),
        Q = A + B (mu_i+mu_o) + C mu_i mu_o + D mu_i mu_o (mu_i+mu_o) + E mu_i^2 mu_o^2 + F (mu_i^2+mu_o^2),
      fm1 = (c H1(mu_i) H1(mu_o) S (1 + l (mu_i+mu_o) + (l^2 + 45 m/64) mu_i mu_o)/(k pi) - n1_ss/j)
            / (mu_i + mu_o),
      fm2 = 15 c S^2 (H2(mu_i) H2(mu_o) - 1) / (256 pi (mu_i + mu_o))  (docs/model.md, "Order 2"),
    A, E exact (eq. 33); ``parts`` maps H0, H1 (and H2) (expressions in mu, c) and l, m, B, C, D, F
    (in c) to expressions with numbers for parameters, or to calls of undefined
    functions (codegen prints those as calls of the parts' own routines).
    normalisation "corrected" uses k = 3, j = 1 (the exact solution); "printed"
    uses eqs. 22 and 28 as printed, k = 6 and 384 pi (j = 2), which halves fm1.
    fm2 vanishes at c = 0 and where H2 = 1, is reciprocal when H2 is one function of (mu, c), and
    is exact with the exact H2.
    """
    missing = [p for p in RUNTIME_PARTS if p not in parts]
    if missing:
        raise KeyError(f"runtime model needs forms for {missing}")
    if normalisation not in NORMALISATIONS:
        raise ValueError(f"normalisation must be one of {sorted(NORMALISATIONS)}")
    k, j = NORMALISATIONS[normalisation]
    h0i, h0o = (parts["H0"].subs(mu, x) for x in (mu_i, mu_o))
    h1i, h1o = (parts["H1"].subs(mu, x) for x in (mu_i, mu_o))
    l, m = parts["l"], parts["m"]
    B, C, D, F = (parts[n] for n in "BCDF")
    q = A_EXACT + B * (mu_i + mu_o) + C * _P + D * _P * (mu_i + mu_o) + E_EXACT * _P**2 + F * _Q
    fm0 = (h0i * h0o * q / (2 * PI) - SINGLE_NUMERATOR_0) / (mu_i + mu_o)
    n1 = c * h1i * h1o * S * (1 + l * (mu_i + mu_o) + (l**2 + sp.Rational(45, 64) * m) * _P) / (k * PI)
    fm1 = (n1 - SINGLE_NUMERATOR_1 / j) / (mu_i + mu_o)
    out = {"single": SINGLE, "m0": fm0, "m1": fm1}
    if ORDER2_PART in parts:
        h2i, h2o = (parts[ORDER2_PART].subs(mu, x) for x in (mu_i, mu_o))
        s2 = (1 - mu_i**2) * (1 - mu_o**2)
        out["m2"] = 15 * c * s2 * (h2i * h2o - 1) / (256 * PI * (mu_i + mu_o))
    return out


def runtime_brdf(parts: Mapping[str, sp.Expr], normalisation: str = "corrected", scale=1) -> sp.Expr:
    r"""The runtime model (docs/model.md, "The runtime BRDF") as one expression in (mu_i, mu_o, phi, c):
    f_r = max(0, s (f_1 + fm0 + fm1 cos(phi) [+ fm2 cos(2 phi) where ``parts`` holds H2])), the terms of
    :func:`runtime_terms`; s = ``scale`` is the energy scale of fitted models (1 for the published ones;
    :func:`fitlab.families.lambert_sphere.runtime.energy_scale`)."""
    t = runtime_terms(parts, normalisation)
    total = sum(t[n] * AZIMUTH[n] for n in RUNTIME_TERMS if n in t)
    return sp.Max(0, total if scale == 1 else sp.Mul(scale, total, evaluate=False))
