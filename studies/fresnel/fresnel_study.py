r"""Which Fresnel approximation, for which material, at what error: writes docs/fresnel.md, fresnel.json and
one figure per material (fresnel_<material>.png), every number computed here.

For every material and every approximation (:mod:`fitlab.families.fresnel.forms`), per sRGB channel:

* the published construction where one exists (Schlick with F0 = F(1), F82-tint from F(mu = 1/7), Hoffman's
  "82 degrees" (81.79 degrees), Gulbrandsen's map of the measured n, k);
* a refit on the unweighted measure: least squares, then Lawson's minimax on |F - F_exact| over the training
  angles (``fitlab refit``), validated on the 1027 validation angles;
* a refit on the cosine-weighted measure: least squares with weight mu (the energy a direction carries in
  a cosine-weighted integral), no minimax.

Each is measured by the max of |F - F_exact| over the validation angles (worst channel), the error of
F_avg = 2 int F mu dmu (worst channel: what Kulla-Conti's coloured factor uses), and the CIEDE2000
difference between the hemispherical averages' colours (F_avg of the three channels, linear sRGB to
CIELAB under D65, colour-science's CIE 2000 formula).  Run as
``python -m studies.fresnel.fresnel_study --out docs`` (about 8 minutes on 2 cores: 360 fits).
"""

from __future__ import annotations

import argparse
import io
import json
import math
from pathlib import Path

import numpy as np

from fitlab.core import get_target
from fitlab.families.fresnel.exact import CHANNELS, MATERIALS, SPACES, average_reflectance, cosine_average, reflectance
from fitlab.families.fresnel.forms import FORM_NAMES, MU_BAR
from fitlab.families.fresnel.targets import PUBLISHED, target_name

__all__ = [
    "VARIANTS",
    "run",
    "markdown",
    "figure",
    "main",
    "approximation_costs",
    "COST_MATERIAL",
    "CHROMIUM_F0_PUBLISHED",
    "optical_constant_points",
]

#: the variants measured per form: its published construction (the preset's name), and the two refits
VARIANTS = ("construction", "refit", "refit_cosine")
#: the forms with a published construction (for some kind of material), and its preset: the targets' PUBLISHED
_CONSTRUCTION = {form: preset for published in PUBLISHED.values() for form, preset in published}
#: chromium's F0 (linear sRGB / Rec. 709) as two published tables give it, against the shipped n, k's: RTR4 Table 9.2,
#: and the Adobe Standard Material's "Metal material references" (Base Color (F0), linear Rec. 709)
CHROMIUM_F0_PUBLISHED = {
    "RTR4 Table 9.2": (0.549, 0.556, 0.554),
    "the Adobe Standard Material's metal references": (0.5496, 0.5561, 0.5531),
}
#: the visible range a table's points are counted in, and the range the channels integrate (CIE weights' range)
_VISIBLE_NM = (380.0, 780.0)
_LABEL = {
    "schlick": "Schlick",
    "schlick_generalised": "generalised Schlick",
    "lazanyi": "Lazanyi-Schlick",
    "f82_tint": "F82-tint",
    "gulbrandsen": "Gulbrandsen",
}


def _fits(material: str, form_name: str) -> dict:
    """{variant: parameter vectors per channel (None where the variant does not exist)}."""
    from fitlab.fit.refit import refit
    from fitlab.fit.solver import FitError, fit_form

    out: dict = {v: [] for v in VARIANTS}
    for channel in CHANNELS:
        t = get_target(target_name(material, channel))
        form = t.forms[form_name]
        preset = dict(t.published).get(form_name)  # Gulbrandsen's map is a construction for metals only
        out["construction"].append(None if preset is None else form.vector(preset))
        try:
            out["refit"].append(refit(t, form).fit.theta)
        except FitError:
            out["refit"].append(None)
        train = t.training()
        try:
            # residuals are multiplied by the weights: sqrt(mu) makes the objective sum mu (F - F_exact)^2
            with np.errstate(divide="ignore"):
                out["refit_cosine"].append(
                    fit_form(
                        form, train, np.ones_like(train.y), minimax_rounds=0, weights=np.sqrt(train.inputs["mu"])
                    ).theta
                )
        except FitError:
            out["refit_cosine"].append(None)
    return out


def _approx(material: str, form_name: str, thetas):
    """mu -> (mu.size, 3) of the form with one parameter vector per channel."""
    forms = [get_target(target_name(material, c)).forms[form_name] for c in CHANNELS]

    def f(mu):
        return np.stack([form.numpy_function(th, mu) for form, th in zip(forms, thetas)], axis=-1)

    return f


def _lab(rgb):
    import colour

    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    xyz = colour.RGB_to_XYZ(np.asarray(rgb, dtype=float), "sRGB", apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, white)


def _delta_e(rgb_a, rgb_b) -> float:
    import colour

    return float(colour.delta_E(_lab(rgb_a), _lab(rgb_b), method="CIE 2000"))


def _measures(f, exact_valid: np.ndarray, mu_valid: np.ndarray, f_avg: np.ndarray) -> dict:
    with np.errstate(all="ignore"):
        err = np.abs(f(mu_valid) - exact_valid)
        avg = cosine_average(f)
    if not (np.all(np.isfinite(err)) and np.all(np.isfinite(avg))):
        return {"max_abs": math.inf, "max_abs_channel": [math.inf] * 3, "f_avg_error": math.inf, "delta_e00": math.inf}
    return {
        "max_abs": float(err.max()),
        "max_abs_channel": err.max(axis=0).tolist(),
        "f_avg_error": float(np.max(np.abs(avg - f_avg))),
        "delta_e00": _delta_e(avg, f_avg),
        "f_avg": avg.tolist(),
    }


#: depths F(1) - min F up to this are the exact engine's rounding, not a dip
DIP_ROUNDING = 1e-12


def _dip(material: str) -> dict:
    """Where the exact F falls below F(1) before its rise to 1 at grazing: per channel the least F, its angle,
    and the depth F(1) - min F."""
    theta = np.linspace(0.0, 90.0, 9001)
    mu = np.cos(np.radians(theta))
    mu[-1] = 0.0
    f = reflectance(material, mu)
    # a dielectric's F rises from F(1) as theta^4: near normal incidence that is below the engine's rounding (a few
    # ulps), which must not read as a dip
    f = np.where(f > f[0] - DIP_ROUNDING, np.maximum(f, f[0]), f)
    i = np.argmin(f, axis=0)
    return {"min": f[i, range(3)].tolist(), "angle_deg": theta[i].tolist(), "depth": (f[0] - f[i, range(3)]).tolist()}


#: the target whose presets the cost programs print (the cost of a form does not depend on its parameters' values)
COST_MATERIAL = ("cu", "r")


def approximation_costs(n: int = 200_000, repeat: int = 5) -> dict:
    """{form: {"double": ns, "float": ns}}: ns per evaluation of each approximation's generated C (``-O2``, double
    and float), every form with its preset for copper's red (:data:`COST_MATERIAL`) a routine of one program,
    timed in one interleaved run (:func:`fitlab.codegen.bench.time_expressions`) on ``n`` random mu in [0, 1]:
    only the ratios carry meaning.  {} without a C compiler."""
    from fitlab.codegen.bench import time_expressions
    from fitlab.codegen.native import compiler

    if compiler() is None:
        return {}
    target = get_target(target_name(*COST_MATERIAL))
    exprs = {}
    for name in FORM_NAMES:
        form = target.forms[name]
        exprs[name] = (("mu",), form.substituted(next(iter(form.presets))), {"mu": (0.0, 1.0)})
    ns = time_expressions(exprs, n=n, repeat=repeat, seed=1)
    return {name: {"double": double, "float": single} for name, (double, single) in ns.items()}


def optical_constant_points(material: str) -> dict:
    """Where a conductor's measured n, k lie: the points in 380 to 780 nm and in the range the channels integrate,
    and the widest gap between neighbouring points of that range (nm, with its ends)."""
    from fitlab.families.fresnel.exact.colour import channel_weights
    from fitlab.resources import packaged_tables
    from fitlab.store import read_table

    _, table = read_table(packaged_tables("fresnel") / MATERIALS[material].file, ("wavelength_nm", "n", "k"))
    lam = table[:, 0]
    integrated = channel_weights("srgb")[0]
    lo, hi = float(integrated.min()), float(integrated.max())
    inside = lam[(lam >= lo) & (lam <= hi)]
    widest = int(np.argmax(np.diff(inside)))
    return {
        "visible": int(np.count_nonzero((lam >= _VISIBLE_NM[0]) & (lam <= _VISIBLE_NM[1]))),
        "integrated_range_nm": [lo, hi],
        "integrated": int(inside.size),
        "widest_gap_nm": [float(inside[widest]), float(inside[widest + 1])],
    }


def run(materials=None, progress: bool = True) -> dict:
    """Every measure of the module docstring, as data."""
    from tqdm import tqdm

    chosen = list(materials or MATERIALS)
    result: dict = {"materials": {}, "forms": list(FORM_NAMES), "variants": list(VARIANTS)}
    with tqdm(total=len(chosen) * len(FORM_NAMES), desc="fresnel study", unit="fit x 6", disable=not progress) as bar:
        for m in chosen:
            valid = get_target(target_name(m, "r")).validation()
            mu_valid = valid.inputs["mu"]
            exact_valid = reflectance(m, mu_valid)
            f_avg = {s: average_reflectance(m, s) for s in SPACES}
            row: dict = {
                "name": MATERIALS[m].name,
                "kind": MATERIALS[m].kind,
                "source": MATERIALS[m].source,
                "F0": {s: reflectance(m, 1.0, s).tolist() for s in SPACES},
                "F82": reflectance(m, float(MU_BAR)).tolist(),
                "F_82_degrees": reflectance(m, math.cos(math.radians(82.0))).tolist(),
                "F_avg": {s: v.tolist() for s, v in f_avg.items()},
                "dip": _dip(m),
                "approximations": {},
            }
            if MATERIALS[m].kind == "conductor":
                row["optical_constants"] = optical_constant_points(m)
            for name in FORM_NAMES:
                fits = _fits(m, name)
                row["approximations"][name] = {}
                for variant, thetas in fits.items():
                    if any(t is None for t in thetas):
                        row["approximations"][name][variant] = None
                        continue
                    meas = _measures(_approx(m, name, thetas), exact_valid, mu_valid, f_avg["srgb"])
                    form = get_target(target_name(m, "r")).forms[name]
                    meas["params"] = [dict(zip(form.params, np.asarray(t, dtype=float).tolist())) for t in thetas]
                    row["approximations"][name][variant] = meas
                bar.update(1)
            result["materials"][m] = row
    result["costs"] = approximation_costs()
    return result


def _e(x) -> str:
    if x is None:
        return "-"
    if not math.isfinite(x):
        return "inf"
    return "0" if x == 0 else f"{x:.1e}"


#: the (form, variant) columns of the tables: each form's construction (where it has one) and its refit
_COLUMNS = tuple((f, v) for f in FORM_NAMES for v in ("construction", "refit") if v == "refit" or f in _CONSTRUCTION)


def _header(extra: str = "") -> list[str]:
    return [
        "| material | " + " | ".join(f"{_LABEL[f]}, {v}" for f, v in _COLUMNS) + f" |{extra}",
        "|---|" + "---|" * (len(_COLUMNS) + bool(extra)),
    ]


def _cells(row: dict, show) -> str:
    """The row's cells of the (form, variant) columns, ``show(measures)`` each ("-" where there are none)."""
    return " | ".join(
        "-" if row["approximations"][f][v] is None else show(row["approximations"][f][v]) for f, v in _COLUMNS
    )


def _best(row: dict) -> tuple[str, str, float]:
    cands = [
        (v["max_abs"], name, variant)
        for name, by in row["approximations"].items()
        for variant, v in by.items()
        if v is not None and variant != "refit_cosine"
    ]
    err, name, variant = min(cands)
    return name, variant, err


def _cost_section(result: dict) -> list[str]:
    costs = result.get("costs") or {}
    if not costs:
        return ["", "## Accuracy against cost", "", "Not measured: no C compiler on the machine that wrote this.", ""]
    metals = [row for row in result["materials"].values() if row["kind"] == "conductor"]
    lines = [
        "",
        "## Accuracy against cost",
        "",
        "ns per evaluation of each approximation's generated C (`-O2`, double and float; one interleaved run "
        "on the machine that wrote this page: only the ratios carry meaning), against its max |F - F_exact| "
        f"on the worst of the {len(metals)} metals (worst channel): with the published construction where "
        "there is one, and refitted. The exact F of one complex index is Gulbrandsen's form itself (its "
        "routine evaluates the exact conductor reflectance of n(r, g) + i k(r, g)).",
        "",
        "| approximation | C double ns | C float ns | worst metal, construction | worst metal, refit |",
        "|---|---|---|---|---|",
    ]
    for name in FORM_NAMES:
        worst = {}
        for variant in ("construction", "refit"):
            errs = [
                (row["approximations"][name][variant]["max_abs"], row["name"])
                for row in metals
                if row["approximations"][name][variant] is not None
            ]
            worst[variant] = f"{_e(max(errs)[0])} ({max(errs)[1]})" if errs else "-"
        c = costs[name]
        lines.append(
            f"| {_LABEL[name]} | {c['double']:.2f} | {c['float']:.2f} | {worst['construction']} | {worst['refit']} |"
        )
    base = costs["schlick"]["double"]
    lines += [
        "",
        "Relative to Schlick in double: "
        + ", ".join(f"{_LABEL[n]} {costs[n]['double'] / base:.1f}x" for n in FORM_NAMES[1:])
        + ".",
    ]
    return lines


def _mu_bar_degrees() -> float:
    """Hoffman's angle of the F82 tint, mu = 1/7, in degrees (81.79)."""
    return math.degrees(math.acos(float(MU_BAR)))


def _measured_data_section(mats: dict) -> list[str]:
    """Hoffman's angle, chromium's F0 against two published tables, and where each conductor's n, k were measured."""

    def rgb(v):
        return "(" + ", ".join(f"{x:.4f}".rstrip("0") for x in v) + ")"

    off = max(abs(a - b) for row in mats.values() for a, b in zip(row["F82"], row["F_82_degrees"]))
    worst = max(mats.values(), key=lambda row: max(abs(a - b) for a, b in zip(row["F82"], row["F_82_degrees"])))
    lines = [
        "",
        f'F(mu = 1/7) is the point F82-tint pins: Hoffman\'s "82 degrees" is mu = 1/7, '
        f"{_mu_bar_degrees():.2f} degrees. At exactly 82 degrees F differs from it by up to {off:.4f} in "
        f"these materials ({worst['name']}: {rgb(worst['F_82_degrees'])} at 82 degrees).",
    ]
    conductors = {key: row for key, row in mats.items() if "optical_constants" in row}
    if "cr" in conductors:
        f0 = conductors["cr"]["F0"]["srgb"]
        published = "; ".join(f"{source} {rgb(v)}" for source, v in CHROMIUM_F0_PUBLISHED.items())
        gaps = [a - b for v in CHROMIUM_F0_PUBLISHED.values() for a, b in zip(f0, v)]
        lines += [
            "",
            f"Chromium's F0 from the shipped n, k is {rgb(f0)}. Two published tables give less: "
            f"{published}, {min(gaps):.3f} to {max(gaps):.3f} below per channel: they were not computed from "
            "the luxpop n, k that Mitsuba 3 ships. fitlab keeps that table as shipped; which measurement "
            "of chromium is right is not settled here.",
        ]
    if conductors:
        lo, hi = next(iter(conductors.values()))["optical_constants"]["integrated_range_nm"]
        lines += [
            "",
            f"The measured n, k of each conductor: the points of its table between "
            f"{_VISIBLE_NM[0]:.0f} and {_VISIBLE_NM[1]:.0f} nm, between {lo:.0f} and {hi:.0f} nm (the "
            "range the channels integrate), and the widest gap between two of those, across which F is "
            "interpolated linearly in wavelength:",
            "",
            "| material | points, visible | points, integrated | widest gap (nm) |",
            "|---|---|---|---|",
        ]
        for row in conductors.values():
            pts = row["optical_constants"]
            a, b = pts["widest_gap_nm"]
            lines.append(f"| {row['name']} | {pts['visible']} | {pts['integrated']} | {a:.1f} to {b:.1f} |")
    return lines


def markdown(result: dict) -> str:
    mats = result["materials"]
    lines = [
        "# Fresnel reflectance of real materials, and its approximations",
        "",
        "Written by `python -m studies.fresnel.fresnel_study --out docs`; every number is computed "
        "by that run. The family is `fitlab.families.fresnel` (targets `F_<material>_<channel>`, e.g. "
        "`fitlab refit --target F_cu_r --form gulbrandsen`).",
        "",
        "## What is exact",
        "",
        "F(mu) of an interface between air and a material of complex index n + i k, unpolarised: the amplitude "
        "coefficients r_s = (mu - w)/(mu + w), r_p = (eta^2 mu - w)/(eta^2 mu + w) with "
        "w = sqrt(eta^2 - sin^2 theta), F = (|r_s|^2 + |r_p|^2)/2, evaluated in Born and Wolf's real form without "
        "cancellation (`fitlab.physics.fresnel.fresnel_conductor`), per wavelength from 360 to 780 nm "
        "(1 nm steps). A channel of linear sRGB (or ACEScg) is the spectrum weighted by the CIE 1931 2-degree "
        "observer under D65 and the colour space's matrix (ACEScg reached from D65 by CAT02), each channel "
        "normalised so that a constant spectrum gives that constant; the weights come from colour-science and "
        "ship as `fitlab/data/fresnel/colour_weights.csv`. Conductors: measured n, k (luxpop.com, Palik for "
        "nickel) as Mitsuba 3 ships them, interpolated linearly in wavelength; iron and zinc, two of RTR4 "
        "Figure 9.22's metals, are not among those tables and are left out. Dielectrics: constant indices and "
        "Schott's Sellmeier formula for N-BK7.",
        "",
        "A channel can exceed 1: gold's red at normal incidence is outside sRGB's gamut (RTR4 Table 9.2 shows it "
        "clamped). Gulbrandsen's form is bounded by 1 there.",
        "",
        "## F0 and F_avg per material",
        "",
        f"| material | F0, linear sRGB | F0, ACEScg | F(mu = 1/7), sRGB ({_mu_bar_degrees():.2f} deg) | "
        "F_avg = 2 int F mu dmu, sRGB | F_avg, ACEScg |",
        "|---|---|---|---|---|---|",
    ]

    def rgb(v):
        return "(" + ", ".join(f"{x:.4f}" for x in v) + ")"

    for row in mats.values():
        lines.append(
            f"| {row['name']} | {rgb(row['F0']['srgb'])} | {rgb(row['F0']['acescg'])} | {rgb(row['F82'])} | "
            f"{rgb(row['F_avg']['srgb'])} | {rgb(row['F_avg']['acescg'])} |"
        )
    lines += _measured_data_section(mats)
    lines += [
        "",
        "## Which approximation, for which material, at what error",
        "",
        "Max |F - F_exact| over the 1027 validation angles (evenly spaced in theta, both ends and mu = 1/7 "
        "included), worst of the three sRGB channels. *construction*: the published way to set the parameters "
        "from the exact F (Schlick: F0 = F(1); F82-tint: F0 and F(mu = 1/7); Gulbrandsen: r = F(1) of the "
        "channel, g from the measured n, k at the channel's mean wavelength; metals only). *refit*: fitted by "
        "`fitlab refit` (least squares, then minimax on the max error).",
        "",
        *_header(" best |"),
    ]
    for row in mats.values():
        name, variant, err = _best(row)
        lines.append(
            f"| {row['name']} | {_cells(row, lambda m: _e(m['max_abs']))} | {_LABEL[name]} ({variant}) {_e(err)} |"
        )
    f90 = [c["F90"] for row in mats.values() for c in row["approximations"]["schlick_generalised"]["refit"]["params"]]
    above = [v for v in f90 if v > 1.0]
    lines += [
        "",
        f"The generalised Schlick's refit puts F90 above 1 in {len(above)} of {len(f90)} channels"
        + (f" (up to {max(above):.3f})" if above else "")
        + ": it buys its accuracy by reflecting more than all the light at grazing, which a renderer that "
        "conserves energy has to clamp.",
    ]
    lines += [
        "",
        "Headline: Schlick's max error (its construction, F0 = F(1)) against the best approximation's.",
        "",
        "| material | Schlick | best | ratio |",
        "|---|---|---|---|",
    ]
    for row in mats.values():
        s = row["approximations"]["schlick"]["construction"]["max_abs"]
        name, variant, err = _best(row)
        ratio = "exact" if err < 1e-12 else f"{s / err:.0f}x"
        lines.append(f"| {row['name']} | {_e(s)} | {_LABEL[name]} ({variant}): {_e(err)} | {ratio} |")
    lines += _cost_section(result)
    lines += [
        "",
        "## Colour and energy: the hemispherical average",
        "",
        "For each approximation's construction and unweighted refit: the CIEDE2000 difference between the "
        "colours of the exact and the approximated F_avg (linear sRGB to CIELAB, D65), and the largest error of "
        "F_avg over the channels (the number Kulla-Conti's coloured compensation f_add = F_avg^2 E_avg / "
        "(1 - F_avg (1 - E_avg)) takes).",
        "",
        *_header(),
    ]
    for row in mats.values():
        lines.append(
            f"| {row['name']} | "
            + _cells(row, lambda m: f"dE {m['delta_e00']:.2g}, dF_avg {_e(m['f_avg_error'])}")
            + " |"
        )
    lines += [
        "",
        "## The cosine-weighted measure",
        "",
        "The same forms fitted by least squares with weight mu (no minimax): the fit that spends its accuracy "
        "where a cosine-weighted integral (an albedo, F_avg) does. Max |F - F_exact| / |dF_avg|, worst channel.",
        "",
        "| material | " + " | ".join(_LABEL[f] for f in FORM_NAMES) + " |",
        "|---|" + "---|" * len(FORM_NAMES),
    ]
    for row in mats.values():
        cells = []
        for f in FORM_NAMES:
            meas = row["approximations"][f]["refit_cosine"]
            cells.append("-" if meas is None else f"{_e(meas['max_abs'])} / {_e(meas['f_avg_error'])}")
        lines.append(f"| {row['name']} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "## Schlick's dips",
        "",
        "Schlick's form rises monotonically from F0 to 1; the exact F of a metal first falls below F0 towards "
        "grazing (a dip, deepest near 80 degrees) and then rises. Per material, the deepest dip over the "
        "channels (F(1) - min F), its angle, and Schlick's error (construction) anywhere:",
        "",
        "| material | deepest dip | at (deg) | channel | Schlick's max error |",
        "|---|---|---|---|---|",
    ]
    for row in mats.values():
        d = row["dip"]
        c = int(np.argmax(d["depth"]))
        s = row["approximations"]["schlick"]["construction"]["max_abs"]
        if d["depth"][c] > 0:
            lines.append(f"| {row['name']} | {d['depth'][c]:.4f} | {d['angle_deg'][c]:.1f} | {CHANNELS[c]} | {_e(s)} |")
        else:
            lines.append(f"| {row['name']} | none (F rises from F0) | - | - | {_e(s)} |")
    deep_rows = [row for row in mats.values() if max(row["dip"]["depth"]) > 0.01]
    flat_metals = [row for row in mats.values() if row["kind"] == "conductor" and max(row["dip"]["depth"]) <= 0.01]
    dielectrics = [row for row in mats.values() if row["kind"] == "dielectric"]

    def span(rows, pick) -> str:
        values = [pick(r) for r in rows]
        lo, hi = _e(min(values)), _e(max(values))
        return lo if lo == hi else f"{lo} to {hi}"

    def schlick(r):
        return r["approximations"]["schlick"]["construction"]["max_abs"]

    def f82(r):
        return r["approximations"]["f82_tint"]["construction"]["max_abs"]

    lines.append("")
    if deep_rows:
        lines.append(
            f"The dip is deeper than 0.01 for {', '.join(r['name'] for r in deep_rows)}: Schlick's max error there "
            f"is {span(deep_rows, schlick)}; F82-tint's construction, which pins mu = 1/7, brings it to "
            f"{span(deep_rows, f82)}, and the best refit of each to {span(deep_rows, lambda r: _best(r)[2])}."
        )
    if flat_metals:
        lines.append(
            f"The metals with shallower dips ({', '.join(r['name'] for r in flat_metals)}): Schlick's max "
            f"error {span(flat_metals, schlick)}."
        )
    if dielectrics:
        lines.append(
            f"The dielectrics have no dip (F rises from F0); Schlick's error there, "
            f"{span(dielectrics, schlick)}, comes from the shape of the rise near grazing."
        )
    lines += [
        "",
        "## Figures",
        "",
        "One figure per material, in the manner of RTR4's Figure 9.22: the exact F per channel (solid), and "
        "each approximation (dashed): the constructions of Schlick, F82-tint and Gulbrandsen (metals), and the "
        "refits of the generalised Schlick and Lazanyi-Schlick.",
        "",
    ]
    for m in mats:
        lines.append(f"![{mats[m]['name']}](fresnel_{m}.png)")
    return "\n".join(lines) + "\n"


def _shown(row: dict, name: str):
    by = row["approximations"][name]
    return ("construction", by["construction"]) if by.get("construction") else ("refit", by["refit"])


def figure(material: str, row: dict) -> bytes:
    """PNG bytes of the material's figure: a panel per approximation, angle in degrees."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    theta = np.linspace(0.0, 90.0, 361)
    mu = np.cos(np.radians(theta))
    mu[-1] = 0.0
    exact = reflectance(material, mu)
    colours = ("tab:red", "tab:green", "tab:blue")
    fig, axes = plt.subplots(1, len(FORM_NAMES), figsize=(3.0 * len(FORM_NAMES), 2.8), sharey=True)
    for ax, name in zip(axes, FORM_NAMES):
        variant, meas = _shown(row, name)
        for c in range(3):
            ax.plot(theta, exact[:, c], color=colours[c], lw=1.4)
        if meas is not None:
            forms = [get_target(target_name(material, ch)).forms[name] for ch in CHANNELS]
            for c in range(3):
                th = np.array([meas["params"][c][p] for p in forms[c].params])
                ax.plot(theta, forms[c].numpy_function(th, mu), color=colours[c], lw=1.0, ls="--")
            ax.set_title(f"{_LABEL[name]} ({variant})\nmax err {_e(meas['max_abs'])}", fontsize=8)
        ax.set_xlabel("angle of incidence (deg)", fontsize=7)
        ax.set_xlim(0, 90)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel(f"{row['name']}: F, linear sRGB", fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def main(argv=None) -> int:
    from fitlab._io import atomic_write_many, check_output_folder

    p = argparse.ArgumentParser(
        prog="python -m studies.fresnel.fresnel_study",
        description="Write fresnel.md, fresnel.json and fresnel_<material>.png.",
    )
    p.add_argument("--out", default=".", help="folder for the files")
    p.add_argument(
        "--materials", default=None, help=f"comma-separated materials (default: all of {', '.join(MATERIALS)})"
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    args = p.parse_args(argv)
    chosen = None if args.materials is None else [m.strip() for m in args.materials.split(",")]
    unknown = [m for m in chosen or () if m not in MATERIALS]
    if unknown:
        p.error(f"--materials: unknown {', '.join(unknown)}; known: {', '.join(MATERIALS)}")
    out = Path(args.out)
    try:
        import colour  # noqa: F401
    except ImportError:
        p.error("the study needs colour-science (CIEDE2000): pip install 'fitlab-brdf[fresnel]'")
    check_output_folder(out)
    result = run(chosen, progress=not args.quiet)
    files = {out / f"fresnel_{m}.png": figure(m, row) for m, row in result["materials"].items()}
    files[out / "fresnel.md"] = markdown(result).encode()
    files[out / "fresnel.json"] = (json.dumps(result, indent=1, allow_nan=False, default=float) + "\n").encode()
    atomic_write_many(files)
    for f in files:
        print(f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
