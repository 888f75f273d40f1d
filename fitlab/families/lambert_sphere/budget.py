r"""The error budget of a runtime model: how much of its error each fitted part contributes.

The runtime structure f_r = max(0, s (f_1 + fm0 + fm1 cos phi + fm2 cos 2phi)) with every part exact
(H0, H1, H2 from :func:`fitlab.families.lambert_sphere.exact.h_function`, l, m, B, C, D, F from
:func:`~fitlab.families.lambert_sphere.exact.constants`) is the reference BRDF itself: the three-term
phase function has Legendre orders 0 to 2, so multiple scattering has exactly these three Fourier
orders.  :func:`error_budget` swaps in one fitted part at a time (the others exact), then all of them,
then the energy scale (the runtime model itself), and measures each with :func:`.runtime.accuracy`:
max and RMS relative error over mu >= 0.01 and every c, max on the grazing set, and the albedo error.

``python -m fitlab.families.lambert_sphere.budget --out docs`` writes docs/error_budget.md and .json.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab._io import atomic_write_text
from fitlab.core import get_target
from fitlab.families.lambert_sphere.exact import constants, h_function
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, runtime_brdf
from fitlab.families.lambert_sphere.runtime import ORDER2_FORMS, accuracy, energy_scale
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import fit_path, load

__all__ = ["error_budget", "assembled", "exact_parts", "PARTS"]

#: the parts of the order-2 runtime model, in the order of the budget
PARTS = (*RUNTIME_PARTS, ORDER2_PART)
_H = {"H0": 0, "H1": 1, "H2": 2}
mu, c = symbols(("mu", "c"))


def _exact_h(order: int):
    def f(x, cv):
        x, cv = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(cv, dtype=float))
        out = np.empty(x.shape)
        for value in np.unique(cv):
            at = cv == value
            out[at] = h_function(order, x[at], float(value))
        return out

    return f


def _exact_constant(name: str):
    def f(cv):
        cv = np.asarray(cv, dtype=float)
        values, where = np.unique(cv, return_inverse=True)  # the sets repeat a few albedos many times
        return np.asarray(constants(values)[name], dtype=float)[where].reshape(cv.shape)

    return f


def exact_parts() -> dict:
    """{part: numpy function} of every part, exact: H_n(mu, c), X(c)."""
    return {p: (_exact_h(_H[p]) if p in _H else _exact_constant(p)) for p in PARTS}


def assembled(functions: dict, scale=1):
    """The runtime structure with each part a numpy function ({part: f(mu, c) or f(c)}): a model
    f(mu_i, mu_o, phi, c) with the energy scale ``scale``."""
    placeholders = {p: sp.Function(f"part_{p}")(*((mu, c) if get_target(p).inputs == ("mu", "c") else (c,))) for p in PARTS}
    expr = runtime_brdf(placeholders, scale=scale)
    names = {f"part_{p}": f for p, f in functions.items()}
    args = symbols(("mu_i", "mu_o", "phi", "c"))
    f = sp.lambdify(args, expr, modules=[names, "numpy"])

    def model(mu_i, mu_o, phi, cv):
        arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (mu_i, mu_o, phi, cv)))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            return np.broadcast_to(np.asarray(f(*arrays), dtype=float), arrays[0].shape).copy()

    return model


def error_budget(fits_dir: Path, forms: dict | None = None, seed: int = 18, n: int = 400, progress=None) -> list[dict]:
    """Rows (label, max, rms, max_grazing, albedo_err) of the budget of the runtime model with the fits in
    ``fits_dir`` (``forms``: {part: form}, default :data:`.runtime.ORDER2_FORMS`), on :func:`.runtime.accuracy`'s
    sets (``seed``, ``n``).  ``progress(label)`` is called before each row."""
    forms = dict(ORDER2_FORMS if forms is None else forms)
    fits = {p: load(fit_path(Path(fits_dir), p, forms.get(p, get_target(p).default_form))) for p in PARTS}
    fitted = {p: lambdify_numpy(symbols(get_target(p).inputs), fits[p].expression) for p in PARTS}
    exact = exact_parts()
    scale = energy_scale({p: fits[p].expression for p in PARTS})
    cases = [("every part exact (the reference)", {}, 1)]
    cases += [(f"{p} fitted ({fits[p].form}), the rest exact", {p: fitted[p]}, 1) for p in PARTS]
    cases += [("every part fitted, no energy scale", fitted, 1), (f"every part fitted, energy scale {float(scale)!r} "
                                                                  "(the runtime model)", fitted, scale)]
    rows = []
    for label, swap, s in cases:
        if progress is not None:
            progress(label)
        r = accuracy(assembled({**exact, **swap}, s), seed=seed, n=n)
        rows.append({"model": label, "max_rel": r["max"], "rms_rel": r["rms"], "max_rel_grazing": r["max_grazing"],
                     "albedo_err": r["albedo_err"], "albedo_c1_max": r.get("albedo_c1_max")})  # fmt: skip
    return rows


def _markdown(rows: list[dict], command: str) -> str:
    out = ["# Error budget of the order-2 runtime model", "",
           f"Generated by `{command}` (fitlab.families.lambert_sphere.budget); do not edit, regenerate.", "",
           "Each row is the runtime structure with the parts named fitted and every other part exact, measured "
           "against the exact BRDF on the sets of `runtime.accuracy` (mu >= 0.01 and every c down to 1e-6 for max "
           "and RMS; mu down to 1e-6 for grazing; the directional albedo at c in {1e-3, 0.3, 0.7, 0.95, 1} against "
           "the exact one). With every part exact the structure is the reference, so each row is that part's "
           "own contribution to the model's error.", "",
           "| model | max rel | RMS rel | max rel, grazing | albedo error | albedo at c = 1, max |", "|---|---|---|---|---|---|"]  # fmt: skip
    for r in rows:
        a1 = "-" if r["albedo_c1_max"] is None else f"{r['albedo_c1_max']:.6f}"
        out.append(f"| {r['model']} | {r['max_rel']:.2e} | {r['rms_rel']:.2e} | {r['max_rel_grazing']:.2e} | "
                   f"{r['albedo_err']:.2e} | {a1} |")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m fitlab.families.lambert_sphere.budget", description=__doc__.splitlines()[0])
    p.add_argument("--fits", default=None, help="fits folder (default: the packaged fits)")
    p.add_argument("--out", default="docs", help="folder for error_budget.md and error_budget.json (default: docs)")
    args = p.parse_args(argv)
    from fitlab.resources import packaged_fits

    fits = Path(args.fits) if args.fits else packaged_fits()
    rows = error_budget(fits, progress=lambda label: print(f"  {label}", flush=True))
    out = Path(args.out)
    command = "python -m fitlab.families.lambert_sphere.budget --out " + args.out
    atomic_write_text(out / "error_budget.md", _markdown(rows, command))
    atomic_write_text(out / "error_budget.json", json.dumps(rows, indent=1) + "\n")
    print(_markdown(rows, command))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
