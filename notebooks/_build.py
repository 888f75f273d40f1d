"""Write the notebooks of this folder from the cells below (the notebooks' source).

    python notebooks/_build.py          # rewrite notebooks/*.ipynb
    python notebooks/_build.py --check  # exit 1 if a committed notebook differs

Edit the cells here, not in Jupyter, then rebuild: the committed notebooks carry
no outputs, and tests/test_notebooks.py checks that they match this file and
runs each of them top to bottom.  Every computation is fitlab's API (mostly
fitlab.residuals); the notebooks only choose grids and plot.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import nbformat

HERE = Path(__file__).resolve().parent

SETUP = '''\
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fitlab.resources import packaged_fits

# tests/test_notebooks.py sets FITLAB_NOTEBOOK_SMALL=1: coarse grids, a few seconds per notebook
SMALL = os.environ.get("FITLAB_NOTEBOOK_SMALL") == "1"
FITS = packaged_fits()  # the fits packaged with fitlab (fitlab.resources)
'''


def md(text: str):
    return nbformat.v4.new_markdown_cell(text.strip("\n"))


def code(text: str):
    return nbformat.v4.new_code_cell(text.strip("\n"))


# -----------------------------------------------------------------------------
H_FUNCTIONS = [
    md(r"""
# H-functions: where the approximations of H0 and H1 err

$H_0(\mu; c)$ and $H_1(\mu; c)$ are Chandrasekhar H-functions of the three-term Lambert-sphere
half space (docs/model.md, "H-functions"): the solutions of $H(\mu) = 1 + \mu H(\mu) \int_0^1 \Psi_m(v) H(v)/(\mu + v)\,dv$
for the characteristic functions $\Psi_0, \Psi_1$. `fitlab.families.lambert_sphere.exact.h_function` solves them
(Nyström + Newton; the Fock integral agrees to about 1e-13). The BRDF uses them at
$\mu = \mu_i$ and $\mu = \mu_o$, so errors are wanted over the whole square $(\mu, c) \in [0, 1]^2$.

The approximations:
* **published**: Hapke-style $H_0$ (eq. 31) and the separable $H_1$ (two readings of the printed form, and
  the renderer's coefficients), as presets of `fitlab.forms`;
* **fits** in `fits/`: the same forms refitted (`fitlab refit --target H0`), the richer `hapke_rational` form of
  $H_0$, and whatever else is saved there for the target (e.g. the forms `fitlab discover` found, `H0.sr_*.json`).

The error is relative, $|H_\text{approx} - H|/H$. What to look for:
* where each fit's largest errors lie (a minimax fit spreads its error evenly; docs/fitting.md shows why the
  eq. 31 form cannot do better than 0.484 % at $c = 1$);
* whether the refits trade accuracy at small $c$ for accuracy near $c = 1$ (the $H_0$ refit weights small $c$
  more: the runtime model is most sensitive there);
* grazing angles: the exact $H - 1$ vanishes like $\mu \log(1/\mu)$ as $\mu \to 0$; a form that vanishes like a
  power $\mu^d$, $d < 1$, can be accurate in $H$ and still wrong in $(H - 1)/\mu$, which the BRDF divides out
  (see 04_brdf.ipynb, grazing behaviour).
"""),
    code(SETUP + '''
from fitlab.families.lambert_sphere.exact import h_function
from fitlab.core import get_target, targets
from fitlab.residuals import approximations, heatmap, residuals
'''),
    md(r"""
## The grid

With full settings the grid is the refits' own validation grid (`get_target(...).validation()`: $c = 1 - s^2$,
$s$ and $\mu$ at odd multiples of 1/256, plus the edges and $\mu$ = 1e-10, 1e-7, 1e-5), so every maximum below is
the one stored in the fit record. With `SMALL` it is a coarse grid of the same kind.
"""),
    code('''
if SMALL:
    MU = np.concatenate(([0.0, 1e-5], np.linspace(1 / 16, 1, 16)))
    C = np.sort(1 - np.linspace(0, 1, 13) ** 2)
else:
    validation = get_target("H0").validation()  # H1's validation set has the same points
    MU, C = np.unique(validation.inputs["mu"]), np.unique(validation.inputs["c"])
print(f"{MU.size} values of mu x {C.size} values of c")

found = {name: approximations(name, FITS) for name in ("H0", "H1")}
res = {name: {label: residuals(name, a, mu=MU, c=C) for label, a in found[name].items()} for name in found}
'''),
    md(r"""
## The exact functions

$H_0$ and $H_1$ rise from 1 at grazing ($\mu = 0$); $H_0$ grows fastest at $c = 1$, where $H_0(\infty)$ is infinite
(the conservative case, eq. 32).
"""),
    code('''
fig, axes = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
mu = np.linspace(0, 1, 101)
for ax, order in zip(axes, (0, 1)):
    for c in (0.3, 0.7, 0.9, 0.99, 1.0):
        ax.plot(mu, h_function(order, mu, c), label=f"c = {c}")
    ax.set(xlabel="mu", ylabel=f"H{order}(mu; c)", title=f"exact H{order}")
axes[0].legend()
plt.show()
'''),
    md(r"""
## Summary

`max` is the largest relative error on the grid, `rms` its root mean square; `worst at` is where the maximum lies.
For the refits, `record` is the validation maximum stored in the fit file (with full settings the two agree).
"""),
    code('''
print(f"{'approximation':<54} {'max':>9} {'rms':>9} {'record':>9}  worst at")
for name, by_label in res.items():
    for label, r in by_label.items():
        s = r.summary()
        fit = found[name][label]
        record = f"{fit.record['validation']['max_rel']:9.2e}" if hasattr(fit, "record") else " " * 9
        w = s["worst"]
        print(f"{name + ': ' + label:<54} {s['max_rel']:9.2e} {s['rms_rel']:9.2e} {record}  mu = {w['mu']:.4g}, c = {w['c']:.4g}")
'''),
    md(r"""
## Heat maps over $(\mu, c)$

One colour scale for all panels (log, 1e-6 to 1e-1). The rows are $H_0$ and $H_1$; the columns the best published
preset, then every saved fit (the refit of the same form first). Look at where the colour is brightest, and at how
evenly a minimax refit spreads its error compared with the published preset.
"""),
    code('''
def best_published(name):
    published = {label: r for label, r in res[name].items() if r.published}
    return min(published.values(), key=lambda r: r.summary()["max_rel"])


def saved_fits(name):
    return [r for r in res[name].values() if not r.published]


rows = {name: [best_published(name), *saved_fits(name)] for name in res}
ncols = max(len(v) for v in rows.values())
fig, axes = plt.subplots(len(rows), ncols, figsize=(4.6 * ncols, 3.8 * len(rows)), layout="constrained", squeeze=False)
for row, (name, panels) in zip(axes, rows.items()):
    for ax, r in zip(row, panels):
        heatmap(r, "mu", "c", ax=ax, vmin=1e-6, vmax=1e-1)
        ax.set_title(f"{name}: " + ax.get_title(), fontsize="medium")
    for ax in row[len(panels):]:
        ax.set_visible(False)
plt.show()
'''),
    md(r"""
## Slices

Left: the error along $\mu$ at a few fixed $c$ (the grid value nearest to each; log $\mu$, to show grazing angles);
right: along $c$ at fixed $\mu$. Solid lines are the refit of the default form, dashed the best published preset.
"""),
    code('''
fig, axes = plt.subplots(2, 2, figsize=(11, 7), layout="constrained")
for row, name in zip(axes, res):
    refit = res[name][next(label for label in res[name] if label.endswith(f"({name}.json)"))]
    published = best_published(name)
    for c, colour in zip((0.5, 0.9, 0.99, 1.0), ("C0", "C1", "C2", "C3")):
        for r, style in ((refit, "-"), (published, "--")):
            s = r.at(c=c)
            row[0].loglog(s.axes["mu"], s.error, style, color=colour, label=f"c = {s.fixed['c']:.3g}" if style == "-" else None)
    for mu, colour in zip((0.01, 0.3, 1.0), ("C0", "C1", "C2")):
        for r, style in ((refit, "-"), (published, "--")):
            s = r.at(mu=mu)
            row[1].semilogy(s.axes["c"], s.error, style, color=colour, label=f"mu = {s.fixed['mu']:.3g}" if style == "-" else None)
    row[0].set(xlabel="mu", ylabel="relative error", title=f"{name} at fixed c (solid: {refit.label}; dashed: {published.label})")
    row[1].set(xlabel="c", ylabel="relative error", title=f"{name} at fixed mu")
    row[0].legend(fontsize="small")
    row[1].legend(fontsize="small")
plt.show()
'''),
    md(r"""
## The worst points

The largest errors of the best published preset and of each saved fit, with the exact and approximate values.
Neighbouring grid points of one peak follow each other in the list.
"""),
    code('''
for name in res:
    for r in (best_published(name), *saved_fits(name)):
        print(f"{name}: " + r.table(6), end="\\n\\n")
'''),
]

# -----------------------------------------------------------------------------
CONSTANTS = [
    md(r"""
# Constants: l, m (order 1) and B, C, D, F (order 0)

The Fourier orders of the three-term BRDF (docs/model.md, "Order 0", "Order 1") need a handful of functions of $c$ alone:
$l(c), m(c)$ in $f^{(1)}$ (eq. 22) and $B, C, D, F$ in the polynomial $Q$ of $f^{(0)}$ (eq. 30),
$Q = A + B(\mu_i+\mu_o) + C\mu_i\mu_o + D\mu_i\mu_o(\mu_i+\mu_o) + E\mu_i^2\mu_o^2 + F(\mu_i^2+\mu_o^2)$ with
$A = 69c/128$ and $E$ exact (eq. 33). `fitlab.families.lambert_sphere.exact.constants` computes them from moments of the exact H-functions.

Errors use each target's own scale (`fitlab.families.lambert_sphere.targets`):
* $l$, $m$: relative, $|\Delta l|/|l|$;
* $B, C, D, F$: **relative to $A$**, $|\Delta X|/A$. $B$ changes sign near $c = 0.94$ and $D$, $F$ vanish at $c = 1$, so
  $|\Delta X|/|X|$ has no bound; an error $\Delta X$ moves $Q$ (and $f^{(0)}$) by at most $2|\Delta X|$ against $A$.

All four printed rationals for $B..F$ miss the exact zero at $c = 0$, an infinite error in this measure:
`max*` below leaves the exact zeros out.
"""),
    code(SETUP + '''
from fitlab.families.lambert_sphere.exact import constants
from fitlab.core import get_target, targets
from fitlab.residuals import approximations, residuals

NAMES = ("l", "m", "B", "C", "D", "F")
'''),
    md(r"""
## The grid

$c = 1 - s^2$ for evenly spaced $s$, dense near $c = 1$ where the constants bend. With full settings: the refits'
validation grid ($s$ at odd multiples of 1/256 plus the edges), as in the fit records.
"""),
    code('''
if SMALL:
    C = np.sort(1 - np.linspace(0, 1, 17) ** 2)
else:
    C = np.unique(get_target("l").validation().inputs["c"])
found = {name: approximations(name, FITS) for name in NAMES}
res = {name: {label: residuals(name, a, c=C) for label, a in found[name].items()} for name in NAMES}
print(f"{C.size} values of c; approximations: " + ", ".join(f"{n}: {len(v)}" for n, v in found.items()))
'''),
    md(r"""
## The exact constants and the approximations

Each panel shows the exact constant (black) and every approximation; at this scale they overlap: the errors
are below.
"""),
    code('''
fig, axes = plt.subplots(2, 3, figsize=(13, 7), layout="constrained")
for ax, name in zip(axes.flat, NAMES):
    ax.plot(C, next(iter(res[name].values())).exact, "k", lw=3, alpha=0.4, label="exact")
    for label, r in res[name].items():
        ax.plot(C, r.approx, lw=1, label=label)
    ax.set(xlabel="c", title=name)
    ax.legend(fontsize="x-small")
plt.show()
'''),
    md(r"""
## Errors along $c$

Log scale; dashed lines are the published presets. Points with zero error (exact zeros the form builds in) are
not drawn.
"""),
    code('''
fig, axes = plt.subplots(2, 3, figsize=(13, 7), layout="constrained")
for ax, name in zip(axes.flat, NAMES):
    for label, r in res[name].items():
        ax.semilogy(C, r.error, "--" if r.published else "-", label=label)
    ax.set(xlabel="c", ylabel=next(iter(res[name].values())).error_measure.split(":")[0], title=name)
    ax.legend(fontsize="x-small")
plt.show()
'''),
    md(r"""
## Summary and worst points

`max*` leaves out the target's exact zeros ($c = 0$ for $B..F$), `worst at` is where `max*` lies.
"""),
    code('''
print(f"{'approximation':<44} {'max':>9} {'max*':>9} {'rms':>9}  worst at")
for name in NAMES:
    for label, r in res[name].items():
        s = r.summary()
        nonzero = r.scale > 0
        worst_c = r.axes["c"][nonzero][np.argmax(r.error[nonzero])]
        print(f"{name + ': ' + label:<44} {s['max_rel']:9.2e} {s['max_rel_nonzero']:9.2e} {s['rms_rel']:9.2e}  c = {worst_c:.4g}")
'''),
    code('''
for name in NAMES:
    refit = next(r for label, r in res[name].items() if label.endswith(f"({name}.json)"))
    print(refit.table(4), end="\\n\\n")
'''),
    md(r"""
## An identity: the runtime model needs no fit of $m$

The order-1 term uses $l$ and $m$ only through $l$ and $l^2 + 45m/64$, and the moment relations give
$l^2 + 45m/64 = (45 + 20c)/64$ exactly (docs/fitting.md). The exact constants confirm it to rounding:
"""),
    code('''
exact = constants(C)
deviation = np.abs(exact["l"] ** 2 + 45 * exact["m"] / 64 - (45 + 20 * C) / 64)
print(f"max |l^2 + 45 m/64 - (45 + 20c)/64| over {C.size} values of c: {deviation.max():.1e}")
'''),
]

# -----------------------------------------------------------------------------
ALBEDO = [
    md(r"""
# Albedo maps: $k_d(c)$, $c(k_d)$ and the round trip

A renderer is given the spherical (Bond) albedo $k_d$ of the material, the fraction of light it reflects, and
needs the particle albedo $c$. `fitlab.families.lambert_sphere.exact.spherical_albedo(c, model="true")` integrates the exact BRDF (true
phase function in single scattering): $k_d$ = kd_true(c). The two maps are fitted separately:
* `kd_of_c`: $k_d(c)$, the printed form (which misses $k_d(0) = 0$) and forms that build the zero in;
* `c_of_kd`: its inverse (paper and renderer coefficients, and the refit).

Note kd_true(1) = 1 + 1e-5, not 1 (docs/errata.md): the inverse is fitted and measured on $k_d \le 1$ only, so the
$c$ grid of `c_of_kd` leaves out $c = 1$.

Errors are relative. The last section composes the two fitted maps: a renderer that converts $k_d \to c$ and
back should get its $k_d$ back.
"""),
    code(SETUP + '''
from fitlab.families.lambert_sphere.exact import spherical_albedo
from fitlab.core import get_target, targets
from fitlab.store import load
from fitlab.residuals import approximations, residuals
'''),
    code('''
if SMALL:  # every new c costs the exact engine up to seconds (most near c = 1)
    C = np.array([0.0, 0.25, 0.5, 0.75, 0.9, 0.97, 1.0])
else:
    C = np.unique(get_target("kd_of_c").validation().inputs["c"])
C_INV = C[C < 1]  # c_of_kd is fitted and measured on kd <= 1: every c but c = 1 (its validation set)

kd_res = {label: residuals("kd_of_c", a, c=C) for label, a in approximations("kd_of_c", FITS).items()}
c_res = {label: residuals("c_of_kd", a, c=C_INV) for label, a in approximations("c_of_kd", FITS).items()}
print(f"{C.size} values of c")
'''),
    md(r"""
## The exact map, and the three-term phase function

The three-term half space alone (`model="three_term"`) gives a slightly different albedo; the true phase function
enters only through single scattering, so the difference grows in proportion to $c$.
"""),
    code('''
kd_true, kd_three = spherical_albedo(C, model="true"), spherical_albedo(C, model="three_term")
fig, axes = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
axes[0].plot(C, kd_true, ".-", label="kd_true (exact BRDF)")
axes[0].plot(C, C, ":", color="grey", label="kd = c")
axes[0].set(xlabel="c", ylabel="kd", title="spherical albedo")
axes[0].legend()
axes[1].plot(C, kd_true - kd_three, ".-")
axes[1].set(xlabel="c", ylabel="kd_true - kd_three_term", title="true vs three-term phase function")
plt.show()
'''),
    md(r"""
## Errors of $k_d(c)$ and $c(k_d)$

Dashed lines are published presets. The printed $k_d(c)$ misses $k_d(0) = 0$ (infinite relative error at $c = 0$, not
drawn on a log scale); the refitted forms are exact there.
"""),
    code('''
fig, axes = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
for label, r in kd_res.items():
    axes[0].semilogy(r.axes["c"], r.error, "--" if r.published else "-", label=label)
axes[0].set(xlabel="c", ylabel="relative error", title="kd_of_c")
for label, r in c_res.items():
    axes[1].semilogy(r.inputs["kd"], r.error, "--" if r.published else "-", label=label)
axes[1].set(xlabel="kd", ylabel="relative error", title="c_of_kd")
for ax in axes:
    ax.legend(fontsize="small")
plt.show()

for group in (kd_res, c_res):
    for label, r in group.items():
        s = r.summary()
        where = ", ".join(f"{k} = {v:.4g}" for k, v in s["worst"].items() if k not in ("exact", "approx"))
        print(f"{r.target + ': ' + label:<58} max {s['max_rel']:.2e}  max* {s['max_rel_nonzero']:.2e}  rms {s['rms_rel']:.2e}  at {where}")
'''),
    code('''
for r in (*kd_res.values(), *c_res.values()):
    if not r.published:
        print(r.table(5), end="\\n\\n")
'''),
    md(r"""
## The round trip

With the refitted maps, $c \to k_d(c) \to c(k_d)$ should return $c$, and $k_d \to c(k_d) \to k_d(c)$ should
return $k_d$. The two fits are independent, so their errors add (or cancel); the round trip shows what a renderer
that converts both ways actually gets. The same for the published pair (paper $k_d(c)$, renderer $c(k_d)$).
"""),
    code('''
kd_of_c, c_of_kd = load(FITS / "kd_of_c.json"), load(FITS / "c_of_kd.json")
c = C_INV[C_INV > 0]
kd = spherical_albedo(c, model="true")  # exact kd in (0, 1)
c_back = c_of_kd(kd=kd)
# just below kd = 1 the fitted c(kd) overshoots 1 by rounding-level amounts; a loaded fit refuses
# inputs outside its domain, and the generated code clamps c into [0, 1]: do the same here
print(f"largest c(kd) - 1: {np.max(c_back - 1):.1e}")

trips = {
    "refits: c -> kd -> c": (c, c_of_kd(kd=kd_of_c(c=c))),
    "refits: kd -> c -> kd": (kd, kd_of_c(c=np.clip(c_back, 0, 1))),
    "published: c -> kd -> c": (c, get_target("c_of_kd").forms["rational_power"]("renderer", get_target("kd_of_c").forms["printed"]("paper", c))),
}
fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
for label, (start, back) in trips.items():
    err = np.abs(back - start) / start
    ax.semilogy(c, err, label=label)
    print(f"{label:<26} max relative round-trip error {err.max():.2e} at c = {c[np.argmax(err)]:.4g}")
ax.set(xlabel="c", ylabel="relative round-trip error")
ax.legend()
plt.show()
'''),
]

# -----------------------------------------------------------------------------
BRDF = [
    md(r"""
# The full BRDF: the runtime model and the fast variant

`fitlab.families.lambert_sphere.runtime.runtime_model` assembles the runtime BRDF (docs/model.md),
$f_r = \max(0, f_1 + f_m^{(0)} + f_m^{(1)}\cos\phi)$: exact single scattering with the true phase function plus the
multiple scattering of Fourier orders 0 and 1 built from approximations of $H_0$, $H_1$, $l$, $m$, $B..F$.
It is measured against `fitlab.families.lambert_sphere.exact.brdf`, the reference (all three Fourier orders, exact H-functions).
The fast variant (eq. 41) replaces the multiple scattering by a lobe and a constant in $k_d$ = kd_true(c).

Models compared:
* `paper`: printed coefficients, renderer reading of $H_1$, exact normalisations;
* `refit`: the default forms refitted (`fits/*.json`);
* `refit (richer)`: the richer forms where fitted (`hapke_rational` $H_0$, cubic $l$, ...);
* the fast variant, published and refitted.

Errors are relative, $|f_\text{model} - f|/f$. The order-2 term that the runtime model drops, and the grazing pole
at $\mu_i = \mu_o = 0$ (where the exact $f_r$ grows like $\log(1/\mu)$ at $\phi = \pi$, and like $1/\mu$ through
single scattering elsewhere), set floors no fit of the parts can remove.
$\phi = 0$ is back-scattering (the viewer beside the light).
"""),
    code(SETUP + '''
from fitlab.families.lambert_sphere.exact import brdf
from fitlab.store import load
from fitlab.residuals import brdf_residuals, heatmap, residuals
from fitlab.families.lambert_sphere.runtime import runtime_model
'''),
    code('''
RICHER = {"H0": "hapke_rational", "l": "cubic", "m": "quadratic", **{n: "rational_4_3" for n in "BCDF"}}
MODELS = {
    "paper": runtime_model("paper"),
    "refit": runtime_model(fits_dir=FITS),
    "refit (richer)": runtime_model(fits_dir=FITS, forms=RICHER),
}
FAST = {"fast / paper": ("paper", "paper"), "fast / refit": load(FITS / "fast_brdf.json")}

n = 13 if SMALL else 41
MU = np.geomspace(1e-3, 1, n)  # log-spaced: grazing angles get room
PHI = np.array([0.0, np.pi / 2, np.pi])
C = np.array([0.5, 0.99]) if SMALL else np.array([0.3, 0.9, 0.99])
axes = dict(mu_i=MU, mu_o=MU, phi=PHI, c=C)
res = {label: brdf_residuals(m, label=label, **axes) for label, m in MODELS.items()}
res |= {label: residuals("fast_brdf", a, label=label, **axes) for label, a in FAST.items()}
print(f"{MU.size}^2 directions x {PHI.size} azimuths x {C.size} albedos")
'''),
    md(r"""
## Summary

`max` over the whole grid, `max (mu >= 0.1)` away from grazing, and where the maximum lies.
"""),
    code('''
print(f"{'model':<16} {'max':>9} {'rms':>9} {'max (mu >= 0.1)':>16}  worst at")
for label, r in res.items():
    s = r.summary()
    away = (r.inputs["mu_i"] >= 0.1) & (r.inputs["mu_o"] >= 0.1)
    w = s["worst"]
    print(f"{label:<16} {s['max_rel']:9.2e} {s['rms_rel']:9.2e} {r.error[away].max():16.2e}  "
          f"mu_i = {w['mu_i']:.3g}, mu_o = {w['mu_o']:.3g}, phi = {w['phi']:.3g}, c = {w['c']:.3g}")
'''),
    md(r"""
## Heat maps over $(\mu_i, \mu_o)$

Rows are albedos, columns azimuths; log axes in $\mu$ and a log colour scale (1e-4 to 1). First the refitted runtime
model, then the refitted fast variant. The diagonal $\mu_i = \mu_o$ at $\phi = \pi$ is where the grazing pole bites.
"""),
    code('''
def heatmaps(r):
    fig, grid = plt.subplots(C.size, PHI.size, figsize=(4.2 * PHI.size, 3.4 * C.size), layout="constrained", squeeze=False)
    for row, c in zip(grid, C):
        for ax, phi in zip(row, PHI):
            heatmap(r.at(phi=phi, c=c), "mu_i", "mu_o", ax=ax, vmin=1e-4, vmax=1.0, colorbar=phi == PHI[-1])
            ax.set(xscale="log", yscale="log")
    fig.suptitle(r.label)
    plt.show()


heatmaps(res["refit"])
'''),
    code('''
heatmaps(res["fast / refit"])
'''),
    md(r"""
## Polar slices in the plane of incidence

Light at $\theta_i = 60°$; the viewer moves through the plane of incidence, $\theta_o$ from $-89°$ (beside the light,
$\phi = 0$) to $+89°$ (opposite, $\phi = \pi$). Left: $f_r$ (1/sr); right: the relative error of each model.
"""),
    code('''
theta = np.radians(np.linspace(0, 89, 30 if SMALL else 90))
mu_i = np.cos(np.radians(60.0))
c = 0.9
plane = {label: brdf_residuals(m, label=label, mu_i=[mu_i], mu_o=np.cos(theta), phi=[0.0, np.pi], c=[c]) for label, m in MODELS.items()}
plane |= {label: residuals("fast_brdf", a, label=label, mu_i=[mu_i], mu_o=np.cos(theta), phi=[0.0, np.pi], c=[c]) for label, a in FAST.items()}


def signed(values):  # (phi = 0 side, phi = pi side) -> one curve over signed theta_o
    return np.concatenate((values[::-1, 0], values[:, 1]))


angle = np.concatenate((-theta[::-1], theta))
fig = plt.figure(figsize=(12, 4.5), layout="constrained")
polar = fig.add_subplot(1, 2, 1, projection="polar")
polar.set(theta_zero_location="N", theta_direction=-1, thetamin=-90, thetamax=90, title=f"f_r (1/sr), theta_i = 60 deg, c = {c}; grey: exact")
polar.plot(angle, signed(next(iter(plane.values())).exact[0, :, :, 0]), "k", lw=3, alpha=0.4, label="exact")
errors = fig.add_subplot(1, 2, 2)
for label, r in plane.items():
    polar.plot(angle, signed(r.approx[0, :, :, 0]), lw=1, label=label)
    errors.semilogy(np.degrees(angle), signed(r.error[0, :, :, 0]), label=label)
polar.set_rticks(np.linspace(0, polar.get_rmax(), 4)[1:].round(2))
errors.set(xlabel="theta_o (deg); negative: the light's side (phi = 0)", ylabel="relative error")
errors.legend(fontsize="small")
plt.show()
'''),
    md(r"""
## Grazing behaviour

Along $\mu_i = \mu_o = \mu \to 0$ (the diagonal of the grid, extended to $\mu$ = 1e-6):
* at $\phi = 0$ single scattering, $c\,p(u)/(2\mu)$, dominates and every model follows it;
* at $\phi = \pi$ single scattering vanishes ($u \to 1$) and the exact BRDF grows like $\log(1/\mu)$ through its
  multiple-scattering orders. Every member of the fast family stays bounded there, so its relative error tends to 1
  (docs/fitting.md). The runtime models do not stay bounded: the separable $H_1$ form,
  $\exp(k(c)\,\mu^{e(\mu)})$, approaches 1 like $\mu^{e(0)}$ with $e(0) < 1$, where the exact $H_1 - 1$ goes like
  $\mu\log\mu$, so $(H_1(\mu_i)H_1(\mu_o) - 1)/(\mu_i + \mu_o)$ in $f_m^{(1)}$ grows like a power of $1/\mu$ instead
  of $\log(1/\mu)$. The printed cells below show the size of this at the smallest $\mu$.
"""),
    code('''
mu = np.geomspace(1e-6, 1, 13 if SMALL else 49)
diag = {label: brdf_residuals(m, label=label, mu_i=mu, mu_o=mu, phi=PHI, c=[0.9]) for label, m in MODELS.items()}
diag |= {label: residuals("fast_brdf", a, label=label, mu_i=mu, mu_o=mu, phi=PHI, c=[0.9]) for label, a in FAST.items()}

fig, axes = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
for k, (phi, style) in enumerate(zip(PHI, ("-", ":", "--"))):
    first = next(iter(diag.values()))
    axes[0].loglog(mu, np.diagonal(first.exact[:, :, k, 0]), style, color="k", lw=3, alpha=0.4, label=f"exact, phi = {phi:.2f}")
    for j, (label, r) in enumerate(diag.items()):
        axes[0].loglog(mu, np.diagonal(r.approx[:, :, k, 0]), style, color=f"C{j}", lw=1, label=label if k == 0 else None)
        axes[1].loglog(mu, np.diagonal(r.error[:, :, k, 0]), style, color=f"C{j}", label=label if k == 0 else None)
axes[0].set(xlabel="mu_i = mu_o", ylabel="f_r (1/sr)", title="c = 0.9; line style: phi = 0, pi/2, pi")
axes[1].set(xlabel="mu_i = mu_o", ylabel="relative error")
axes[0].legend(fontsize="x-small")
axes[1].legend(fontsize="x-small")
plt.show()

k = int(np.argmin(np.abs(PHI - np.pi)))
for label, r in diag.items():
    print(f"{label:<16} phi = pi, mu_i = mu_o = {mu[0]:.0e}: exact {r.exact[0, 0, k, 0]:.4g}, model {r.approx[0, 0, k, 0]:.4g}, "
          f"relative error {r.error[0, 0, k, 0]:.3g}")
'''),
    md(r"""
## The worst points

The grid points of largest error for the refitted runtime model and the refitted fast variant.
"""),
    code('''
for label in ("refit", "refit (richer)", "fast / refit"):
    print(res[label].table(8), end="\\n\\n")
'''),
    md(r"""
## One part on its own: $f_m^{(1)}$

The fast $f_m^{(1)}$ of eq. 29 against the exact order-1 multiple scattering, measured relative to $f^{(0)}$ (the
azimuthal mean of the exact BRDF; $f_m^{(1)}$ itself vanishes at $c = 0$ and $\mu = 1$). The published coefficient
was fitted to the halved $f_m^{(1)}$ of eq. 28 as printed (docs/errata.md); the refit is not.
"""),
    code('''
fm1 = {label: residuals("fm1", a, mu_i=MU, mu_o=MU, c=[0.9]) for label, a in (("fast / paper", ("fast", "paper")), ("fast / refit", load(FITS / "fm1.json")))}
fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
for ax, r in zip(axes, fm1.values()):
    heatmap(r.at(c=0.9), "mu_i", "mu_o", ax=ax, vmin=1e-4, vmax=1e-1)
    ax.set(xscale="log", yscale="log")
plt.show()
'''),
]

# -----------------------------------------------------------------------------
WALKTHROUGH = [
    md(r"""
# Refit a target and generate code: a walkthrough

This notebook does, through the Python API, what these commands do:

```
fitlab refit --list
fitlab refit --target H1 --out SCRATCH/fits
fitlab codegen --lang python --fits SCRATCH/fits --out SCRATCH/generated
fitlab codegen --lang c --fits SCRATCH/fits --out SCRATCH/generated
```

It works in a scratch folder, so the fits packaged with fitlab stay as they are.
"""),
    code(SETUP + '''
import importlib.util
import inspect
import shutil
import tempfile
import time

from fitlab.codegen import generate, load_program, write_generated
from fitlab.codegen.native import CompileError, build, compiler
from fitlab.families.lambert_sphere.exact import brdf, h_function
from fitlab.fit.refit import refit, table
from fitlab.store import fit_path, write_fit
from fitlab.core import get_target, targets
from fitlab.store import load
from fitlab.families.lambert_sphere.runtime import runtime_model
'''),
    md(r"""
## 1. The targets

Each target is something the exact engine computes (`fitlab.families.lambert_sphere.targets`), with its forms (`fitlab.forms`: one sympy
expression each, with published presets) and the form `fitlab refit` fits by default.
"""),
    code('''
for t in targets().values():
    forms = ", ".join(f"{f}*" if f == t.default_form else f for f in t.forms)
    print(f"{t.name:<10} {forms:<42} {t.description}")
print("* the default form")
'''),
    code('''
t = get_target("H1")
form = t.forms[t.default_form]
print(form.description)
print("expression:", form.expression)
print("parameters:", form.params, " fixed:", dict(form.fixed))
print("error measure:", t.error_measure)
'''),
    md(r"""
## 2. Refit into a scratch folder

The code generator needs a fit of every part of the runtime model, so the scratch folder starts as a copy of the
committed fits; the refit of $H_1$ then replaces `H1.json` in it. `refit` fits the training set (the table
`h1.csv` of the packaged exact tables: least squares with optimistix, then a Lawson minimax refinement), measures the fit and every
published preset on the denser validation set and writes the record. With `SMALL` the minimax refinement is
skipped: compare its maximum with the committed fit's to see what the refinement buys.
"""),
    code('''
scratch = Path(tempfile.mkdtemp(prefix="fitlab-walkthrough-"))
shutil.copytree(FITS, scratch / "fits", ignore=shutil.ignore_patterns("generated", "README.md"))

start = time.perf_counter()
result = refit("H1", minimax=not SMALL)
wall = time.perf_counter() - start
print(table([result], [wall]))
path = fit_path(scratch / "fits", "H1", result.record["form"])
write_fit(path, result.record)
print("written:", path)
'''),
    md(r"""
## 3. The record

The JSON file holds everything needed to evaluate and judge the fit: the expression, the parameters, the domain, the
validation metrics (with the worst point), the published presets measured the same way, and the optimizer's settings.
"""),
    code('''
record = result.record
print("params:", record["params"])
print("validation:", {k: record["validation"][k] for k in ("max_rel", "rms_rel", "points", "worst")})
for p in record["published"]:
    print(f"published {p['form']} / {p['preset']}: max {p['validation']['max_rel']:.3g}")
print("optimizer:", record["optimizer"]["objective"])
committed = load(FITS / "H1.json")
print(f"committed fit: max {committed.record['validation']['max_rel']:.3e};  this refit: max {record['validation']['max_rel']:.3e}")
'''),
    md(r"""
## 4. Load and evaluate

`fitlab.store.load` turns the file into a numpy callable (the file alone suffices: the expression is in it). Inputs go
by name or position; outside the fit's domain it refuses.
"""),
    code('''
h1 = load(path)
mu = np.array([0.0, 0.1, 0.5, 1.0])
c = 0.9
print(h1)
for mi, fi, ei in zip(mu, h1(mu=mu, c=c), h_function(1, mu, c)):
    print(f"mu = {mi:<4} c = {c}  fit {fi:.6f}  exact {ei:.6f}")
try:
    h1(mu=1.5, c=c)
except ValueError as err:
    print("outside the domain:", err)
'''),
    md(r"""
## 5. Generate Python and compare

`generate("python", fits_dir)` prints the runtime BRDF and every fitted part from the fits and the sympy forms; the
module needs only numpy. It should agree with the same model evaluated through fitlab (`runtime_model(fits_dir=...)`)
to rounding. Note the generated `brdf` takes $\cos\phi$, `runtime_model` takes $\phi$.
"""),
    code('''
paths = write_generated(generate("python", fits_dir=scratch / "fits"), scratch / "generated")
print("wrote", [p.name for p in paths])
spec = importlib.util.spec_from_file_location("lambert_sphere_walkthrough", scratch / "generated" / "lambert_sphere.py")
generated = importlib.util.module_from_spec(spec)
spec.loader.exec_module(generated)
print(inspect.getsource(generated.h1))
print("h1, generated vs loaded fit: max |difference| =", np.abs(generated.h1(mu, c) - h1(mu=mu, c=c)).max())
'''),
    code('''
rng = np.random.default_rng(0)
n = 2000 if SMALL else 100_000
mu_i, mu_o = rng.uniform(0.01, 1, (2, n))
phi = rng.uniform(0, np.pi, n)
c = rng.choice([0.2, 0.5, 0.8, 0.95, 1.0], n)  # a few albedos: the exact engine solves the H-equations once per c
model = runtime_model(fits_dir=scratch / "fits")
via_fitlab = model(mu_i, mu_o, phi, c)
via_generated = generated.brdf(mu_i, mu_o, np.cos(phi), c)
print(f"generated vs runtime_model: max relative difference {np.max(np.abs(via_generated - via_fitlab) / via_fitlab):.1e}")
exact = brdf(mu_i, mu_o, phi, c)
err = np.abs(via_generated - exact) / exact
print(f"generated vs exact BRDF ({n} random points, mu >= 0.01): max relative error {err.max():.2e}, median {np.median(err):.2e}")
'''),
    md(r"""
## 6. Generate C, compile and compare (when a compiler is present)

The C file has double and float versions of every routine (`lambert_sphere_brdf`, `lambert_sphere_brdf_f`, ...).
`fitlab.codegen.native.build` compiles it with the strict flags the tests use
(`-std=c99 -O2 -Wall -Wextra -Wpedantic -Werror`) and calls it through ctypes.
"""),
    code('''
files = generate("c", fits_dir=scratch / "fits")
header = files["lambert_sphere.h"]
print("\\n".join(line for line in header.splitlines() if "_h1" in line))
if compiler() is None:
    print("no C compiler (cc, gcc or clang) on PATH: skipped")
else:
    try:
        native = build(files, load_program(scratch / "fits"), scratch / "c")
    except CompileError as err:
        print(err)
    else:
        double = native("brdf", mu_i, mu_o, np.cos(phi), c)
        single = native("brdf", mu_i, mu_o, np.cos(phi), c, dtype=np.float32)
        print(f"C double vs generated Python: max relative difference {np.max(np.abs(double - via_generated) / via_generated):.1e}")
        print(f"C float vs C double:          max relative difference {np.max(np.abs(single - double) / double):.1e}")
'''),
    md(r"""
## 7. Clean up

To keep a refit, write it to `fits/` instead (`refit(..., out=Path("../fits"))`, or `fitlab refit --target H1`),
then regenerate `fits/generated/` with `fitlab codegen` for each language.
"""),
    code('''
shutil.rmtree(scratch)
'''),
]

NOTEBOOKS = {
    "01_h_functions.ipynb": H_FUNCTIONS,
    "02_constants.ipynb": CONSTANTS,
    "03_albedo_maps.ipynb": ALBEDO,
    "04_brdf.ipynb": BRDF,
    "05_refit_and_codegen.ipynb": WALKTHROUGH,
}


def build_notebook(cells) -> nbformat.NotebookNode:
    nb = nbformat.v4.new_notebook()
    nb.metadata = {
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
    }
    nb.cells = [nbformat.from_dict(dict(cell)) for cell in cells]
    for i, cell in enumerate(nb.cells):
        cell.id = f"cell-{i:02d}"  # stable ids: a rebuild changes nothing unless the cells do
    nbformat.validate(nb)
    return nb


def render(name: str) -> str:
    return nbformat.writes(build_notebook(NOTEBOOKS[name]))


def main(argv) -> int:
    check = "--check" in argv
    stale = []
    for name in NOTEBOOKS:
        path = HERE / name
        text = render(name)
        if check:  # compare content, not formatting
            if not path.exists() or json.loads(path.read_text()) != json.loads(text):
                stale.append(name)
        else:
            path.write_text(text)
    if stale:
        print(f"out of date with notebooks/_build.py: {', '.join(stale)}; run python notebooks/_build.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
