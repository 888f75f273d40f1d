r"""The energy-compensation study behind docs/energy_compensation.md: how well, at what memory and at what
cost, a renderer can know E(mu, alpha) for Kulla-Conti's compensation lobe.

For each model (GGX with separable or height-correlated Smith, Oren-Nayar with A's 0.33) the methods are:

* **none**: no compensation; the white furnace of f alone is E(mu_o) < 1.
* **table N x N**: E at texel centres, (j + 1/2)/N in mu and alpha, read with bilinear filtering and
  clamp-to-edge addressing, as a GPU samples a texture (the blog's 128 x 128 and "32 x 32 is more than
  enough", with 16 and 64); E_avg from a 1-D table of N texel centres, read the same way.  Below the first
  and above the last centre such a read is constant: the half texel at each edge (alpha -> 0 above all,
  where GGX turns into a mirror) is where a centred table errs most.
* **table N x N, nodes**: E at k/(N - 1), both edges included, read at u' = (u (N - 1) + 1/2)/N so that
  the filter's centres fall on the nodes (the same texture, addressed differently).
* **fitted forms**: the fits of the family's E and E_avg targets (``fitlab refit``), when given.

Details: docs/microfacet_energy_derivation.md, section
``studies.microfacet_energy.energy_compensation``."""

from __future__ import annotations

import ctypes
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from fitlab.cache import cached_arrays
from fitlab.codegen.native import compiler
from fitlab.export import texel_centres
from fitlab.families.microfacet_energy import exact
from fitlab.families.microfacet_energy.exact import average_albedo, directional_albedo
from fitlab.physics.fresnel import schlick_average

__all__ = [
    "STUDY_MODELS",
    "TABLE_SIZES",
    "ALPHA_MIN",
    "validation_set",
    "centre_table",
    "bilinear",
    "study_rows",
    "markdown",
    "main",
    "fitted_methods",
    "FIT_TARGETS",
    "table_method",
    "exact_method",
    "no_compensation",
    "furnace",
    "measure",
    "table_lookup_ns",
    "KC_ALPHAS",
    "kulla_conti_furnace",
    "COLOURED_ALPHAS",
    "coloured_compensation",
]

#: the models studied (the exact engine's names)
STUDY_MODELS = ("ggx_separable", "ggx_correlated", "oren_nayar")
#: the table resolutions compared (the blog's 128 and 32, and 16 and 64)
TABLE_SIZES = (16, 32, 64, 128)
#: the smallest alpha of the validation set (GGX becomes a mirror as alpha -> 0; a table's first texel
#: centre is 1/(2N))
ALPHA_MIN = 1e-3
_GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


def _lattice(n: int, start: float) -> np.ndarray:
    return np.sort((start + _GOLDEN * np.arange(n)) % 1.0)


def validation_set(n: int = 64) -> dict[str, np.ndarray]:
    """{"mu", "alpha"} (flat, same length): an n x n golden-ratio lattice in (0, 1)^2 (alpha >= ALPHA_MIN),
    with the edges mu = 0, mu = 1, alpha = ALPHA_MIN and alpha = 1 added; no point on a texel centre
    of the tables studied."""
    mu = np.concatenate(([0.0, 1.0], _lattice(n, 0.1234567)))
    alpha = np.concatenate(([ALPHA_MIN, 1.0], np.maximum(_lattice(n, 0.3456789), ALPHA_MIN)))
    a, m = np.meshgrid(alpha, mu, indexing="ij")
    return {"mu": m.ravel(), "alpha": a.ravel()}


def _exact_E(model: str, mu: np.ndarray, alpha: np.ndarray, name: str) -> np.ndarray:
    return cached_arrays(f"microfacet_energy-study-{name}", {"model": model, "mu": mu, "alpha": alpha},
                         lambda: {"E": directional_albedo(mu, alpha, model)}, ("E",), sources=exact.SOURCES)["E"]  # fmt: skip


def _exact_E_avg(model: str, alpha: np.ndarray, name: str) -> np.ndarray:
    return cached_arrays(f"microfacet_energy-study-{name}", {"model": model, "alpha": alpha},
                         lambda: {"E_avg": average_albedo(alpha, model)}, ("E_avg",), sources=exact.SOURCES)["E_avg"]  # fmt: skip


def centre_table(model: str, n: int, nodes: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(E of shape (n, n) indexed [alpha, mu], E_avg of shape (n,)) at the texel centres (k + 1/2)/n, or
    (``nodes``) at k/(n - 1)."""
    c = np.arange(n) / (n - 1.0) if nodes else texel_centres(n)
    a, m = np.meshgrid(c, c, indexing="ij")
    kind = "nodes" if nodes else "table"
    E = _exact_E(model, m.ravel(), a.ravel(), f"{kind}{n}").reshape(n, n)
    return E, _exact_E_avg(model, np.maximum(c, 0.0), f"avg{kind}{n}")


def bilinear(table: np.ndarray, u: np.ndarray, v: np.ndarray | None = None) -> np.ndarray:
    """A texture read: ``table`` (1-D, or 2-D indexed [v, u]) at coordinates in [0, 1], texel centres at
    (k + 1/2)/n, linear filtering, clamp-to-edge."""

    def coord(x, n):
        t = np.clip(np.asarray(x, dtype=float) * n - 0.5, 0.0, n - 1.0)
        i = np.minimum(np.floor(t).astype(int), max(n - 2, 0))
        return i, t - i

    if table.ndim == 1:
        i, f = coord(u, table.size)
        return table[i] * (1.0 - f) + table[i + 1] * f
    iu, fu = coord(u, table.shape[1])
    iv, fv = coord(v, table.shape[0])
    top = table[iv, iu] * (1.0 - fu) + table[iv, iu + 1] * fu
    bottom = table[iv + 1, iu] * (1.0 - fu) + table[iv + 1, iu + 1] * fu
    return top * (1.0 - fv) + bottom * fv


def table_method(model: str, n: int, nodes: bool = False) -> dict:
    """The method "table n x n" (texel centres, or ``nodes``): {"E": E_hat(mu, alpha), "E_avg":
    E_avg_hat(alpha), "bytes", "label"}."""
    E, E_avg = centre_table(model, n, nodes)
    to = (lambda u: (np.asarray(u, dtype=float) * (n - 1) + 0.5) / n) if nodes else (lambda u: u)
    return {"label": f"table {n} x {n}" + (", nodes" if nodes else ""),
            "E": lambda mu, alpha: bilinear(E, to(mu), to(alpha)), "E_avg": lambda alpha: bilinear(E_avg, to(alpha)),
            "bytes": 4 * (n * n + n)}  # fmt: skip


def exact_method(model: str) -> dict:
    """The exact E and E_avg (the furnace is then 1: the identity the study's furnace is checked on)."""
    return {"label": "exact", "E": lambda mu, alpha: directional_albedo(mu, alpha, model),
            "E_avg": lambda alpha: average_albedo(alpha, model), "bytes": None}  # fmt: skip


def no_compensation() -> dict:
    return {"label": "none", "E": None, "E_avg": None, "bytes": 0}


_MID = (np.arange(512) + 0.5) / 512


def furnace(method: dict, model: str, mu: np.ndarray, alpha: np.ndarray, E_exact: np.ndarray) -> np.ndarray:
    """The white furnace a(mu_o) of f + f_ms with ``method``'s E_hat and E_avg_hat (docs/microfacet_energy_derivation.md);
    ``E_exact`` is E at (mu, alpha).  No compensation: a = E."""
    if method["E"] is None:
        return E_exact
    alphas, where = np.unique(alpha, return_inverse=True)
    a_mid, m_mid = np.meshgrid(alphas, _MID, indexing="ij")
    lobe = 2.0 * np.mean((1.0 - method["E"](m_mid.ravel(), a_mid.ravel()).reshape(a_mid.shape)) * _MID, axis=1)
    ratio = lobe / (1.0 - method["E_avg"](alphas))
    return E_exact + (1.0 - method["E"](mu, alpha)) * ratio[where]


def measure(model: str, methods: list[dict], n: int = 64) -> list[dict]:
    """One row per method: label, max |E_hat - E|, max |furnace - 1|, where the furnace is worst, bytes."""
    v = validation_set(n)
    E = _exact_E(model, v["mu"], v["alpha"], f"validation{n}")
    rows = []
    inner = (v["mu"] >= 1.0 / 16) & (v["alpha"] >= 1.0 / 16)
    for method in methods:
        diff = None if method["E"] is None else np.abs(method["E"](v["mu"], v["alpha"]) - E)
        err_E = None if diff is None else float(np.max(diff))
        err_inner = None if diff is None else float(np.max(diff[inner]))
        a = furnace(method, model, v["mu"], v["alpha"], E)
        k = int(np.argmax(np.abs(a - 1.0)))
        rows.append({"model": model, "method": method["label"], "max_abs_E": err_E, "max_abs_E_interior": err_inner,
                     "max_furnace_interior": float(np.max(np.abs(a[inner] - 1.0))),
                     "max_furnace": float(np.abs(a[k] - 1.0)), "worst": {"mu": float(v["mu"][k]), "alpha": float(v["alpha"][k])},
                     "bytes": method["bytes"]})  # fmt: skip
    return rows


_LOOKUP_C = r"""
#include <math.h>
static const float TABLE[%(n)d * %(n)d] = {%(values)s};
static double lookup(double mu, double alpha)
{
    const int n = %(n)d;
    double x = mu * n - 0.5, y = alpha * n - 0.5;
    x = x < 0.0 ? 0.0 : (x > n - 1 ? n - 1 : x);
    y = y < 0.0 ? 0.0 : (y > n - 1 ? n - 1 : y);
    int i = (int)x, j = (int)y;
    if (i > n - 2) i = n - 2;
    if (j > n - 2) j = n - 2;
    const double fx = x - i, fy = y - j;
    const double top = TABLE[j * n + i] * (1.0 - fx) + TABLE[j * n + i + 1] * fx;
    const double bottom = TABLE[(j + 1) * n + i] * (1.0 - fx) + TABLE[(j + 1) * n + i + 1] * fx;
    return top * (1.0 - fy) + bottom * fy;
}
void loop(const double *mu, const double *alpha, double *out, long count)
{
    for (long k = 0; k < count; ++k) out[k] = lookup(mu[k], alpha[k]);
}
"""


class _TableLib:
    """A compiled bilinear table read, callable like :class:`fitlab.codegen.native.NativeModel` by
    :func:`fitlab.codegen.bench.time_routines`."""

    def __init__(self, table: np.ndarray, workdir: Path):
        n = table.shape[0]
        src, lib = workdir / f"table{n}.c", workdir / f"table{n}.so"
        src.write_text(_LOOKUP_C % {"n": n, "values": ",".join(f"{x:.9g}f" for x in table.ravel())})
        subprocess.run([compiler(), "-std=c99", "-O2", "-shared", "-fPIC", str(src), "-o", str(lib)], check=True,
                       capture_output=True)  # fmt: skip
        self.lib = ctypes.CDLL(str(lib))
        p = ctypes.POINTER(ctypes.c_double)
        self.lib.loop.argtypes = [p, p, p, ctypes.c_long]

    def __call__(self, name, mu, alpha, dtype=np.float64):
        out = np.empty_like(mu)
        p = ctypes.POINTER(ctypes.c_double)
        self.lib.loop(mu.ctypes.data_as(p), alpha.ctypes.data_as(p), out.ctypes.data_as(p), mu.size)
        return out


def table_lookup_ns(model: str, sizes=TABLE_SIZES, extra_cases: dict | None = None, n: int = 200_000,
                    repeat: int = 5) -> dict:  # fmt: skip
    """ns per evaluation of the compiled bilinear read of each table size (and of ``extra_cases``, in
    :func:`fitlab.codegen.bench.time_routines`'s form), in one interleaved run."""
    from fitlab.codegen.bench import time_routines

    rng = np.random.default_rng(0)
    mu, alpha = rng.random(n), rng.random(n)
    with tempfile.TemporaryDirectory(prefix="fitlab-study-") as tmp:
        cases = {f"table {s} x {s}": (_TableLib(centre_table(model, s)[0], Path(tmp)), "loop", [mu, alpha], np.float64)
                 for s in sizes}  # fmt: skip
        cases.update(extra_cases or {})
        return time_routines(cases, repeat)


#: the alphas of the generated Kulla-Conti lobe's furnace (:func:`kulla_conti_furnace`)
KC_ALPHAS = (1e-6, 1e-5, 1e-4, 1e-3, *(float(f"{a:.3g}") for a in np.geomspace(0.01, 1.0, 17)))


def _graded_nodes(alpha: float, n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [0, 1], panels with edges at t alpha (t from 1/64 to 4096) and k/8."""
    edges = np.unique(
        np.clip(np.concatenate([[0.0], alpha * np.geomspace(1 / 64, 4096, 25), np.linspace(0, 1, 9)]), 0.0, 1.0)
    )
    x, w = np.polynomial.legendre.leggauss(n)
    lo, hi = edges[:-1, None], edges[1:, None]
    return (lo + (hi - lo) * (x + 1) / 2).ravel(), ((hi - lo) * w / 2).ravel()


def kulla_conti_furnace(native, alphas=KC_ALPHAS) -> list[dict]:
    """Per alpha and precision, max |a - 1| over mu_o of the exact single scattering plus the generated
    ``ms_kulla_conti`` (``native``: the compiled program, :func:`fitlab.codegen.native.build`), and where."""
    from scipy.optimize import minimize_scalar

    rows = []
    for alpha in alphas:
        mu_i, w = _graded_nodes(alpha)
        for dtype, label in ((np.float64, "double"), (np.float32, "float")):

            def error(mu_o, mu_i=mu_i, w=w, dtype=dtype, alpha=alpha):
                lobe = native(
                    "ms_kulla_conti",
                    mu_i.astype(dtype),
                    np.full(mu_i.shape, mu_o, dtype),
                    np.full(mu_i.shape, alpha, dtype),
                    dtype=dtype,
                ).astype(float)
                e = float(directional_albedo(float(mu_o), alpha, "ggx_correlated"))
                return abs(e + 2 * np.pi * float(np.sum(w * mu_i * lobe)) - 1.0)

            scan = np.unique(
                np.clip(
                    np.concatenate([[0.0, 1.0], alpha * np.geomspace(1 / 16, 1e4, 41), np.linspace(0, 1, 41)]), 0.0, 1.0
                )
            )
            errors = np.array([error(m) for m in scan])
            k = int(np.argmax(errors))
            best_mu, best = float(scan[k]), float(errors[k])
            lo, hi = scan[max(k - 1, 0)], scan[min(k + 1, len(scan) - 1)]
            if hi > lo:
                res = minimize_scalar(
                    lambda m: -error(m), bounds=(lo, hi), method="bounded", options={"xatol": 1e-3 * (hi - lo)}
                )
                if -res.fun > best:
                    best_mu, best = float(res.x), float(-res.fun)
            rows.append({"alpha": alpha, "precision": label, "max_furnace": best, "worst_mu_o": best_mu})
    return rows


def _kc_native():
    """The committed generated C of the family's program, compiled (None without a C compiler)."""
    from fitlab.codegen import load_program
    from fitlab.codegen.native import build
    from fitlab.resources import packaged_fits

    if compiler() is None:
        return None
    generated = packaged_fits() / "generated"
    files = {n: (generated / n).read_text() for n in ("microfacet_energy.c", "microfacet_energy.h")}
    with tempfile.TemporaryDirectory(prefix="kc_furnace_") as workdir:  # the loaded library outlives its file
        return build(files, load_program(family="microfacet_energy"), Path(workdir))


#: the roughnesses of the coloured-compensation table
COLOURED_ALPHAS = (0.25, 0.5, 1.0)


def coloured_compensation(model: str = "ggx_correlated", alphas=COLOURED_ALPHAS) -> list[dict]:
    """Per conductor of the fresnel family and linear sRGB channel: F0, the exact F_avg and Schlick's (20 F0 +
    1)/21, and Kulla-Conti's f_add of each at every alpha (docs/microfacet_energy_derivation.md).  A channel whose F0 or F_avg
    exceeds 1 (gold's red: a colour out of sRGB's gamut) has no f_add (None): the factor is defined for
    F_avg in [0, 1]."""
    from fitlab.core import HasMaterials, family_with

    materials = family_with(HasMaterials).materials()
    e_avg = average_albedo(np.asarray(alphas, dtype=float), model)
    rows = []
    for key, m in materials.items():
        if m.kind != "conductor":
            continue
        for c, channel in enumerate(("r", "g", "b")):
            f0, f_avg = float(m.F0[c]), float(m.F_avg[c])
            row = {
                "material": key,
                "name": m.name,
                "channel": channel,
                "F0": f0,
                "F_avg": f_avg,
                "F_avg_schlick": schlick_average(f0),
                "alphas": list(alphas),
                "E_avg": e_avg.tolist(),
            }
            if max(f0, f_avg) <= 1.0:
                row["f_add"] = exact.fresnel_compensation_factor(f_avg, e_avg).tolist()
                row["f_add_schlick"] = exact.fresnel_compensation_factor(row["F_avg_schlick"], e_avg).tolist()
            else:
                row["f_add"] = row["f_add_schlick"] = None
            rows.append(row)
    return rows


def _coloured_markdown(coloured: list[dict]) -> list[str]:
    alphas = coloured[0]["alphas"]
    heads = " | ".join(f"f_add, alpha = {a:g}" for a in alphas)
    out = [
        "## Coloured compensation of measured metals",
        "",
        "Kulla-Conti's coloured lobe f_ms_F = f_add f_ms, f_add = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), of "
        "height-correlated GGX, per linear sRGB channel of each measured conductor of the fresnel family "
        "(docs/fresnel.md): with the exact F_avg = 2 int_0^1 F mu dmu of its spectral Fresnel reflectance, "
        "and with the F_avg a renderer derives from Schlick's F of the same F0 = F(1), (20 F0 + 1)/21. Each "
        "f_add cell is exact / Schlick-derived; the last column is the largest relative difference of the "
        "Schlick-derived f_add over these roughnesses, which is the relative error of the compensation "
        "lobe's energy.",
        "",
        f"| metal | channel | F0 | F_avg exact | F_avg Schlick | {heads} | worst relative |",
        "|---|---|---|---|---|" + "---|" * len(alphas) + "---|",
    ]
    for r in coloured:
        if r["f_add"] is None:
            cells = " | ".join("-" for _ in alphas)
            worst = "- (F > 1: out of sRGB's gamut)"
        else:
            cells = " | ".join(f"{e:.4f} / {s:.4f}" for e, s in zip(r["f_add"], r["f_add_schlick"], strict=True))
            worst = f"{max(abs(s / e - 1) for e, s in zip(r['f_add'], r['f_add_schlick'], strict=True)):.1%}"
        out.append(
            f"| {r['name']} | {r['channel']} | {r['F0']:.4f} | {r['F_avg']:.4f} | {r['F_avg_schlick']:.4f} | "
            f"{cells} | {worst} |"
        )
    rel = [abs(s / e - 1) for r in coloured if r["f_add"] for e, s in zip(r["f_add"], r["f_add_schlick"], strict=True)]
    worst = max(
        (r for r in coloured if r["f_add"]),
        key=lambda r: max(abs(s / e - 1) for e, s in zip(r["f_add"], r["f_add_schlick"], strict=True)),
    )
    low = sum(r["F_avg_schlick"] > r["F_avg"] for r in coloured)
    out += [
        "",
        f"Schlick's F_avg is above the exact one in {low} of {len(coloured)} channels (Schlick's curve "
        f"lacks the dip of real metals below F0 near grazing), so the derived lobe is too bright; the largest "
        f"relative difference of f_add is {max(rel):.1%} ({worst['name']}, {worst['channel']}).",
        "",
    ]
    return out


def _g(x) -> str:
    return "-" if x is None else f"{x:.2e}"


def study_rows(models=STUDY_MODELS, sizes=TABLE_SIZES, fitted: dict | None = None) -> list[dict]:
    """Every model's rows: none, each table size (centres and nodes), and ``fitted`` ({model: [method]})."""
    rows = []
    for model in models:
        methods = [no_compensation()] + [table_method(model, s, nodes) for s in sizes for nodes in (False, True)]
        rows += measure(model, methods + list((fitted or {}).get(model, ())))
    return rows


def markdown(
    rows: list[dict], ns: dict, validation_n: int = 64, kc: list[dict] | None = None, coloured: list[dict] | None = None
) -> str:
    """docs/energy_compensation.md from :func:`study_rows`, :func:`table_lookup_ns`,
    :func:`kulla_conti_furnace` and :func:`coloured_compensation`."""
    out = ["# Energy compensation: what a renderer needs to know of E(mu, alpha)", "",
           "Generated by `python -m studies.microfacet_energy.energy_compensation --out docs` "
           "(do not edit); the "
           "method is in the module's docstring, the exact engine in `fitlab.families.microfacet_energy.exact`.",
           "",
           f"Validation set: {validation_n} x {validation_n} golden-ratio lattice in (mu, alpha) plus the edges "
           f"mu = 0, mu = 1, alpha = {ALPHA_MIN:g}, alpha = 1 ({(validation_n + 2) ** 2} points, none on a texel). "
           "Columns: max |E_hat - E| over the set and over its interior (mu, alpha >= 1/16), the white furnace "
           "error max |a - 1| of f + f_ms evaluated with the method's E_hat and E_avg_hat (F = 1; 0 for the exact "
           "E), where it is worst, and the memory kept.", ""]  # fmt: skip
    for model in dict.fromkeys(r["model"] for r in rows):
        out += [f"## {model}", "", "| method | max abs E | interior | furnace max | interior | worst (mu, alpha) | bytes |",
                "|---|---|---|---|---|---|---|"]  # fmt: skip
        for r in (r for r in rows if r["model"] == model):
            w = r["worst"]
            out.append(f"| {r['method']} | {_g(r['max_abs_E'])} | {_g(r['max_abs_E_interior'])} | "
                       f"{_g(r['max_furnace'])} | {_g(r['max_furnace_interior'])} | ({w['mu']:.3g}, {w['alpha']:.3g}) | "
                       f"{'-' if r['bytes'] is None else r['bytes']} |")  # fmt: skip
        out.append("")
    if kc:
        by = {(r["alpha"], r["precision"]): r for r in kc}
        alphas = list(dict.fromkeys(r["alpha"] for r in kc))
        out += [
            "## Exact single scattering plus the generated Kulla-Conti lobe",
            "",
            "The white furnace max |a - 1| over mu_o (searched for: a scan and a bounded search around its worst "
            "point) of the exact single scattering of height-correlated GGX plus the generated "
            "`ms_kulla_conti` (fitlab/fits/generated/microfacet_energy.c, double and `_f` float), the lobe "
            "integrated over mu_i on panels graded at multiples of alpha; the table figures above use the "
            "validation lattice, alpha >= 1e-3, instead.",
            "",
            "| alpha | double | worst mu_o | float | worst mu_o |",
            "|---|---|---|---|---|",
        ]
        for a in alphas:
            d, f = by[(a, "double")], by[(a, "float")]
            out.append(
                f"| {a:g} | {_g(d['max_furnace'])} | {d['worst_mu_o']:.3g} | {_g(f['max_furnace'])} | "
                f"{f['worst_mu_o']:.3g} |"
            )
        big = [by[(a, p)]["max_furnace"] for a in alphas if a >= 0.01 for p in ("double", "float")]
        small = [by[(a, p)]["max_furnace"] for a in alphas for p in ("double", "float")]
        out += [
            "",
            f"So, over these alphas: at most {max(big):.1e} for alpha >= 0.01 and {max(small):.1e} from "
            f"alpha = {min(alphas):g} up, float and double alike (float differs from double by at most "
            f"{max(abs(by[(a, 'float')]['max_furnace'] - by[(a, 'double')]['max_furnace']) for a in alphas):.0e}"
            "); the error is the fits' (E_ggx_cor, E_avg_ggx_cor), largest in the grazing layer mu_o ~ alpha "
            "as alpha -> 0.",
            "",
        ]
    if coloured:
        out += _coloured_markdown(coloured)
    out += [
        "## Why a fit's furnace can be far worse than its E",
        "",
        "The lobe is divided by 1 - E_avg_hat, which goes to 0 as alpha -> 0 (GGX becomes a mirror and "
        "loses nothing). A method whose E_avg_hat is not the average of its own E_hat (a fit of E beside a "
        "separate fit of E_avg, or a published E with a fitted E_avg) has a numerator and a denominator that "
        "do not vanish together there, and the ratio runs away at the smallest alpha: compare the whole-"
        "domain and interior furnace columns. A renderer that takes E_avg_hat = 2 int E_hat mu dmu from the "
        "same E_hat (or clamps the lobe where 1 - E_avg_hat is tiny) does not have this failure; a table "
        "and its own 1-D average nearly do that by construction.",
        "",
    ]
    out += [
        "## Cost",
        "",
        "ns per evaluation of E_hat in C (double, -O2), one interleaved run on this machine "
        "(only the ratios carry meaning): " + ", ".join(f"{k}: {v:.1f}" for k, v in ns.items()) + ".",
        "",
    ]
    sep = {r["method"]: r for r in rows if r["model"] == "ggx_separable"}
    t32, n32 = sep.get("table 32 x 32"), sep.get("table 32 x 32, nodes")
    if t32 is not None and n32 is not None:
        out += ["## The blog's \"32 x 32 is more than enough\"", "",
                f"For its GGX (separable Smith), a 32 x 32 texture of texel centres gets E within "
                f"{t32['max_abs_E_interior']:.1e} in the interior (mu, alpha >= 1/16) but only within "
                f"{t32['max_abs_E']:.1e} over the whole domain: the error sits in the half texel below the first "
                f"centre, alpha < 1/64, where GGX turns into a mirror and E changes fastest at grazing mu. "
                f"Addressed so that the texels fall on the nodes k/31, the same 32 x 32 texture reaches "
                f"{n32['max_abs_E_interior']:.1e} inside and {n32['max_abs_E']:.1e} overall. So: enough for about "
                f"1 % of E away from alpha -> 0, not everywhere.", ""]  # fmt: skip
    return "\n".join(out)


#: model -> (its E target, its E_avg target) in the family's registry
FIT_TARGETS = {
    "ggx_separable": ("E_ggx_sep", "E_avg_ggx_sep"),
    "ggx_correlated": ("E_ggx_cor", "E_avg_ggx_cor"),
    "oren_nayar": ("E_on", "E_avg_on"),
}


def fitted_methods(fits_dir=None) -> dict:
    """{model: [method]}: each E form with a saved fit in ``fits_dir`` (None: the packaged fits), paired with
    the default fit of E_avg, and every published preset of the E target with that same E_avg."""
    from fitlab.core import get_target
    from fitlab.store import fit_files, fit_path, fits_folder, load

    folder = fits_folder(fits_dir)
    out = {}
    for model, (e_name, avg_name) in FIT_TARGETS.items():
        avg = load(fit_path(folder, avg_name, get_target(avg_name).default_form))
        E_avg = lambda alpha, avg=avg: np.asarray(avg(alpha=np.asarray(alpha, dtype=float)), dtype=float)  # noqa: E731
        methods = []
        for path in fit_files(folder, e_name):
            fit = load(path)
            methods.append({"label": f"fit {path.name} + {avg_name}.json",
                            "E": lambda mu, alpha, fit=fit: np.asarray(fit(mu=mu, alpha=alpha), dtype=float),
                            "E_avg": E_avg, "bytes": 8 * len(fit.params)})  # fmt: skip
        target = get_target(e_name)
        for form_name, preset in target.published:
            form = target.forms[form_name]
            theta = form.vector(preset)
            methods.append({"label": f"published {form_name} / {preset} + {avg_name}.json",
                            "E": lambda mu, alpha, form=form, theta=theta: np.asarray(form.numpy_function(theta, mu, alpha), dtype=float),
                            "E_avg": E_avg, "bytes": 8 * len(form.free_params)})  # fmt: skip
        out[model] = methods
    return out


def main(argv=None) -> int:
    import argparse
    import json

    from fitlab._io import atomic_write_many

    p = argparse.ArgumentParser(
        prog="python -m studies.microfacet_energy.energy_compensation",
        description="Write energy_compensation.md and .json (the study of this module).",
    )
    p.add_argument("--out", default=".", help="folder for energy_compensation.md and .json")
    args = p.parse_args(argv)
    rows = study_rows(fitted=fitted_methods())
    ns = table_lookup_ns("ggx_separable")
    from fitlab.discover.cost import routine_cost

    for e_name in (FIT_TARGETS["ggx_separable"][0], FIT_TARGETS["ggx_correlated"][0]):
        ns[f"fit {e_name} (generated C, a separate run)"] = next(iter(routine_cost(e_name, [None]).values()))
    native = _kc_native()
    kc = kulla_conti_furnace(native) if native is not None else None
    coloured = coloured_compensation()
    out = Path(args.out)
    atomic_write_many(
        {
            out / "energy_compensation.md": markdown(rows, ns, kc=kc, coloured=coloured).encode(),
            out / "energy_compensation.json": json.dumps(
                {"rows": rows, "kulla_conti_furnace": kc, "coloured_compensation": coloured}, indent=1
            ).encode(),
        }
    )
    print(f"wrote {out / 'energy_compensation.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
