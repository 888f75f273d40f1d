r"""Forms of E(mu, alpha) for GGX (and, through :func:`.common.complement`, of 1 - E), mu and alpha in [0, 1],
alpha the GGX parameter of D (a renderer's perceptual roughness r has alpha = r^2).

Details: docs/microfacet_energy_derivation.md, section ``fitlab.families.microfacet_energy.forms.ggx``."""

from __future__ import annotations

import sympy as sp

from fitlab.families.microfacet_energy.forms.common import alpha, monomials, mu, polynomial, safe_log, u, v
from fitlab.forms import Form

__all__ = [
    "SFORZA_PELLACINI_2022",
    "MATERIALX",
    "MATERIALX_PRE_2022",
    "KNARKOWICZ_2014",
    "KARIS_2014",
    "e_forms",
    "sforza_ratpoly3",
    "materialx_ratquad",
    "knarkowicz_poly",
    "karis_linear",
    "rational_v_alpha_4",
    "grazing_rational",
    "grazing_log_rational",
]

# -- published coefficients (numbers verbatim from the sources named in docs/microfacet_energy_derivation.md) -----------
#: Sforza and Pellacini 2022 (dsforza96/yocto-gl energy-compensation, libs/yocto/yocto_shading.h, MIT):
#: coef[0..18], numerator n0..n9, then denominator d1..d9
SFORZA_PELLACINI_2022 = (1.0247217, -10.984229, 10.918318, 46.93353, -54.779343, 21.742077, -30.368898, 31.919222,
                         -8.013965, -6.2407165, -10.218104, 10.955399, 44.08196, -55.33452, 21.437538, -23.744568,
                         33.265057, -7.9268975, -5.930959)  # fmt: skip

#: MaterialX mx_ggx_dir_albedo_analytic (libraries/pbrlib/genglsl/lib/mx_microfacet_specular.glsl at 4177b2cb,
#: Apache-2.0): the vec4 of each term, in the source's order
#: 1, x, y, x y, x^2, y^2, x^2 y, x y^2, x^2 y^2 (x = NdotV, y = alpha); components (A num, B num, A den, B den)
MATERIALX = (
    (0.1003, 0.9345, 1.0, 1.0),
    (-0.6303, -2.323, -1.765, 0.2281),
    (9.748, 2.229, 8.263, 15.94),
    (-2.038, -3.748, 11.53, -55.83),
    (29.34, 1.424, 28.96, 13.08),
    (-8.245, -0.7684, -7.507, 41.26),
    (-26.44, 1.436, -36.11, 54.9),
    (19.99, 0.2913, 15.86, 300.2),
    (-5.448, 0.6286, 33.37, -285.1),
)
#: the same file before MaterialX commit 77ff72f (2022-02-07; Apache-2.0)
MATERIALX_PRE_2022 = (
    (0.10031, 0.93450, 1, 1),
    (-0.63301, -2.32352, -1.76427, 0.22797),
    (9.74995, 2.22823, 8.26501, 15.93688),
    (-2.02075, -3.74584, 11.54840, -55.82466),
    (29.38247, 1.42450, 28.99991, 13.07919),
    (-8.24713, -0.76829, -7.50867, 41.25882),
    (-26.51510, 1.43366, -36.16186, 54.86775),
    (19.98406, 0.29060, 15.85408, 300.10923),
    (-5.41717, 0.62933, 33.41550, -284.73288),
)

#: Knarkowicz 2014, "Analytical DFG Term for IBL" (knarkowicz.wordpress.com, no code licence stated): EnvDFGPolynomial's
#: d0..d6
KNARKOWICZ_2014 = {"d0": 0.6045, "d1": 1.699, "d2": -0.5228, "d3": -3.603, "d4": 1.404, "d5": 0.1939, "d6": 2.661}

#: Karis 2014 EnvBRDFApprox as three.js DFGApprox (src/renderers/shaders/ShaderChunk/
#: lights_physical_pars_fragment.glsl.js, MIT): the z and w components of c0 and c1
KARIS_2014 = {"c0_z": -0.572, "c0_w": 0.022, "c1_z": 1.04, "c1_w": -0.04}


# -- the forms ----------------------------------------------------------------------------------------------
_SFORZA_NUM = ("n0", "n1", "n2", "n3", "n4", "n5", "n6", "n7", "n8", "n9")
_SFORZA_DEN = ("d1", "d2", "d3", "d4", "d5", "d6", "d7", "d8", "d9")


def sforza_ratpoly3(target: str, published: bool) -> Form:
    """Sforza-Pellacini's rational cubic in (sqrt(alpha), mu); ``published``: the coefficients are its
    preset (separable Smith) or only its start (another model, which they were not fitted to)."""
    x, y = sp.sqrt(alpha), mu
    basis = (1, x, y, x**2, x * y, y**2, x**3, x**2 * y, x * y**2, y**3)  # eval_ratpoly2d's order
    n = sp.symbols(_SFORZA_NUM, real=True)
    d = sp.symbols(_SFORZA_DEN, real=True)
    expr = sp.Add(*(c * t for c, t in zip(n, basis))) / (1 + sp.Add(*(c * t for c, t in zip(d, basis[1:]))))
    values = dict(zip(_SFORZA_NUM + _SFORZA_DEN, SFORZA_PELLACINI_2022))
    return Form(
        target=target,
        name="sforza_ratpoly3",
        inputs=("mu", "alpha"),
        params=_SFORZA_NUM + _SFORZA_DEN,
        expr=expr,
        presets={"sforza_pellacini_2022": values} if published else {},
        start=None if published else values,
        # on another model the shape is one more rational beside rational_v_alpha_4: refit on request
        refit_by_default=published,
        description=(
            "Sforza-Pellacini 2022: cubic/cubic rational in (sqrt(alpha), mu), denominator constant 1 "
            "(yocto_shading.h eval_ratpoly2d)"
            + ("" if published else "; starts from their coefficients, fitted to separable Smith")
        ),
    )


_MX_TERMS = ("1", "x", "y", "xy", "x2", "y2", "x2y", "xy2", "x2y2")


def materialx_ratquad(target: str) -> Form:
    """MaterialX's white GGX albedo A + B, each clamped to [0, 1] as in the source."""
    x, y = mu, alpha
    basis = (1, x, y, x * y, x**2, y**2, x**2 * y, x * y**2, x**2 * y**2)
    comps = "xyzw"
    params = tuple(f"r{c}_{t}" for c in comps for t in _MX_TERMS)
    r = {c: sp.Add(*(sp.Symbol(f"r{c}_{t}", real=True) * b for t, b in zip(_MX_TERMS, basis))) for c in comps}

    def clamp01(e):
        return sp.Min(1, sp.Max(0, e))

    def preset(table):
        return {f"r{c}_{t}": float(row[j]) for j, c in enumerate(comps) for t, row in zip(_MX_TERMS, table)}

    return Form(
        target=target,
        name="materialx_ratquad",
        inputs=("mu", "alpha"),
        params=params,
        expr=clamp01(r["x"] / r["z"]) + clamp01(r["y"] / r["w"]),
        presets={"materialx": preset(MATERIALX), "materialx_pre_2022": preset(MATERIALX_PRE_2022)},
        # the denominators' constants are the source's 1.0: each ratio's scale, redundant in a fit
        fixed={"rz_1": 1.0, "rw_1": 1.0},
        description=(
            "MaterialX mx_ggx_dir_albedo_analytic with F0 = F90 = 1: clamp(rx/rz, 0, 1) + clamp(ry/rw, 0, 1), each "
            "r a bi-quadratic in (mu, alpha) (terms 1, mu, alpha, mu alpha, mu^2, alpha^2, mu^2 alpha, mu alpha^2, "
            "mu^2 alpha^2); fitted by MaterialX to height-correlated Smith. Only A + B is determined by E: a "
            "refit moves both"
        ),
    )


def knarkowicz_poly(target: str) -> Form:
    """Knarkowicz's EnvDFGPolynomial at specular colour 1 (its delta), gloss = 1 - alpha^(1/4)."""
    x, y = 1 - alpha ** sp.Rational(1, 4), mu
    d = sp.symbols(tuple(KNARKOWICZ_2014), real=True)
    poly = d[0] + d[1] * x + d[2] * y + d[3] * x**2 + d[4] * x * y + d[5] * y**2 + d[6] * x**3
    return Form(
        target=target,
        name="knarkowicz_poly",
        inputs=("mu", "alpha"),
        params=tuple(KNARKOWICZ_2014),
        expr=sp.Min(1, sp.Max(0, poly)),
        presets={"knarkowicz_2014": dict(KNARKOWICZ_2014)},
        description=(
            "Knarkowicz 2014 EnvDFGPolynomial, specular colour 1: saturate(d0 + d1 g + d2 mu + d3 g^2 + d4 g mu + "
            "d5 mu^2 + d6 g^3), gloss g = 1 - alpha^(1/4) (the mapping alpha = (1 - gloss)^4 is inferred)"
        ),
        refit_by_default=False,  # a cheap published baseline; the refit of its seven numbers is on request
    )


def karis_linear(target: str, inputs: tuple[str, ...]) -> Form:
    """Karis's EnvBRDFApprox at F0 = F90 = 1: (c1.z + c1.w) + (c0.z + c0.w) sqrt(alpha)."""
    c0_z, c0_w, c1_z, c1_w = sp.symbols(tuple(KARIS_2014), real=True)
    return Form(
        target=target,
        name="karis_linear",
        inputs=inputs,
        params=tuple(KARIS_2014),
        expr=(c1_z + c1_w) + (c0_z + c0_w) * sp.sqrt(alpha),
        presets={"karis_2014": dict(KARIS_2014)},
        # only the sums enter: holding the w parts keeps the refit's two free parameters determined
        fixed={"c0_w": KARIS_2014["c0_w"], "c1_w": KARIS_2014["c1_w"]},
        description=(
            "Karis 2014 EnvBRDFApprox (three.js DFGApprox) at F0 = F90 = 1: (c1.z + c1.w) + (c0.z + c0.w) roughness, "
            "roughness = sqrt(alpha); no dependence on mu (a baseline)"
        ),
        refit_by_default=False,  # a baseline: two numbers and no mu; refit on request
    )


def rational_v_alpha_4(target: str) -> Form:
    """A quartic over a quartic in (v, alpha), the denominator's constant 1; starts from E = 1."""
    terms = monomials({"v": v, "alpha": alpha}, 4)
    num_params, num = polynomial("a", terms)
    den_terms = {k: t for k, t in terms.items() if k != "00"}
    den_params, den = polynomial("b", den_terms)
    start = {p: 0.0 for p in num_params + den_params}
    start["a00"] = 1.0
    return Form(
        target=target,
        name="rational_v_alpha_4",
        inputs=("mu", "alpha"),
        params=num_params + den_params,
        expr=num / (1 + den),
        start=start,
        # at alpha = 0 (v = 0) the form is a00: the mirror's E, 1 exactly (a free a00 lets a fit put E above 1 there)
        fixed={"a00": 1.0},
        description=(
            "sum a_ij v^i alpha^j / (1 + sum b_ij v^i alpha^j), i + j <= 4, v = alpha/(mu + alpha) (the grazing-"
            "layer variable; v = 0 at alpha = 0, where a00 = 1, fixed, is the mirror's E); labels ij = powers of v, "
            "alpha"
        ),
    )


def _grazing_parts(prefix_p: str, prefix_q: str):
    """P and Q: the monomials of degree <= 2 in (u, mu, alpha) but u alpha (P with a constant, Q without)."""
    variables = {"u": u, "mu": mu, "alpha": alpha}
    # u (mu + alpha) = mu: mu, u mu and u alpha are linearly dependent, and a fit would run off to infinity along
    # their null combination (it did: coefficients of 1e11 cancelling); u alpha is left out
    dependent = "101"
    p_params, p = polynomial(prefix_p, {k: t for k, t in monomials(variables, 2).items() if k != dependent})
    q_params, q = polynomial(
        prefix_q, {k: t for k, t in monomials(variables, 2, constant=False).items() if k != dependent}
    )
    return p_params, p, q_params, q


def grazing_rational(target: str) -> Form:
    """E = 1 - v^2 P(u, mu, alpha)/(1 + Q(u, mu, alpha)), P, Q quadratic (separable Smith)."""
    p_params, p, q_params, q = _grazing_parts("p", "q")
    start = {k: 0.0 for k in p_params + q_params}
    start["p000"] = 1.0
    return Form(
        target=target,
        name="grazing_rational",
        inputs=("mu", "alpha"),
        params=p_params + q_params,
        expr=1 - v**2 * p / (1 + q),
        start=start,
        description=(
            "1 - v^2 P/(1 + Q), P and Q quadratic in (u, mu, alpha) but u alpha (= mu - u mu) (labels: powers of u, mu, "
            "alpha), u = mu/(mu + alpha), v = alpha/(mu + alpha): 1 - E = 0 at alpha = 0 and O(alpha^2) at fixed mu, like "
            "the exact one"
        ),
    )


def grazing_log_rational(target: str) -> Form:
    """E = 1 - v^2 u (1 - lam log u) P/(1 + Q) (height-correlated Smith: E = 1 at grazing)."""
    p_params, p, q_params, q = _grazing_parts("p", "q")
    lam = sp.Symbol("lam", real=True)
    start = {k: 0.0 for k in p_params + q_params}
    start.update(p000=1.0, lam=1.0)
    return Form(
        target=target,
        name="grazing_log_rational",
        inputs=("mu", "alpha"),
        params=p_params + q_params + ("lam",),
        expr=1 - v**2 * u * (1 - lam * safe_log(u)) * p / (1 + q),
        start=start,
        description=(
            "1 - v^2 u (1 - lam log u) P/(1 + Q), P and Q quadratic in (u, mu, alpha) but u alpha: 1 - E = 0 at alpha = 0 and at "
            "mu = 0 (height-correlated Smith has E(0, alpha) = 1), with the -mu log(mu) approach of the exact 1 - E"
        ),
    )


def e_forms(target: str, model: str) -> tuple[Form, ...]:
    """Every form of the E target ``target`` of the GGX ``model`` ("ggx_separable" or "ggx_correlated")."""
    inputs = ("mu", "alpha")
    if model == "ggx_separable":
        return (
            sforza_ratpoly3(target, True),
            knarkowicz_poly(target),
            karis_linear(target, inputs),
            rational_v_alpha_4(target),
            grazing_rational(target),
        )
    return (
        materialx_ratquad(target),
        karis_linear(target, inputs),
        sforza_ratpoly3(target, False),
        rational_v_alpha_4(target),
        grazing_log_rational(target),
    )
