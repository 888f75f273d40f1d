"""Write the notebooks of this folder from the cells below (the notebooks' source).

    python notebooks/_build.py          # rewrite notebooks/*.ipynb
    python notebooks/_build.py --check  # exit 1 if a committed notebook differs

Edit the cells here, not in Jupyter, then rebuild: the committed notebooks carry
no outputs, and tests/test_notebooks.py checks that they match this file and
runs each of them top to bottom.  Every computation is fitlab's API (mostly
fitlab.residuals); the notebooks choose grids, plot, and compare one result with
another (generated code with fitlab's evaluation, a figure measured again).

Every number (and every checkable fact) a notebook's text states is a :class:`Claim`
in ``CLAIMS``: the markdown cell holds its marker ``[[key]]``, which the build
replaces by the claim's sentence, and tests/test_notebooks.py appends
:func:`claims_cell` to its in-memory copy of the notebook, which checks each
claim's value in the kernel after the notebook ran.  A sentence and its check
come from one entry, so they cannot drift apart; the build refuses a claim that
no cell states and a marker that names no claim.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import NamedTuple

import nbformat

HERE = Path(__file__).resolve().parent

SETUP = """\
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from fitlab.resources import packaged_fits

# tests/test_notebooks.py sets FITLAB_NOTEBOOK_SMALL=1: coarse grids, a few seconds per notebook
SMALL = os.environ.get("FITLAB_NOTEBOOK_SMALL") == "1"
FITS = packaged_fits()  # the fits packaged with fitlab (fitlab.resources)
"""


def md(text: str):
    return nbformat.v4.new_markdown_cell(text.strip("\n"))


class Claim(NamedTuple):
    """A number (or a fact) a notebook's text states, and the check of it in the notebook's kernel.

    key: the marker ``[[key]]`` of the markdown cell that states it.
    text: the sentence; ``{bound}`` (``{lo}``, ``{hi}`` for "between") is replaced by the bound as stated,
        ``format(bound, fmt)``.
    value: a Python expression, evaluated in the kernel after the notebook's last cell: a number, or (for the
        comparisons) a sequence of numbers, each of which must hold.
    check: "<", "<=", ">", ">=" (value against bound), "between" (lo <= value <= hi, bound = (lo, hi)),
        "prints as" (format(value, fmt) == format(bound, fmt): the digits the text states) or
        "true" (bool(value); the text states a fact, or a bound its expression holds).
    when: a Python expression; the claim is checked where it is true (a C compiler is present, ...).
    """

    key: str
    text: str
    value: str
    check: str
    bound: object = None
    fmt: str = ".0e"
    when: str | None = None

    def stated(self, x) -> str:
        """``x`` as the text states it: ``format(x, fmt)``, exponents without a leading zero (1e-3, not 1e-03)."""
        return re.sub(r"e([+-])0(\d)", r"e\1\2", format(x, self.fmt)).replace("e+", "e")

    def sentence(self) -> str:
        if self.check == "between":
            lo, hi = self.bound
            return self.text.replace("{lo}", self.stated(lo)).replace("{hi}", self.stated(hi))
        if self.check == "true":
            return self.text
        return self.text.replace("{bound}", self.stated(self.bound))


CHECKS = ("<", "<=", ">", ">=", "between", "prints as", "true")
MARKER = re.compile(r"\[\[([A-Za-z0-9_]+)\]\]")

#: the cell tests/test_notebooks.py appends: each claim's value, its check, and one JSON line of what it found
CHECK_CELL = """\
# appended by tests/test_notebooks.py (never committed): the claims of this notebook's text, notebooks/_build.py CLAIMS
import json as _json
import operator as _operator

_found, _failed = [], []
for _key, _value, _check, _bound, _fmt, _when in __CLAIMS__:
    if _when is not None and not eval(_when):
        _found.append({"key": _key, "skipped": _when})
        continue
    _v = eval(_value)
    if _check == "true":
        _v = bool(_v)
        _ok = _v
    else:
        _v = [float(_x) for _x in _v] if isinstance(_v, (list, tuple)) else float(_v)
        if _check == "between":
            _holds = lambda _x: _bound[0] <= _x <= _bound[1]
        elif _check == "prints as":
            _holds = lambda _x: format(_x, _fmt) == format(_bound, _fmt)
        else:
            _op = {"<": _operator.lt, "<=": _operator.le, ">": _operator.gt, ">=": _operator.ge}[_check]
            _holds = lambda _x: _op(_x, _bound)
        _ok = all(map(_holds, _v)) if isinstance(_v, list) and _v else (not isinstance(_v, list) and _holds(_v))
    _found.append({"key": _key, "value": _v, "check": _check, "bound": _bound, "ok": _ok})
    if not _ok:
        _failed.append(f"{_key}: {_v!r} {_check} {_bound!r}")
print("CLAIMS " + _json.dumps(_found))
assert not _failed, "a claim of the text does not hold: " + "; ".join(_failed)
"""


def check_source(claims) -> str:
    """The source of a code cell that checks ``claims`` in the kernel it runs in."""
    return CHECK_CELL.replace("__CLAIMS__", repr([(c.key, c.value, c.check, c.bound, c.fmt, c.when) for c in claims]))


def claims_cell(name: str) -> nbformat.NotebookNode:
    """The code cell that checks the claims of notebook ``name`` (appended by the test, never written)."""
    return nbformat.v4.new_code_cell(check_source(CLAIMS.get(name, ())))


def code(text: str):
    return nbformat.v4.new_code_cell(text.strip("\n"))


# -----------------------------------------------------------------------------
H_FUNCTIONS = [
    md(r"""
# H-functions: where the approximations of H0 and H1 err

$H_0(\mu; c)$ and $H_1(\mu; c)$ are Chandrasekhar H-functions of the three-term Lambert-sphere
half space (docs/model.md, "H-functions"): the solutions of $H(\mu) = 1 + \mu H(\mu) \int_0^1 \Psi_m(v) H(v)/(\mu + v)\,dv$
for the characteristic functions $\Psi_0, \Psi_1$. `fitlab.families.lambert_sphere.exact.h_function` solves them
(Nyström + Newton; `method="fock"`, the Fock integral, is an independent second method). The BRDF uses them at
$\mu = \mu_i$ and $\mu = \mu_o$, so errors are wanted over the whole square $(\mu, c) \in [0, 1]^2$.

The approximations:
* **published**: Hapke-style $H_0$ (eq. 31) and the separable $H_1$ (two readings of the printed form, and
  the renderer's coefficients), as presets of `fitlab.forms`;
* **fits** packaged with fitlab (`fitlab.resources.packaged_fits()`): the same forms refitted (`H0.json`, `H1.json`:
  `fitlab refit --target H0 --form hapke`), the `log_exp` forms with the exact grazing behaviour that the generated
  code prints (`H0.log_exp.json`: what `fitlab refit --target H0` fits), the richer `hapke_rational` form of $H_0$, and
  whatever else is saved there for the target (the forms `fitlab discover` found, `H0.sr_*.json`).

The error is relative, $|H_\text{approx} - H|/H$. What to look for:
* where each fit's largest errors lie (a minimax fit spreads its error evenly; docs/fitting.md shows why the
  eq. 31 form cannot do much better than its minimax refit: [[hapke_floor]], [[hapke_floor_at]]);
* whether the refits trade accuracy at small $c$ for accuracy near $c = 1$ (the $H_0$ refit weights small $c$
  more: the runtime model is most sensitive there);
* grazing angles: the exact $H - 1$ vanishes like $\mu \log(1/\mu)$ as $\mu \to 0$; a form that vanishes like a
  power $\mu^d$, $d < 1$, can be accurate in $H$ and still wrong in $(H - 1)/\mu$, which the BRDF divides out
  (see 04_brdf.ipynb, grazing behaviour).
"""),
    code(
        SETUP
        + """
from fitlab.families.lambert_sphere.exact import h_function
from fitlab.core import get_target, targets
from fitlab.fit.verify import verify_fit
from fitlab.residuals import approximations, heatmap, residuals
from fitlab.store import load
"""
    ),
    md(r"""
## The grid

With full settings the grid is the refits' own validation grid (`get_target(...).validation()`: [[validation_grid]]),
the one every fit record's figures are measured on. With `SMALL` it is a coarse grid of the same kind.
"""),
    code("""
validation = get_target("H0").validation()  # H1's validation set has the same points
VALID_MU, VALID_C = np.unique(validation.inputs["mu"]), np.unique(validation.inputs["c"])
ODD = np.arange(1, 256, 2) / 256
if SMALL:
    MU = np.concatenate(([0.0, 1e-5], np.linspace(1 / 16, 1, 16)))
    C = np.sort(1 - np.linspace(0, 1, 13) ** 2)
else:
    MU, C = VALID_MU, VALID_C
print(f"{MU.size} values of mu x {C.size} values of c")

found = {name: approximations(name, FITS) for name in ("H0", "H1")}
res = {name: {label: residuals(name, a, mu=MU, c=C) for label, a in found[name].items()} for name in found}
"""),
    md(r"""
## The exact functions

$H_0$ and $H_1$ rise from 1 at grazing ($\mu = 0$); $H_0$ grows fastest at $c = 1$, where $H_0(\infty)$ is infinite
(the conservative case, eq. 32). The two methods agree: [[fock]]
"""),
    code("""
fig, axes = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
mu = np.linspace(0, 1, 21 if SMALL else 101)
fock_difference = 0.0
for ax, order in zip(axes, (0, 1)):
    for c in (0.3, 0.7, 0.9, 0.99, 1.0):
        h = h_function(order, mu, c)
        fock_difference = max(fock_difference, np.max(np.abs(h_function(order, mu, c, method="fock") - h) / h))
        ax.plot(mu, h, label=f"c = {c}")
    ax.set(xlabel="mu", ylabel=f"H{order}(mu; c)", title=f"exact H{order}")
axes[0].legend()
plt.show()
print(f"Nystrom vs Fock on these curves: max relative difference {fock_difference:.1e}")
"""),
    md(r"""
## Summary

`max` is the largest relative error on the grid, `rms` its root mean square; `worst at` is where the maximum lies.
For the saved fits, `record` is the validation maximum the fit file states and `re-measured` the one
`fitlab.fit.verify.verify_fit(load(path))` measures on the validation set (what `fitlab codegen` does before it prints a
fit): [[record_remeasured]] With full settings the grid is that set, and `max` is the same figure again.
"""),
    code("""
remeasured = {}  # (target, label): (the record's max, the max re-measured on the validation set)
print(f"{'approximation':<54} {'max':>9} {'rms':>9} {'record':>9} {'re-measured':>11}  worst at")
for name, by_label in res.items():
    for label, r in by_label.items():
        s = r.summary()
        fit = found[name][label]
        columns = " " * 21
        if hasattr(fit, "record"):
            m = verify_fit(load(fit.path))
            remeasured[name, label] = (fit.record["validation"]["max_rel"], m["max_rel"])
            columns = f"{fit.record['validation']['max_rel']:9.2e} {m['max_rel']:11.2e}"
        w = s["worst"]
        print(f"{name + ': ' + label:<54} {s['max_rel']:9.2e} {s['rms_rel']:9.2e} {columns}  mu = {w['mu']:.4g}, c = {w['c']:.4g}")
hapke = verify_fit(load(FITS / "H0.json"))  # the eq. 31 form, refitted minimax
"""),
    md(r"""
## Heat maps over $(\mu, c)$

One log colour scale for all panels (the colour bars show it). The rows are $H_0$ and $H_1$; the columns the best
published preset, then every saved fit (the refit of the same form first). Look at where the colour is brightest, and at how
evenly a minimax refit spreads its error compared with the published preset.
"""),
    code("""
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
"""),
    md(r"""
## Slices

Left: the error along $\mu$ at a few fixed $c$ (the grid value nearest to each; log $\mu$, to show grazing angles);
right: along $c$ at fixed $\mu$. Solid lines are the refit of the default form, dashed the best published preset.
"""),
    code("""
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
"""),
    md(r"""
## The worst points

The largest errors of the best published preset and of each saved fit, with the exact and approximate values.
Neighbouring grid points of one peak follow each other in the list.
"""),
    code("""
for name in res:
    for r in (best_published(name), *saved_fits(name)):
        print(f"{name}: " + r.table(6), end="\\n\\n")
"""),
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
* $B, C, D, F$: **relative to $A$**, $|\Delta X|/A$. [[b_sign]], and [[df_zero]], so
  $|\Delta X|/|X|$ has no bound; an error $\Delta X$ moves $Q$ (and $f^{(0)}$) by at most $2|\Delta X|$ against $A$.

[[printed_zero]] `max*` below leaves the exact zeros out.
"""),
    code(
        SETUP
        + """
from fitlab.families.lambert_sphere.exact import constants
from fitlab.core import get_target, targets
from fitlab.residuals import approximations, residuals

NAMES = ("l", "m", "B", "C", "D", "F")
"""
    ),
    md(r"""
## The grid

$c = 1 - s^2$ for evenly spaced $s$, dense near $c = 1$ where the constants bend. With full settings: the refits'
validation grid ([[validation_grid]]), as in the fit records.
"""),
    code("""
VALID_C = np.unique(get_target("l").validation().inputs["c"])
ODD = np.arange(1, 256, 2) / 256
C = np.sort(1 - np.linspace(0, 1, 17) ** 2) if SMALL else VALID_C
found = {name: approximations(name, FITS) for name in NAMES}
res = {name: {label: residuals(name, a, c=C) for label, a in found[name].items()} for name in NAMES}
print(f"{C.size} values of c; approximations: " + ", ".join(f"{n}: {len(v)}" for n, v in found.items()))
"""),
    md(r"""
## The exact constants and the approximations

Each panel shows the exact constant (black) and every approximation; at this scale they overlap: the errors
are below.
"""),
    code("""
fig, axes = plt.subplots(2, 3, figsize=(13, 7), layout="constrained")
for ax, name in zip(axes.flat, NAMES):
    ax.plot(C, next(iter(res[name].values())).exact, "k", lw=3, alpha=0.4, label="exact")
    for label, r in res[name].items():
        ax.plot(C, r.approx, lw=1, label=label)
    ax.set(xlabel="c", title=name)
    ax.legend(fontsize="x-small")
plt.show()
"""),
    md(r"""
## Errors along $c$

Log scale; dashed lines are the published presets. Points with zero error (exact zeros the form builds in) are
not drawn.
"""),
    code("""
fig, axes = plt.subplots(2, 3, figsize=(13, 7), layout="constrained")
for ax, name in zip(axes.flat, NAMES):
    for label, r in res[name].items():
        ax.semilogy(C, r.error, "--" if r.published else "-", label=label)
    ax.set(xlabel="c", ylabel=next(iter(res[name].values())).error_measure.split(":")[0], title=name)
    ax.legend(fontsize="x-small")
plt.show()
"""),
    md(r"""
## Summary and worst points

`max*` leaves out the target's exact zeros ($c = 0$ for $B..F$), `worst at` is where `max*` lies.
"""),
    code("""
print(f"{'approximation':<44} {'max':>9} {'max*':>9} {'rms':>9}  worst at")
for name in NAMES:
    for label, r in res[name].items():
        s = r.summary()
        nonzero = r.scale > 0
        worst_c = r.axes["c"][nonzero][np.argmax(r.error[nonzero])]
        print(f"{name + ': ' + label:<44} {s['max_rel']:9.2e} {s['max_rel_nonzero']:9.2e} {s['rms_rel']:9.2e}  c = {worst_c:.4g}")
"""),
    code("""
for name in NAMES:
    refit = next(r for label, r in res[name].items() if label.endswith(f"({name}.json)"))
    print(refit.table(4), end="\\n\\n")
"""),
    md(r"""
## An identity: the runtime model needs no fit of $m$

The order-1 term uses $l$ and $m$ only through $l$ and $l^2 + 45m/64$, and the moment relations give
$l^2 + 45m/64 = (45 + 20c)/64$ exactly (docs/fitting.md). The exact constants confirm it to rounding: [[identity]]
The cell also locates the sign change of $B$ and the values of $D$ and $F$ at $c = 1$ that the introduction states.
"""),
    code("""
exact = constants(C)
deviation = np.abs(exact["l"] ** 2 + 45 * exact["m"] / 64 - (45 + 20 * C) / 64)
print(f"max |l^2 + 45 m/64 - (45 + 20c)/64| over {C.size} values of c: {deviation.max():.1e}")

B = exact["B"]
b_flips = np.flatnonzero(B[:-1] * B[1:] < 0)  # grid intervals where B changes sign (B(0) = 0 is no change)
i = b_flips[0]
b_root = C[i] - B[i] * (C[i + 1] - C[i]) / (B[i + 1] - B[i])  # linear interpolation inside the interval
A1 = 69 / 128  # A at c = 1
at_one = {name: exact[name][C == 1][0] / A1 for name in ("D", "F")}
print(f"B changes sign {b_flips.size} time(s), at c = {b_root:.4f};  at c = 1: D/A = {at_one['D']:.1e}, F/A = {at_one['F']:.1e}")
"""),
]

# -----------------------------------------------------------------------------
ALBEDO = [
    md(r"""
# Albedo maps: $k_d(c)$, $c(k_d)$ and the round trip

A renderer is given the spherical (Bond) albedo $k_d$ of the material, the fraction of light it reflects, and
needs the particle albedo $c$. `fitlab.families.lambert_sphere.exact.spherical_albedo(c)` integrates the exact BRDF (the
whole phase function in every collision, its default `phase="true"`): $k_d$ = kd_true(c). The two maps are fitted separately:
* `kd_of_c`: $k_d(c)$, the printed form (which misses $k_d(0) = 0$) and forms that build the zero in;
* `c_of_kd`: its inverse (paper and renderer coefficients, and the refit).

The true BRDF conserves energy: kd_true(1) = 1 to [[kd_one]], so the inverse is fitted and measured on all of
$0 \le k_d \le 1$: [[c_of_kd_domain]].

Errors are relative. The last section composes the two fitted maps: a renderer that converts $k_d \to c$ and
back should get its $k_d$ back.
"""),
    code(
        SETUP
        + """
from fitlab.families.lambert_sphere.exact import spherical_albedo
from fitlab.core import get_target, targets
from fitlab.store import load
from fitlab.residuals import approximations, residuals
"""
    ),
    code("""
if SMALL:  # every new c costs the exact engine up to seconds (most near c = 1)
    C = np.array([0.0, 0.25, 0.5, 0.75, 0.9, 0.97, 1.0])
else:
    C = np.unique(get_target("kd_of_c").validation().inputs["c"])
C_INV = C  # c_of_kd is fitted and measured on kd in [0, 1]: kd_true(1) = 1, so every c

kd_res = {label: residuals("kd_of_c", a, c=C) for label, a in approximations("kd_of_c", FITS).items()}
c_res = {label: residuals("c_of_kd", a, c=C_INV) for label, a in approximations("c_of_kd", FITS).items()}
print(f"{C.size} values of c")
"""),
    md(r"""
## The exact map, and the three-term phase function

The three-term half space (`phase="three_term"`, the paper's model in every collision) gives a slightly different
albedo, and so does the mixed reference (`phase="mixed"`: true single scattering, three-term multiple scattering).
The mixed one differs from the three-term one in single scattering only, so that difference grows in proportion to
$c$: [[proportional]] The true albedo stays close to the three-term one: [[true_three]]
"""),
    code("""
kd_true, kd_three = spherical_albedo(C), spherical_albedo(C, phase="three_term")
kd_mixed = spherical_albedo(C, phase="mixed")
fig, axes = plt.subplots(1, 2, figsize=(10, 3.5), layout="constrained")
axes[0].plot(C, kd_true, ".-", label="kd_true (exact BRDF)")
axes[0].plot(C, C, ":", color="grey", label="kd = c")
axes[0].set(xlabel="c", ylabel="kd", title="spherical albedo")
axes[0].legend()
axes[1].plot(C, kd_true - kd_three, ".-", label="kd_true - kd_three_term")
axes[1].plot(C, kd_mixed - kd_three, ".-", label="kd_mixed - kd_three_term")
axes[1].set(xlabel="c", ylabel="difference", title="which phase function, where")
axes[1].legend()
plt.show()
per_c = (kd_mixed - kd_three)[C > 0] / C[C > 0]
print(f"kd_true(1) - 1 = {kd_true[C == 1][0] - 1:.2e};  (kd_mixed - kd_three)/c from {per_c.min():.6e} to {per_c.max():.6e}")
"""),
    md(r"""
## Errors of $k_d(c)$ and $c(k_d)$

Dashed lines are published presets. [[printed_kd0]] [[refits_kd0]]
"""),
    code("""
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
"""),
    code("""
for r in (*kd_res.values(), *c_res.values()):
    if not r.published:
        print(r.table(5), end="\\n\\n")
"""),
    md(r"""
## The round trip

With the refitted maps, $c \to k_d(c) \to c(k_d)$ should return $c$, and $k_d \to c(k_d) \to k_d(c)$ should
return $k_d$. The two fits are independent, so their errors add (or cancel); the round trip shows what a renderer
that converts both ways actually gets. The same for the published pair (paper $k_d(c)$, renderer $c(k_d)$).
"""),
    code("""
kd_of_c, c_of_kd = load(FITS / "kd_of_c.json"), load(FITS / "c_of_kd.json")
c = C_INV[C_INV > 0]
kd = spherical_albedo(c)  # exact kd in (0, 1]
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
"""),
]

# -----------------------------------------------------------------------------
BRDF = [
    md(r"""
# The full BRDF: the runtime model and the fast variant

`fitlab.families.lambert_sphere.program.runtime.runtime_model` assembles the runtime BRDF (docs/model.md),
$f_r = \max(0, f_1 + f_m^{(0)} + f_m^{(1)}\cos\phi + f_m^{(2)}\cos 2\phi)$: exact single scattering with the true
phase function plus the multiple scattering of Fourier orders 0, 1 and 2 built from approximations of $H_0$, $H_1$,
$H_2$, $l$, $m$, $B..F$ (the fitted models also carry an energy scale that keeps their albedo at or below 1).
It is measured against `fitlab.families.lambert_sphere.exact.brdf`, the reference: the true BRDF, the whole phase function in
every collision (every Fourier order). The parts of the other fitted models approximate the three-term solution's
H-functions and constants, so those models carry the three-term multiple scattering's own gap from the truth (up to
2e-3 at grazing forward scattering; docs/derivation.md); the shipped model's parts are fitted to the true BRDF.
The fast variant (eq. 41) replaces the multiple scattering by a lobe and a constant in $k_d$ = kd_true(c).

Models compared, the fitted ones from the fits packaged with fitlab (`fitlab.resources.packaged_fits()`; `fits_dir=DIR`
overlays a folder of one's own on them):
* `paper`: printed coefficients, renderer reading of $H_1$, exact normalisations, Fourier orders 0 and 1;
* `shipped (order 2)`: `runtime_model()`, the model `fitlab codegen` prints: the second Fourier order $f_m^{(2)}\cos 2\phi$
  added, $H_0, H_1, H_2$ in the `log_exp_true` forms (the true BRDF's grazing behaviour), $B..F$ exact to first
  order in $c$, every part fitted to the true BRDF (docs/model.md, "Parts fitted to the true BRDF");
* `refit, default forms`: `runtime_model(model="default-forms")`, each part's default form refitted (Hapke-style $H_0$,
  separable $H_1$, ...), with the order-2 term;
* `refit, richer forms`: the same with the richer forms where fitted (`hapke_rational` $H_0$, cubic $l$, ...);
* the fast variant, published and refitted.

Errors are relative, $|f_\text{model} - f|/f$. [[order2]] The grazing pole at
$\mu_i = \mu_o = 0$ (where the exact $f_r$ grows like $\log(1/\mu)$ at $\phi = \pi$, and like $1/\mu$ through
single scattering elsewhere) is where forms without the exact grazing behaviour fail.
$\phi = 0$ is back-scattering (the viewer beside the light).
"""),
    code(
        SETUP
        + """
from fitlab.families.lambert_sphere.exact import brdf
from fitlab.store import load
from fitlab.residuals import brdf_residuals, heatmap, residuals
from fitlab.families.lambert_sphere.program.runtime import runtime_model
"""
    ),
    code("""
RICHER = {"H0": "hapke_rational", "l": "cubic", "m": "quadratic", **{n: "rational_4_3" for n in "BCDF"}}
MODELS = {
    "paper": runtime_model("paper"),
    "shipped (order 2)": runtime_model(),
    "refit, default forms": runtime_model(model="default-forms"),
    "refit, richer forms": runtime_model(model="default-forms", forms=RICHER),
}
for label, m in MODELS.items():
    print(f"{label:<22} {m.name}: " + ", ".join(m.sources.values()))
FAST = {"fast / paper": ("paper", "paper"), "fast / refit": load(FITS / "fast_brdf.json")}

n = 13 if SMALL else 41
MU = np.geomspace(1e-3, 1, n)  # log-spaced: grazing angles get room
PHI = np.array([0.0, np.pi / 2, np.pi])
C = np.array([0.5, 0.99]) if SMALL else np.array([0.3, 0.9, 0.99])
axes = dict(mu_i=MU, mu_o=MU, phi=PHI, c=C)
res = {label: brdf_residuals(m, label=label, **axes) for label, m in MODELS.items()}
res |= {label: residuals("fast_brdf", a, label=label, **axes) for label, a in FAST.items()}
print(f"{MU.size}^2 directions x {PHI.size} azimuths x {C.size} albedos")
"""),
    md(r"""
## Summary

`max` over the whole grid, `max (mu >= 0.1)` away from grazing, and where the maximum lies. [[shipped_best]]
"""),
    code("""
print(f"{'model':<22} {'max':>9} {'rms':>9} {'max (mu >= 0.1)':>16}  worst at")
for label, r in res.items():
    s = r.summary()
    away = (r.inputs["mu_i"] >= 0.1) & (r.inputs["mu_o"] >= 0.1)
    w = s["worst"]
    print(f"{label:<22} {s['max_rel']:9.2e} {s['rms_rel']:9.2e} {r.error[away].max():16.2e}  "
          f"mu_i = {w['mu_i']:.3g}, mu_o = {w['mu_o']:.3g}, phi = {w['phi']:.3g}, c = {w['c']:.3g}")
"""),
    md(r"""
## Heat maps over $(\mu_i, \mu_o)$

Rows are albedos, columns azimuths; log axes in $\mu$ and one log colour scale (the colour bars show it). First the
shipped runtime model, then the refitted runtime model of the default forms, then the refitted fast variant. The
diagonal $\mu_i = \mu_o$ at $\phi = \pi$ is where the grazing pole bites.
"""),
    code("""
def heatmaps(r):
    fig, grid = plt.subplots(C.size, PHI.size, figsize=(4.2 * PHI.size, 3.4 * C.size), layout="constrained", squeeze=False)
    for row, c in zip(grid, C):
        for ax, phi in zip(row, PHI):
            heatmap(r.at(phi=phi, c=c), "mu_i", "mu_o", ax=ax, vmin=1e-4, vmax=1.0, colorbar=phi == PHI[-1])
            ax.set(xscale="log", yscale="log")
    fig.suptitle(r.label)
    plt.show()


heatmaps(res["shipped (order 2)"])
"""),
    code("""
heatmaps(res["refit, default forms"])
"""),
    code("""
heatmaps(res["fast / refit"])
"""),
    md(r"""
## Polar slices in the plane of incidence

The light at a fixed $\theta_i$ (the title states it); the viewer moves through the plane of incidence, from grazing
beside the light ($\phi = 0$, negative $\theta_o$) to grazing opposite ($\phi = \pi$, positive $\theta_o$). Left: $f_r$ (1/sr); right: the relative error of each model.
"""),
    code("""
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
"""),
    md(r"""
## Grazing behaviour

Along $\mu_i = \mu_o = \mu \to 0$ (the diagonal of the grid, [[grazing_mu]], at $c = 0.9$):
* at $\phi = 0$ single scattering, $c\,p(u)/(2\mu)$, dominates and every model follows it: [[grazing_forward]]
* at $\phi = \pi$ single scattering vanishes ($u \to 1$) and the exact BRDF grows like $\log(1/\mu)$ through its
  multiple-scattering orders. Every member of the fast family stays bounded there, so its relative error tends to 1
  (docs/fitting.md): [[grazing_fast]] The separable $H_1$ form of the paper's model and of the default forms,
  $\exp(k(c)\,\mu^{e(\mu)})$, approaches 1 like $\mu^{e(0)}$ with $e(0) < 1$, where the exact $H_1 - 1$ goes like
  $\mu\log\mu$, so $(H_1(\mu_i)H_1(\mu_o) - 1)/(\mu_i + \mu_o)$ in $f_m^{(1)}$ grows like a power of $1/\mu$ instead
  of $\log(1/\mu)$: [[grazing_separable]] The shipped model's `log_exp` forms have the three-term solution's exact
  grazing behaviour: [[grazing_shipped]]

The cell prints each model at the smallest $\mu$, $\phi = \pi$.
"""),
    code("""
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

GRAZING_MU = mu[0]
at_grazing = {label: r.error[0, 0, :, 0] for label, r in diag.items()}  # the relative error at mu[0], by phi
k = int(np.argmin(np.abs(PHI - np.pi)))
for label, r in diag.items():
    print(f"{label:<22} phi = pi, mu_i = mu_o = {mu[0]:.0e}: exact {r.exact[0, 0, k, 0]:.4g}, model {r.approx[0, 0, k, 0]:.4g}, "
          f"relative error {r.error[0, 0, k, 0]:.3g}")
"""),
    md(r"""
## The worst points

The grid points of largest error for the refitted runtime model and the refitted fast variant.
"""),
    code("""
for label in ("shipped (order 2)", "refit, default forms", "fast / refit"):
    print(res[label].table(8), end="\\n\\n")
"""),
    md(r"""
## One part on its own: $f_m^{(1)}$

The fast $f_m^{(1)}$ of eq. 29 against the exact order-1 multiple scattering, measured relative to $f^{(0)}$ (the
azimuthal mean of the exact BRDF; $f_m^{(1)}$ itself vanishes at $c = 0$ and $\mu = 1$). The published coefficient
was fitted to the halved $f_m^{(1)}$ of eq. 28 as printed (docs/errata.md); the refit is not.
"""),
    code("""
fm1 = {label: residuals("fm1", a, mu_i=MU, mu_o=MU, c=[0.9]) for label, a in (("fast / paper", ("fast", "paper")), ("fast / refit", load(FITS / "fm1.json")))}
fig, axes = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
for ax, r in zip(axes, fm1.values()):
    heatmap(r.at(c=0.9), "mu_i", "mu_o", ax=ax, vmin=1e-4, vmax=1e-1)
    ax.set(xscale="log", yscale="log")
plt.show()
"""),
]

# -----------------------------------------------------------------------------
WALKTHROUGH = [
    md(r"""
# Refit a target and generate code that uses the refit: a walkthrough

This notebook does, through the Python API, what these commands do:

```
fitlab refit --list
fitlab refit --target H1 --out SCRATCH/fits
fitlab codegen --lang python --fits SCRATCH/fits --model three-term --out SCRATCH/generated
fitlab codegen --lang c --fits SCRATCH/fits --model three-term --out SCRATCH/generated
```

`fitlab refit --target H1` fits $H_1$ in the form the generated code prints and writes that one fit file. A `--fits`
folder overlays the fits packaged with fitlab (`fitlab.resources.packaged_fits()`): each fit is read from the folder
when it has the file, else from the packaged fits. So the scratch folder starts empty and holds only the refit, the
generated code uses the refit for $H_1$ and the packaged fits for every other part, and the packaged fits stay as
they are. The refit is a fit of $H_1$ itself, the three-term half space's H-function: it goes with the model
`three-term`, whose parts are each fitted to their own target. The default model's parts are fitted to the true BRDF
instead, and `fitlab codegen` refuses to mix the two in one model unless asked (`--allow-mixed-physics`).
"""),
    code(
        SETUP
        + """
import importlib.util
import inspect
import shutil
import tempfile
import time

from fitlab.codegen import generate, load_program, model_form, write_generated
from fitlab.codegen.native import STRICT_FLAGS, CompileError, build, compiler
from fitlab.core import get_target, targets
from fitlab.families.lambert_sphere.exact import brdf, h_function
from fitlab.families.lambert_sphere.program.runtime import runtime_model
from fitlab.fit.refit import refit, table
from fitlab.fit.verify import TOLERANCE
from fitlab.store import fit_path, fit_sha256, fit_source, load, write_fit

MODEL = "three-term"  # the model whose parts are each fitted to their own target, as a refit of H1 is
"""
    ),
    md(r"""
## 1. The targets

Each target is something the exact engine computes (`fitlab.families.lambert_sphere.targets`), with its forms
(`fitlab.forms`: one sympy expression each, with published presets). `fitlab refit` fits by default the form the
generated code prints (`fitlab.codegen.model_form`: the program's default model, the order-2 runtime model of
docs/model.md), else the target's default form.
"""),
    code("""
for t in targets().values():
    if t.family != "lambert_sphere":
        continue
    default = model_form(t.name)
    forms = ", ".join(f"{f}*" if f == default else f for f in t.forms)
    print(f"{t.name:<16} {forms:<58} {t.description}")
print("* the form fitlab refit fits by default")
"""),
    code("""
FORM = model_form("H1")
t = get_target("H1")
form = t.forms[FORM]
print("H1's form in the generated code:", FORM)
print(form.description)
print("parameters:", form.params, " fixed:", dict(form.fixed))
print("error measure:", t.error_measure)
"""),
    md(r"""
## 2. Refit $H_1$ into an empty scratch folder

`refit` fits the training set (from the packaged exact tables: least squares with optimistix, then a Lawson minimax
refinement), measures the fit and the published presets on the denser validation set and returns the record
(`result.record`); it writes no file. `fitlab.store.write_fit` writes it where `fitlab.store.fit_path` names it.
With `SMALL` the minimax refinement is skipped: compare its maximum with the packaged fit's to see what the
refinement buys. [[one_file]]
"""),
    code("""
scratch = Path(tempfile.mkdtemp(prefix="fitlab-walkthrough-"))
fits_dir = scratch / "fits"

start = time.perf_counter()
result = refit("H1", FORM, minimax=not SMALL)
wall = time.perf_counter() - start
print(table([result], [wall]))
path = fit_path(fits_dir, "H1", result.record["form"])
write_fit(path, result.record)
scratch_files = sorted(p.name for p in fits_dir.iterdir())
scratch_sha256 = fit_sha256(path)
print("the scratch folder holds:", scratch_files)
print("sha256:", scratch_sha256)
"""),
    md(r"""
## 3. The record

The JSON file holds everything needed to evaluate and judge the fit: the expression, the parameters, the domain, the
validation metrics (with the worst point), the published presets measured the same way, and the optimizer's settings.
"""),
    code("""
record = result.record
print("params:", record["params"])
print("validation:", {k: record["validation"][k] for k in ("max_rel", "rms_rel", "points", "worst")})
for p in record["published"]:
    print(f"published {p['form']} / {p['preset']}: max {p['validation']['max_rel']:.3g}")
print("optimizer:", record["optimizer"]["objective"])
packaged_h1 = load(fit_source(None, "H1", FORM))  # fits_dir None: the packaged fit
print(f"packaged fit ({packaged_h1.path.name}): max {packaged_h1.record['validation']['max_rel']:.3e};  "
      f"this refit: max {record['validation']['max_rel']:.3e}")
"""),
    md(r"""
## 4. Load and evaluate

`fitlab.store.load` turns the file into a numpy callable (the file alone suffices: the expression is in it). Inputs go
by name or position; outside the fit's domain it refuses.
"""),
    code("""
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
"""),
    md(r"""
## 5. Generate Python from the scratch folder

`generate("python", fits_dir=fits_dir, model=MODEL)` prints the runtime BRDF (the model `three-term`) and every
fitted part,
from the fits and the sympy forms; the module needs only numpy. It re-measures every fit on its target's validation
set first, and refuses one [[tolerance]] than its file states. Its banner lists, fit by fit, the file, its sha256,
where it was read and the error measured. [[banner_h1]] [[banner_rest]] [[banner_max]]
"""),
    code('''
files = generate("python", fits_dir=fits_dir, model=MODEL)
paths = write_generated(files, scratch / "generated")
print("wrote", [p.name for p in paths])
source = files["lambert_sphere.py"]
head = source[:source.index('"""')]  # the banner: the comment lines before the docstring
print(head)
# the lines under "From these fits": file, sha256, "packaged;" or "--fits;", its physics, then the figures
listed = [line[1:].split() for line in head.splitlines() if line.startswith("#   ") and ".json" in line]
banner = {w[0]: (w[1], w[2].rstrip(";"), float(w[w.index("max") + 1].rstrip(","))) for w in listed}
banner_h1 = banner[path.name]
'''),
    md(r"""
The generated $h_1$ is the refit: [[h1_equal]] The packaged fit is another fit of the same form, and the next cell
prints how far the two are apart.
"""),
    code("""
spec = importlib.util.spec_from_file_location("lambert_sphere_walkthrough", scratch / "generated" / "lambert_sphere.py")
generated = importlib.util.module_from_spec(spec)
spec.loader.exec_module(generated)
print(inspect.getsource(generated.h1))

# the whole domain: mu and c in [0, 1], grazing mu included
MU_H, C_H = np.meshgrid(np.concatenate(([0.0, 1e-10, 1e-6, 1e-3], np.linspace(0, 1, 101)[1:])), np.linspace(0, 1, 101))
h1_refit = h1(mu=MU_H, c=C_H)
h1_difference = np.max(np.abs(generated.h1(MU_H, C_H) - h1_refit) / h1_refit)
print(f"h1, generated vs the refit (load(path)): max relative difference {h1_difference:.1e}")
print(f"h1, the refit vs the packaged fit:          max relative difference "
      f"{np.max(np.abs(packaged_h1(mu=MU_H, c=C_H) - h1_refit) / h1_refit):.1e}")
"""),
    md(r"""
The generated `brdf` is the model `runtime_model(fits_dir=fits_dir, model=MODEL)` evaluates through fitlab (the same model,
the same overlay of the scratch folder on the packaged fits): [[brdf_runtime]] Against the exact BRDF
(`fitlab.families.lambert_sphere.exact.brdf`) on random directions with $\mu \ge 0.01$, [[brdf_exact]] (the cell
prints the figure). Note the generated `brdf` takes $\cos\phi$, `runtime_model` takes $\phi$.
"""),
    code("""
rng = np.random.default_rng(0)
n = 2000 if SMALL else 100_000
mu_i, mu_o = rng.uniform(0.01, 1, (2, n))
phi = rng.uniform(0, np.pi, n)
c = rng.choice([0.2, 0.5, 0.8, 0.95, 1.0], n)  # a few albedos: the exact engine solves the H-equations once per c
model = runtime_model(fits_dir=fits_dir, model=MODEL)
print("runtime_model:", model.name, "; H1 from", model.sources["H1"])
via_fitlab = model(mu_i, mu_o, phi, c)
via_generated = generated.brdf(mu_i, mu_o, np.cos(phi), c)
brdf_difference = np.max(np.abs(via_generated - via_fitlab) / via_fitlab)
print(f"generated vs runtime_model: max relative difference {brdf_difference:.1e}")
exact = brdf(mu_i, mu_o, phi, c)
err = np.abs(via_generated - exact) / exact
brdf_error = err.max()
print(f"generated vs exact BRDF ({n} random points, mu >= 0.01): max relative error {brdf_error:.2e}, median {np.median(err):.2e}")
"""),
    md(r"""
## 6. Generate C, compile and compare (when a compiler is present)

The C file has double and float versions of every routine (`lambert_sphere_brdf`, `lambert_sphere_brdf_f`, ...).
[[c_banner]] `fitlab.codegen.native.build` compiles it with the strict flags the tests use
([[c_flags]]) and calls it through ctypes: [[c_python]] The cell also prints how
far the float version is from the double one.
"""),
    code("""
files_c = generate("c", fits_dir=fits_dir, model=MODEL)
header = files_c["lambert_sphere.h"]
words = next(line for line in header.splitlines() if path.name in line).strip(" */").split()
c_banner_h1 = (words[0], words[1], words[2].rstrip(";"))
print("C banner:", " ".join(words))
print("\\n".join(line for line in header.splitlines() if "_h1" in line))
c_difference = None
if compiler() is None:
    print("no C compiler (cc, gcc or clang) on PATH: skipped")
else:
    try:
        native = build(files_c, load_program(fits_dir, model=MODEL), scratch / "c")
    except CompileError as err:
        print(err)
    else:
        double = native("brdf", mu_i, mu_o, np.cos(phi), c)
        single = native("brdf", mu_i, mu_o, np.cos(phi), c, dtype=np.float32)
        print("compiled with", " ".join(STRICT_FLAGS))
        c_difference = np.max(np.abs(double - via_generated) / via_generated)
        print(f"C double vs generated Python: max relative difference {c_difference:.1e}")
        print(f"C float vs C double:          max relative difference {np.max(np.abs(single - double) / double):.1e}")
"""),
    md(r"""
## 7. Keeping a refit

The scratch folder goes away below. To keep a refit, write it into a folder of one's own and generate from that folder
(the packaged fits fill in every part it lacks):

```
fitlab refit --target H1 --out my-fits                       # my-fits/H1.log_exp.json
fitlab codegen --lang c --fits my-fits --model three-term --out my-generated    # and python, glsl, ...
```

or, in Python, `write_fit(fit_path(Path("my-fits"), "H1", result.record["form"]), result.record)`, then
`write_generated(generate("c", fits_dir=Path("my-fits"), model="three-term"), Path("my-generated"))`;
`runtime_model(fits_dir=Path("my-fits"), model="three-term")` evaluates the same model through fitlab. `fitlab refit --form NAME` fits another form (`fitlab refit --list` names them),
and `fitlab codegen --form H1=NAME` prints it.
"""),
    code("""
shutil.rmtree(scratch)
"""),
]

# -----------------------------------------------------------------------------
OWN_TABLE = [
    md(r"""
# Fit a table of your own and generate the function

This notebook does, through the Python API, what these commands do (docs/your_own_data.md):

```
fitlab fit renderer_E.csv --target E --name rational --form "..." --out SCRATCH/fits
fitlab codegen --fit SCRATCH/fits/E.rational.json --lang python --out SCRATCH/generated
fitlab codegen --fit SCRATCH/fits/E.rational.json --lang c --out SCRATCH/generated
```

The table is the example fitlab ships (`fitlab/data/examples/renderer_E.csv`, found by
`fitlab.resources.package_folder`): $E(\mu, \alpha)$ as a renderer tabulates it for energy compensation, the
directional albedo of GGX with height-correlated Smith masking-shadowing and $F = 1$, with the noise of a Monte Carlo
bake (its header says how it was made). The notebook works in a scratch folder it removes at the end.
"""),
    code(
        SETUP
        + """
import importlib.util
import inspect
import shutil
import tempfile

import fitlab
from fitlab.codegen import write_generated
from fitlab.codegen.native import CompileError, build, compiler
from fitlab.codegen.single import generate_fit_file, read_user_fit, user_program
from fitlab.fit.user import HOLDOUT_EVERY, SCALE_FLOOR
from fitlab.resources import package_folder
from fitlab.store import fit_sha256, load
"""
    ),
    md(r"""
## 1. The table

`fitlab.read_csv_table` reads it as `fitlab fit` does: a header row naming the columns, one row per point, lines
starting with `#` skipped. [[table_grid]]
"""),
    code("""
TABLE = package_folder("data", "examples", "renderer_E.csv")
print("".join(line for line in TABLE.open() if line.startswith("#")))
table = fitlab.read_csv_table(TABLE)
mu, alpha, E = (table.column(name) for name in ("mu", "alpha", "E"))
print(f"{table.rows} rows, columns {table.header}, sha256 {table.sha256}")
TEXELS = (np.arange(32) + 0.5) / 32

fig, ax = plt.subplots(figsize=(5, 4), layout="constrained")
grid = ax.tricontourf(mu, alpha, E, levels=20)
fig.colorbar(grid, ax=ax, label="E")
ax.set(xlabel="mu", ylabel="alpha", title="renderer_E.csv")
plt.show()
"""),
    md(r"""
## 2. Fit it

The form is text: an expression in the input columns and the parameters `a0`, `a1`, ..., read by fitlab's restricted
parser (nothing in it runs as code). $E$ depends on $\mu$ mostly through $v = \alpha/(\mu + \alpha)$ and on the
roughness through $\sqrt\alpha$; the form below is a quadratic over a quadratic in $(v, \sqrt\alpha)$.

`fitlab.fit_table` makes the fit `fitlab fit` makes: [[every]], fits the others (least squares with optimistix,
then Lawson's minimax refinement), and measures the relative error with a floor, $|f - E| / \max(|E|, s_0)$,
[[floor]], on the held-out rows the fit never saw. It writes no file. [[held_out_rows]] [[domain]] [[held_out_max]]
[[held_out_worst]]
"""),
    code("""
v = "alpha/(mu + alpha)"
FORM = (f"(a0 + a1*sqrt(alpha) + a2*alpha + (a3 + a4*sqrt(alpha) + a5*{v})*{v})"
        f" / (1 + a6*sqrt(alpha) + a7*alpha + (a8 + a9*sqrt(alpha) + a10*{v})*{v})")
fit = fitlab.fit_table({"mu": mu, "alpha": alpha}, E, FORM, target="E", name="rational", progress=False)
print(fit)
print("domain:", fit.domain)
print("parameters:", {k: float(f"{p:.6g}") for k, p in fit.params.items()})
held_out = fit.validation
print(f"held-out rows: {held_out['points']}; max relative error {held_out['max_rel']:.3e} at {held_out['worst']}, "
      f"RMS {held_out['rms_rel']:.3e}")
"""),
    md(r"""
## 3. The held-out error, measured here

The same figure from the table and the fit alone, following the rule the text above states: sort the rows, take
every 4th from the 3rd, divide by the floored $|E|$. [[split_agrees]]
"""),
    code('''
order = np.lexsort((alpha, mu))  # rows sorted by (mu, alpha)
held = np.zeros(mu.size, bool)
held[order[2::4]] = True
floor = 1e-3 * np.abs(E).max()


def held_out_error(values):
    """max and RMS of |values - E| / max(|E|, floor) on the held-out rows"""
    e = np.abs(values[held] - E[held]) / np.maximum(np.abs(E[held]), floor)
    return e.max(), np.sqrt(np.mean(e ** 2))


here = held_out_error(fit(mu=mu, alpha=alpha))
fitted_rows = np.abs(fit(mu=mu[~held], alpha=alpha[~held]) - E[~held]) / np.maximum(np.abs(E[~held]), floor)
print(f"held-out rows {held.sum()}: max {here[0]:.6e}, RMS {here[1]:.6e}  (the fit states {held_out['max_rel']:.6e}, "
      f"{held_out['rms_rel']:.6e})")
print(f"fitted rows {(~held).sum()}: max {fitted_rows.max():.3e}")
split_difference = max(abs(here[0] - held_out["max_rel"]) / held_out["max_rel"],
                       abs(here[1] - held_out["rms_rel"]) / held_out["rms_rel"])
'''),
    md(r"""
## 4. Save it and generate code

`fit.save` writes the fit file and, beside it, the rows it was fitted to (the fit came from arrays);
`fitlab.codegen.single.generate_fit_file` is what `fitlab codegen --fit` does: it reads the fit and its table, splits
the table again, measures the fit on the held-out rows (and generates nothing when that disagrees with what the file
states), and prints one function clamped to the fit's domain. [[banner_max]]
"""),
    code('''
scratch = Path(tempfile.mkdtemp(prefix="fitlab-own-table-"))
saved = fit.save(scratch / "fits" / "E.rational.json")
print("saved:", [p.name for p in saved])
fit_file = scratch / "fits" / "E.rational.json"
files = generate_fit_file(fit_file, "python")
write_generated(files, scratch / "generated")
source = files["E.py"]
print(source[:source.index('"""')])
# "... on the 256 held-out rows (...), relative error ...: max 2.305e-02, RMS ..." in the banner
banner_max = float(source.split("): max ", 1)[1].split(",", 1)[0])
spec = importlib.util.spec_from_file_location("E_generated", scratch / "generated" / "E.py")
generated = importlib.util.module_from_spec(spec)
spec.loader.exec_module(generated)
print(inspect.getsource(generated.rational))
'''),
    md(r"""
The generated function is the fit: [[generated_equal]] Its held-out error, measured here on the table's held-out
rows as above, is the one the fit states: [[generated_held_out]] Outside the domain it clamps its inputs: [[clamp]]
"""),
    code("""
MU_G, ALPHA_G = np.meshgrid(np.linspace(1 / 64, 63 / 64, 201), np.linspace(1 / 64, 63 / 64, 201))
by_fit = fit(mu=MU_G, alpha=ALPHA_G)
generated_difference = np.max(np.abs(generated.rational(MU_G, ALPHA_G) - by_fit) / np.abs(by_fit))
print(f"generated vs the fit, {MU_G.size} points over the domain: max relative difference {generated_difference:.1e}")
generated_here = held_out_error(generated.rational(mu, alpha))
generated_held_difference = abs(generated_here[0] - held_out["max_rel"]) / held_out["max_rel"]
print(f"generated, held-out rows: max {generated_here[0]:.6e}, RMS {generated_here[1]:.6e}")
corner = (float(generated.rational(0.0, 0.0)), float(fit(mu=1 / 64, alpha=1 / 64)))
print(f"generated at (0, 0): {corner[0]:.12g};  the fit at (1/64, 1/64): {corner[1]:.12g}")
"""),
    md(r"""
## 5. C, compiled and compared (when a compiler is present)

`fitlab codegen --fit ... --lang c` writes `E.h` and `E.c`, C99 and libm only: [[c_names]]
`fitlab.codegen.native.build` compiles them with the strict flags the tests use and calls them through ctypes:
[[c_python]] The cell also prints how far the float version is from the double one.
"""),
    code("""
files_c = generate_fit_file(fit_file, "c")
print("\\n".join(line for line in files_c["E.h"].splitlines() if "E_rational" in line and "(" in line))
c_difference = None
if compiler() is None:
    print("no C compiler (cc, gcc or clang) on PATH: skipped")
else:
    try:
        native = build(files_c, user_program(*read_user_fit(fit_file), (fit_file.name, fit_sha256(fit_file))), scratch / "c")
    except CompileError as err:
        print(err)
    else:
        double = native("rational", MU_G.ravel(), ALPHA_G.ravel())
        single = native("rational", MU_G.ravel(), ALPHA_G.ravel(), dtype=np.float32)
        python = generated.rational(MU_G.ravel(), ALPHA_G.ravel())
        c_difference = np.max(np.abs(double - python) / np.abs(python))
        print(f"C double vs generated Python: max relative difference {c_difference:.1e}")
        print(f"C float vs C double:          max relative difference {np.max(np.abs(single - double) / np.abs(double)):.1e}")
"""),
    md(r"""
## 6. Keeping it

The scratch folder goes away below. With the commands, in a folder of one's own:

```
fitlab fit renderer_E.csv --target E --name rational --form "(a0 + ...)" --out fits   # fits/E.rational.json
fitlab codegen --fit fits/E.rational.json --lang c --out generated              # and glsl, hlsl, metal, python, drjit
```

or, in Python, `fit.save(Path("fits/E.rational.json"))` and `generate_fit_file(Path("fits/E.rational.json"), "c")`
(`fit.generate("c")` prints the fit in memory, before it is saved). `fitlab.fit_function` fits a Python function
sampled on a grid the same way, and `fitlab discover renderer_E.csv --target E` searches for a form
(docs/your_own_data.md).
"""),
    code("""
shutil.rmtree(scratch)
"""),
]

SEPARABLE_H1 = '("paper", "refit, default forms", "refit, richer forms")'
FRESNEL = [
    md(r"""
# The Fresnel reflectance of a metal, exact and approximated

The Fresnel family (`fitlab.families.fresnel`, docs/fresnel.md) computes the reflectance $F(\mu)$ of measured
materials exactly, per wavelength from the complex index $n + ik$, and per channel of linear sRGB through the CIE
1931 observer under D65. Engines approximate it: Schlick, the generalised Schlick, Lazanyi-Schlick, Hoffman's
F82-tint, Gulbrandsen's artist-friendly metallic Fresnel. This notebook puts one metal's exact curves beside each
approximation, as its published construction sets it and as refitted, and looks at the error where it lives: at
grazing. Change `METAL` to any of `exact.MATERIALS`.
"""),
    code(
        SETUP
        + """
from fitlab.core import get_target
from fitlab.families.fresnel import exact
from fitlab.families.fresnel.forms import FORM_NAMES, MU_BAR
from fitlab.store import load

METAL = "cu"
CHANNELS = exact.CHANNELS
COLOURS = ("tab:red", "tab:green", "tab:blue")
theta = np.linspace(0.0, 90.0, 181 if SMALL else 721)
mu = np.cos(np.radians(theta))
mu[-1] = 0.0
"""
    ),
    md(r"""
## 1. The exact reflectance

Per wavelength at normal incidence, and per channel over the angle of incidence. [[grazing_white]]
[[normal_closed_form]]
"""),
    code("""
material = exact.get_material(METAL)
lam = exact.WAVELENGTHS
eta = material.index(lam)
f_spectral = exact.fresnel_reflectance(np.array([1.0, 0.5, 0.0])[:, None], eta[None, :])
F = exact.reflectance(METAL, mu)
normal_error = np.abs(f_spectral[0] - exact.normal_reflectance(eta)).max()
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.2))
for row, label in zip(f_spectral, ("normal", "60 deg", "grazing")):
    a.plot(lam, row, label=label)
a.set_xlabel("wavelength (nm)"); a.set_ylabel("F"); a.set_title(f"{material.name}: F per wavelength"); a.legend()
for c in range(3):
    b.plot(theta, F[:, c], color=COLOURS[c])
b.set_xlabel("angle of incidence (deg)"); b.set_title("F per sRGB channel (linear)")
plt.show()
print("F0 (linear sRGB):", np.round(F[0], 4), " F at grazing:", F[-1])
"""),
    md(r"""
## 2. Each approximation: its construction and the packaged refit

A construction sets the parameters from the exact $F$ alone (Schlick: $F_0 = F(1)$; F82-tint: $F_0$ and
$F(\bar\mu = 1/7)$, 82 degrees; Gulbrandsen: $r = F(1)$ and the edge tint of the measured $n, k$). The packaged fit
of each channel (`fitlab/fits/F_<metal>_<channel>.json`, what `fitlab refit --target F_cu_r` writes) is the
target's default form refitted on the validation-free training angles. [[schlick_misses]] [[f82_pins]]
[[refit_within]]
"""),
    code("""
valid = get_target(f"F_{METAL}_r").validation()
mu_v = valid.inputs["mu"]
F_v = exact.reflectance(METAL, mu_v)
constructions = {"schlick": "normal", "f82_tint": "f82", "gulbrandsen": "gulbrandsen"}
errors = {}
fig, axes = plt.subplots(1, len(constructions) + 1, figsize=(14, 3), sharey=True)
for ax, (name, preset) in zip(axes, constructions.items()):
    forms = [get_target(f"F_{METAL}_{ch}").forms[name] for ch in CHANNELS]
    approx_v = np.stack([f.numpy_function(f.vector(preset), mu_v) for f in forms], axis=-1)
    errors[name] = np.abs(approx_v - F_v).max()
    for c, f in enumerate(forms):
        ax.plot(theta, f.numpy_function(f.vector(preset), mu) - F[:, c], color=COLOURS[c])
    ax.set_title(f"{name} ({preset}): max {errors[name]:.1e}", fontsize=9); ax.set_xlabel("angle (deg)")
fits = [load(FITS / f"F_{METAL}_{ch}.json") for ch in CHANNELS]
refit_v = np.stack([fit(mu=mu_v) for fit in fits], axis=-1)
errors["packaged refit"] = np.abs(refit_v - F_v).max()
for c, fit in enumerate(fits):
    axes[-1].plot(theta, fit(mu=mu) - F[:, c], color=COLOURS[c])
axes[-1].set_title(f"packaged refits ({fits[0].form}): max {errors['packaged refit']:.1e}", fontsize=9)
axes[0].set_ylabel("approx - exact")
plt.show()
mu_bar = np.array([float(MU_BAR)])
f82 = [get_target(f"F_{METAL}_{ch}").forms["f82_tint"] for ch in CHANNELS]
f82_values = np.stack([f.numpy_function(f.vector("f82"), mu_bar) for f in f82], axis=-1)
f82_at_bar = np.abs(f82_values - exact.reflectance(METAL, mu_bar)).max()
errors
"""),
    md(r"""
## 3. The hemispherical average

Kulla and Conti's coloured compensation takes $F_{avg} = 2\int_0^1 F \mu\, d\mu$. fitlab integrates it by two
quadratures (in $\mu$ and in $\theta$); Schlick's has the closed form $(20 F_0 + 1)/21$. [[avg_routes]]
"""),
    code("""
avg_mu = exact.average_reflectance(METAL, route="mu")
avg_theta = exact.average_reflectance(METAL, route="theta")
schlick_avg = (20 * F[0] + 1) / 21
print("F_avg exact:", np.round(avg_mu, 5), " Schlick's:", np.round(schlick_avg, 5))
print("difference of the two quadratures:", np.abs(avg_mu - avg_theta).max())
"""),
]


CLAIMS = {
    "01_h_functions.ipynb": [
        Claim(
            "validation_grid",
            "$c = 1 - s^2$, $s$ and $\\mu$ at odd multiples of 1/256, plus the edges and $\\mu$ = 1e-10, 1e-7, 1e-5",
            "np.array_equal(VALID_MU, np.concatenate(([0, 1e-10, 1e-7, 1e-5], ODD, [1]))) and "
            "np.allclose(VALID_C, np.sort(1 - np.concatenate(([0], ODD, [1])) ** 2), rtol=0, atol=1e-15)",
            "true",
        ),
        Claim(
            "fock",
            "on the curves plotted below their largest relative difference is below {bound}.",
            "fock_difference",
            "<",
            1e-13,
        ),
        Claim("hapke_floor", "the refit `H0.json` reaches {bound}", 'hapke["max_rel"]', "prints as", 0.00484, ".3%"),
        Claim("hapke_floor_at", "at $c = 1$, where its largest error lies", 'hapke["worst"]["c"] == 1', "true"),
        Claim(
            "record_remeasured",
            "for every saved fit the two differ by less than {bound} (relative).",
            "[abs(measured - stated) / stated for stated, measured in remeasured.values()]",
            "<",
            1e-9,
        ),
    ],
    "02_constants.ipynb": [
        Claim(
            "validation_grid",
            "$s$ at odd multiples of 1/256 plus the edges",
            "np.allclose(VALID_C, np.sort(1 - np.concatenate(([0], ODD, [1])) ** 2), rtol=0, atol=1e-15)",
            "true",
        ),
        Claim(
            "b_sign",
            "$B$ changes sign once, between $c$ = {lo} and {hi}",
            "b_root if b_flips.size == 1 else np.nan",
            "between",
            (0.93, 0.95),
            "g",
        ),
        Claim(
            "df_zero",
            "$D$, $F$ vanish at $c = 1$ (below {bound} of $A$ there)",
            "[abs(v) for v in at_one.values()]",
            "<",
            1e-12,
        ),
        Claim(
            "printed_zero",
            "All four printed rationals for $B..F$ miss the exact zero at $c = 0$, an infinite error in this measure.",
            'all(np.isinf(res[n]["printed / paper"].error[C == 0]).all() for n in "BCDF")',
            "true",
        ),
        Claim("identity", "the largest deviation on the grid is below {bound}.", "deviation.max()", "<", 1e-14),
    ],
    "03_albedo_maps.ipynb": [
        Claim("kd_one", "{bound}", "abs(kd_true[C == 1][0] - 1)", "<", 1e-12),
        Claim(
            "c_of_kd_domain",
            "the validation set of `c_of_kd` reaches $k_d = 1$",
            'get_target("c_of_kd").validation().inputs["kd"].max() >= 1 - 1e-12',
            "true",
        ),
        Claim(
            "proportional",
            "$(k_d^{mixed} - k_d^{three})/c$ is the same at every $c > 0$ of the grid to within {bound} (relative).",
            "np.ptp(per_c) / per_c.mean()",
            "<",
            1e-9,
        ),
        Claim("true_three", "within {bound} at every $c$ of the grid.", "np.abs(kd_true - kd_three).max()", "<", 3e-6),
        Claim(
            "printed_kd0",
            "The printed $k_d(c)$ misses $k_d(0) = 0$ (infinite relative error at $c = 0$, not drawn on a log scale);",
            'np.isinf(kd_res["printed / paper"].error[C == 0]).all()',
            "true",
        ),
        Claim(
            "refits_kd0",
            "every fit saved for $k_d(c)$ is exact there.",
            "all(r.error[C == 0][0] == 0 for r in kd_res.values() if not r.published)",
            "true",
        ),
    ],
    "04_brdf.ipynb": [
        Claim(
            "order2",
            "The paper's model has no order-2 term (it has no $H_2$); the three fitted models each read "
            "a fit of $H_2$ for it.",
            '"H2" not in MODELS["paper"].sources and all(MODELS[label].sources.get("H2", "").startswith("H2.") '
            "for label in list(MODELS)[1:])",
            "true",
        ),
        Claim(
            "shipped_best",
            "On this grid the shipped model has the smallest maximum of all the models.",
            'min(res, key=lambda label: res[label].summary()["max_rel"]) == "shipped (order 2)"',
            "true",
        ),
        Claim("grazing_mu", "extended down to $\\mu$ = {bound}", "GRAZING_MU", "prints as", 1e-6, ".0e"),
        Claim(
            "grazing_forward",
            "at the smallest $\\mu$ every model is within {bound} of it (relative);",
            "[errors[0] for errors in at_grazing.values()]",
            "<",
            1e-2,
        ),
        Claim(
            "grazing_fast",
            "at the smallest $\\mu$ the fast variants' relative errors lie between {lo} and {hi}.",
            "[at_grazing[label][-1] for label in FAST]",
            "between",
            (0.5, 1.0),
            "g",
        ),
        Claim(
            "grazing_separable",
            "at the smallest $\\mu$ their relative errors exceed {bound}.",
            f"[at_grazing[label][-1] for label in {SEPARABLE_H1}]",
            ">",
            5.0,
            "g",
        ),
        Claim(
            "grazing_shipped",
            "its relative error there stays below {bound}.",
            'at_grazing["shipped (order 2)"][-1]',
            "<",
            4e-3,
        ),
    ],
    "05_refit_and_codegen.ipynb": [
        Claim(
            "one_file",
            "The scratch folder then holds that one file, `H1.log_exp.json`.",
            'scratch_files == ["H1.log_exp.json"]',
            "true",
        ),
        Claim("tolerance", "more than {bound} worse", "TOLERANCE", "prints as", 0.10, ".0%"),
        Claim(
            "banner_h1",
            "The line of $H_1$ names the scratch file, `--fits` as where it was read, and the sha256 of "
            "the file's bytes (`fitlab.store.fit_sha256(path)`);",
            'banner_h1[:2] == (scratch_sha256, "--fits")',
            "true",
        ),
        Claim(
            "banner_rest",
            "every other line says `packaged`;",
            'len(banner) > 1 and all(where == "packaged" for name, (_, where, _) in banner.items() if name != path.name)',
            "true",
        ),
        Claim(
            "banner_max",
            "and the maximum it measured for $H_1$ prints as the one the refit's record states.",
            "f\"{banner_h1[2]:.2e}\" == f\"{record['validation']['max_rel']:.2e}\"",
            "true",
        ),
        Claim(
            "h1_equal",
            "over the whole domain ($\\mu, c \\in [0, 1]$, grazing $\\mu$ included) the generated `h1` "
            "and the fit that `load(path)` returns differ by less than {bound} (relative).",
            "h1_difference",
            "<",
            1e-14,
        ),
        Claim(
            "brdf_runtime",
            "their largest relative difference on random directions is below {bound}.",
            "brdf_difference",
            "<",
            1e-13,
        ),
        Claim("brdf_exact", "the largest relative error is below {bound}", "brdf_error", "<", 2e-3, ".0e"),
        Claim(
            "c_banner",
            "Its banner names the same file, sha256 and origin as the Python module's.",
            'c_banner_h1 == (path.name, scratch_sha256, "--fits")',
            "true",
        ),
        Claim(
            "c_flags",
            "`-std=c99 -O2 -Wall -Wextra -Wpedantic -Werror`",
            '" ".join(STRICT_FLAGS) == "-std=c99 -O2 -Wall -Wextra -Wpedantic -Werror"',
            "true",
        ),
        Claim(
            "c_python",
            "the double version and the generated Python differ by less than {bound} (relative).",
            "c_difference",
            "<",
            1e-13,
            when="c_difference is not None",
        ),
    ],
    "06_your_own_table.ipynb": [
        Claim(
            "table_grid",
            "It has 1024 rows on the texel centres of a 32 x 32 texture, $\\mu$ and $\\alpha$ at $(k + 1/2)/32$.",
            "table.rows == 1024 and all(np.array_equal(np.unique(x), TEXELS) for x in (mu, alpha)) and TEXELS.size == 32",
            "true",
        ),
        Claim("held_out_rows", "Here {bound} rows are held out,", 'held_out["points"]', "prints as", 256, ".0f"),
        Claim(
            "domain",
            "the fit's domain is the bounding box of the rows, $\\mu, \\alpha \\in [1/64, 63/64]$,",
            'fit.domain == {"mu": (1 / 64, 63 / 64), "alpha": (1 / 64, 63 / 64)}',
            "true",
        ),
        Claim(
            "every",
            "it holds out one row in {bound} (the rows sorted by $(\\mu, \\alpha)$, every {bound}th from the 3rd)",
            "HOLDOUT_EVERY",
            "prints as",
            4,
            ".0f",
        ),
        Claim("floor", "$s_0$ = {bound} of the largest $|E|$", "SCALE_FLOOR", "prints as", 1e-3, ".0e"),
        Claim(
            "held_out_max",
            "and the largest held-out relative error is below {bound} (the cell prints it),",
            'held_out["max_rel"]',
            "<",
            2.5e-2,
            ".1e",
        ),
        Claim(
            "held_out_worst",
            "at grazing, $\\mu = 1/64$, where $E$ of GGX changes on the scale $\\alpha$.",
            'held_out["worst"]["mu"] == 1 / 64',
            "true",
        ),
        Claim(
            "split_agrees",
            "The max and RMS agree with the fit's to a relative {bound}.",
            "split_difference",
            "<",
            1e-12,
        ),
        Claim(
            "banner_max",
            "The banner states the held-out maximum it measured, which prints as the fit's.",
            'f"{banner_max:.3e}" == f"{held_out[\'max_rel\']:.3e}"',
            "true",
        ),
        Claim(
            "generated_equal",
            "on a grid over the domain the two differ by less than {bound} (relative).",
            "generated_difference",
            "<",
            1e-14,
        ),
        Claim(
            "generated_held_out",
            "the two maxima differ by less than {bound} (relative).",
            "generated_held_difference",
            "<",
            1e-12,
        ),
        Claim(
            "clamp",
            "at $(\\mu, \\alpha) = (0, 0)$ it returns the fit's value at $(1/64, 1/64)$, the domain's corner.",
            "abs(corner[0] - corner[1]) <= 1e-15 * abs(corner[1])",
            "true",
        ),
        Claim(
            "c_names",
            "`E_rational` in double and `E_rational_f` in float.",
            '"double E_rational(double mu, double alpha)" in files_c["E.h"] and '
            '"float E_rational_f(float mu, float alpha)" in files_c["E.h"]',
            "true",
        ),
        Claim(
            "c_python",
            "the double version and the generated Python differ by less than {bound} (relative).",
            "c_difference",
            "<",
            1e-14,
            when="c_difference is not None",
        ),
    ],
    "07_fresnel.ipynb": [
        Claim(
            "grazing_white",
            "At grazing ($\\mu = 0$) $F = 1$ in every channel, to {bound};",
            "np.abs(F[-1] - 1).max()",
            "<",
            1e-14,
        ),
        Claim(
            "normal_closed_form",
            "at normal incidence $F = ((n-1)^2 + k^2)/((n+1)^2 + k^2)$ at every wavelength, to {bound}.",
            "normal_error",
            "<",
            1e-14,
        ),
        Claim(
            "schlick_misses",
            "For copper, Schlick's construction misses the exact $F$ by more than {bound} near grazing,",
            'errors["schlick"]',
            ">",
            0.03,
            ".2f",
        ),
        Claim("f82_pins", "F82-tint's construction meets it at 82 degrees to {bound},", "f82_at_bar", "<", 1e-14),
        Claim(
            "refit_within",
            "and the packaged refits stay within {bound} of it over the whole hemisphere.",
            'errors["packaged refit"]',
            "<",
            3e-3,
        ),
        Claim("avg_routes", "The two quadratures agree to {bound}.", "np.abs(avg_mu - avg_theta).max()", "<", 1e-10),
    ],
}

NOTEBOOKS = {
    "01_h_functions.ipynb": H_FUNCTIONS,
    "02_constants.ipynb": CONSTANTS,
    "03_albedo_maps.ipynb": ALBEDO,
    "04_brdf.ipynb": BRDF,
    "05_refit_and_codegen.ipynb": WALKTHROUGH,
    "06_your_own_table.ipynb": OWN_TABLE,
    "07_fresnel.ipynb": FRESNEL,
}

#: the question each notebook answers, in two sentences: the build writes them under its title
QUESTIONS = {
    "01_h_functions.ipynb": "How far from the exact H-functions are the published approximations of H0 and H1, and "
    "the fits fitlab ships? Where over (mu, c) do their largest errors lie, and what do they do at grazing angles?",
    "02_constants.ipynb": "How accurate are the published and refitted approximations of the constants l, m, B, C, D "
    "and F over every albedo c? Where does each err most, and does the exact identity between l and m hold?",
    "03_albedo_maps.ipynb": "How accurately do the fitted maps take a material's spherical albedo kd to the particle "
    "albedo c and back? How far do the round trips c -> kd -> c and kd -> c -> kd drift?",
    "04_brdf.ipynb": "How far is the runtime BRDF, built from approximate parts, from the exact BRDF over every pair "
    "of directions and every albedo? Where are its worst points, grazing angles included, and how does the fast "
    "variant compare?",
    "05_refit_and_codegen.ipynb": "How does one refit a part of the runtime BRDF and get generated code that uses the "
    "refit? This walkthrough does it through the Python API and checks the code against the refit and the exact "
    "BRDF.",
    "06_your_own_table.ipynb": "How does one fit a form of one's own to a table of one's own and generate that "
    "function? This notebook fits the example E(mu, alpha) table fitlab ships, measures the held-out error again "
    "from the table alone, and generates the code.",
    "07_fresnel.ipynb": "How far from a metal's exact Fresnel reflectance are Schlick, F82-tint, Gulbrandsen and "
    "fitlab's refits over the whole range of incidence? And how well does each give the hemispherical average F_avg?",
}


def with_question(name: str, cells) -> list:
    """The cells of notebook ``name`` with its question (:data:`QUESTIONS`) under the title of its first cell."""
    if name not in QUESTIONS:
        raise ValueError(f"{name}: no question in QUESTIONS")
    first = nbformat.from_dict(dict(cells[0]))
    title, _, rest = first.source.partition("\n")
    if first.cell_type != "markdown" or not title.startswith("# "):
        raise ValueError(f"{name}: the first cell is not a markdown cell with a title")
    first.source = f"{title}\n\n*{QUESTIONS[name]}*\n{rest}"
    return [first, *cells[1:]]


def state_claims(name: str, cells) -> list:
    """The cells of notebook ``name`` with each marker [[key]] of its markdown replaced by its claim's sentence;
    ValueError for a marker that names no claim, and for a claim stated nowhere or twice."""
    claims = {c.key: c for c in CLAIMS.get(name, ())}
    if len(claims) != len(CLAIMS.get(name, ())):
        raise ValueError(f"{name}: two claims share a key")
    for c in claims.values():
        if c.check not in CHECKS:
            raise ValueError(f"{name}: claim {c.key}: unknown check {c.check!r}; one of {', '.join(CHECKS)}")
    used = []

    def sentence(match):
        key = match.group(1)
        if key not in claims:
            raise ValueError(f"{name}: the marker [[{key}]] names no claim")
        used.append(key)
        return claims[key].sentence()

    out = []
    for cell in cells:
        cell = nbformat.from_dict(dict(cell))
        if cell.cell_type == "markdown":
            cell.source = MARKER.sub(sentence, cell.source)
        elif MARKER.search(cell.source):
            raise ValueError(f"{name}: a claim's marker in a code cell")
        out.append(cell)
    unstated = sorted(set(claims) - set(used)) + sorted({k for k in used if used.count(k) > 1})
    if unstated:
        raise ValueError(f"{name}: claims stated nowhere or twice: {', '.join(unstated)}")
    return out


def build_notebook(cells, name: str | None = None) -> nbformat.NotebookNode:
    nb = nbformat.v4.new_notebook()
    nb.metadata = {
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
    }
    nb.cells = state_claims(name, cells) if name is not None else [nbformat.from_dict(dict(cell)) for cell in cells]
    for i, cell in enumerate(nb.cells):
        cell.id = f"cell-{i:02d}"  # stable ids: a rebuild changes nothing unless the cells do
    nbformat.validate(nb)
    return nb


def same_cells(a: nbformat.NotebookNode, b: nbformat.NotebookNode) -> bool:
    """Whether two notebooks hold the same cells (type and source), outputs aside: an executed copy of the other."""
    return [(c.cell_type, c.source) for c in a.cells] == [(c.cell_type, c.source) for c in b.cells]


def execute(path: Path, *, small: bool = True, timeout: int = 240) -> tuple[nbformat.NotebookNode, list]:
    """The notebook at ``path`` run top to bottom in a fresh kernel (in its own folder, ``FITLAB_NOTEBOOK_SMALL`` as
    ``small`` says), with :func:`claims_cell` appended: every claim of its text is checked in the kernel, and a
    false one raises (nbclient's CellExecutionError) like an error in any cell.  Returns the executed notebook
    without the claims' cell, and what that cell found (one dict per claim, in the order of ``CLAIMS``)."""
    import os

    from nbclient import NotebookClient

    nb = nbformat.read(path, as_version=4)
    nb.cells.append(claims_cell(path.name))
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}  # the kernel's inline backend: plots as PNG
    env = {**env, "FITLAB_NOTEBOOK_SMALL": "1" if small else "0",
           # the exact engine's small linear solves: a second BLAS thread gains nothing, and on a busy 2-core
           # machine OpenBLAS's spinning threads made them 10x slower (measured)
           "OPENBLAS_NUM_THREADS": "1"}  # fmt: skip
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(path.parent)}})  # fmt: skip
    client.execute(env=env)
    printed = [line for o in nb.cells[-1].outputs for line in o.get("text", "").splitlines()]
    report = [line for line in printed if line.startswith("CLAIMS ")]
    found = json.loads(report[-1][len("CLAIMS ") :]) if report else []
    nb.cells.pop()
    return nb, found


def render(name: str) -> str:
    return nbformat.writes(build_notebook(with_question(name, NOTEBOOKS[name]), name))


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
        print(
            f"out of date with notebooks/_build.py: {', '.join(stale)}; run python notebooks/_build.py", file=sys.stderr
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
