r"""The runtime model's parts fitted to the true BRDF (docs/model.md, "Parts fitted to the true BRDF").

The runtime structure f_r = max(0, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi) (:func:`.forms.runtime_terms`) comes from
the three-term half space, where fm0 is H0(mu_i) H0(mu_o) Q(mu_i, mu_o) over (mu_i + mu_o) less single
scattering, and so on: its parts H0, H1, H2, l, m, B, C, D, F are the three-term solution's.  The true BRDF
(the whole phase function in every collision, ``exact.brdf(..., phase="true")``) is not of that form, but close:
its orders 0 to 2 differ from the three-term ones by about 2e-3 of f_r at grazing, and its orders >= 3 are
2e-5 of f_r at most.  Here each order's parts are fitted jointly to that order of the true BRDF, in the
forms of the shipped model, so that the same structure, at the same cost, approximates the true BRDF:

* order 0: H0, B, C, D, F to fm0;  order 1: H1, l, m to fm1;  order 2: H2 to fm2;
* on :func:`.datasets.true_orders_training` (a lattice apart from the audit's validation lattice), each
  residual relative to the true f_r's minimum over phi at its (mu_i, mu_o, c), by least squares
  (:func:`fitlab.fit.solver.fit_form`, no minimax rounds: see :data:`MINIMAX_ROUNDS`), starting from the
  shipped fits;
* A and E stay exact (the structure holds them), and every form keeps its exact O(c) part, so the model is
  0 at c = 0 and its multiple scattering O(c^2).

:func:`fitted_parts` returns one fit record per part (the format of ``fitlab refit``'s files; ``validation``
measures the part against its own target, the three-term quantity, which it no longer approximates closely:
that figure says how far the fitted part moved).  ``python -m fitlab.families.lambert_sphere.true_refit --out
DIR`` writes them; the packaged ones are in ``fitlab/fits/true`` (:data:`TRUE_FITS`), and
``runtime_model(fits_dir=TRUE_FITS)`` is the model they make, which the audit measures against the true BRDF.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import sympy as sp

from fitlab.codegen import program_spec
from fitlab.core import Dataset, data_hash, get_form, get_target
from fitlab.fit.refit import fit_identity, validation_metrics
from fitlab.fit.solver import SOLVER_SETTINGS, fit_form
from fitlab.families.lambert_sphere.datasets import true_orders_training
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, runtime_terms
from fitlab.families.lambert_sphere.runtime import RuntimeModel, runtime_model
from fitlab.forms import Form
from fitlab.store import FitFileError, fit_path, fit_source, fits_folder, load, write_fits

__all__ = ["ORDER_PARTS", "TRUE_FITS", "TRUE_MODEL_NAME", "order_form", "fitted_parts", "true_runtime_model", "MINIMAX_ROUNDS"]

#: the parts each Fourier order of the runtime structure is made of
ORDER_PARTS = {0: ("H0", "B", "C", "D", "F"), 1: ("H1", "l", "m"), 2: (ORDER2_PART,)}
#: the packaged fits of the parts fitted to the true BRDF, a folder that overlays the packaged fits
TRUE_FITS = fits_folder(None) / "true"
#: Lawson rounds after the least squares: none.  Each order is fitted on its own, and minimax rounds level each
#: order's error to its maximum over the training set; at phi = 0 and pi the orders' errors then add, and the
#: BRDF's error grows (30 rounds: 2.3e-3 on the audit's true set for mu >= 0.01, against 5.9e-4 for least squares)
MINIMAX_ROUNDS = 0


#: the name the audit and the report give the model of :data:`TRUE_FITS`
TRUE_MODEL_NAME = "refit to the true BRDF (fits/true)"


def true_runtime_model(fits_dir: Path | None = None) -> RuntimeModel:
    """The runtime model of the parts fitted to the true BRDF, from ``fits_dir`` (default :data:`TRUE_FITS`), in the
    shipped model's forms, orders 0 to 2; every part must be in the folder (FitFileError names those that are not),
    the other fits the program needs come from the packaged ones."""
    folder = TRUE_FITS if fits_dir is None else Path(fits_dir)
    forms = _model_forms()
    # runtime_model falls back to the packaged fits for a part the folder lacks: here that would mix in a part
    # fitted to the mixed reference
    missing = [p for p in (*RUNTIME_PARTS, ORDER2_PART) if not fit_path(folder, p, forms[p]).is_file()]
    if missing:
        raise FitFileError(f"{folder}: no fit to the true BRDF of {', '.join(missing)} in the model's forms "
                           f"({', '.join(fit_path(folder, p, forms[p]).name for p in missing)})")
    m = runtime_model(fits_dir=folder)
    return RuntimeModel(TRUE_MODEL_NAME, m.expr, m.sources)


def _model_forms() -> dict:
    """{part: form} of the program's default model (the shipped runtime model)."""
    _, forms, _ = program_spec("lambert_sphere").model(None)
    return dict(forms)


def order_form(order: int, forms: dict | None = None) -> tuple[Form, dict]:
    """The runtime structure's Fourier order ``order`` (fm0, fm1 or fm2 of :func:`.forms.runtime_terms`) as one
    form in (mu_i, mu_o, c) whose parameters are its parts' (named ``part_param``), and the start vector by
    name: the shipped fits' parameters.  ``forms``: {part: form}, default the shipped model's."""
    forms = {**_model_forms(), **(forms or {})}
    parts, params, fixed, start = {}, [], {}, {}
    for part in (*RUNTIME_PARTS, ORDER2_PART):
        shipped = load(fit_source(None, part, forms[part]))
        if part not in ORDER_PARTS[order]:
            parts[part] = shipped.expression  # not in this order's term
            continue
        form = get_form(part, forms[part])
        rename = {sp.Symbol(p, real=True): sp.Symbol(f"{part}_{p}", real=True) for p in form.params}
        parts[part] = form.expr.xreplace(rename)
        params += [f"{part}_{p}" for p in form.params]
        fixed.update({f"{part}_{p}": v for p, v in form.fixed.items()})
        start.update({f"{part}_{p}": float(v) for p, v in shipped.params.items()})
    expr = runtime_terms(parts)[f"m{order}"]
    form = Form(f"fm{order}_true", "runtime_parts", ("mu_i", "mu_o", "c"), tuple(params), expr, start=start,
                fixed=fixed, description=f"order {order} of the runtime structure, its parts' forms: "
                + ", ".join(f"{p} {forms[p]}" for p in ORDER_PARTS[order]))
    return form, start


def _training(order: int) -> tuple[Dataset, np.ndarray]:
    ds = true_orders_training()
    return Dataset(ds.inputs, ds.aux[f"fm{order}"], ds.grid), ds.aux["scale"]


def fitted_parts(forms: dict | None = None, minimax_rounds: int = MINIMAX_ROUNDS, on_order=None) -> dict:
    """{part: fit record} of every part of the runtime structure fitted to the true BRDF's orders 0 to 2 (module
    docstring).  ``on_order(order, result)`` is called after each order's fit (a progress hook)."""
    forms = {**_model_forms(), **(forms or {})}
    records = {}
    for order, names in ORDER_PARTS.items():
        form, start = order_form(order, forms)
        train, scale = _training(order)
        fit = fit_form(form, train, scale, form.vector(start), minimax_rounds=minimax_rounds)
        if on_order is not None:
            on_order(order, fit)
        values = dict(zip(form.params, (float(x) for x in fit.theta)))
        for part in names:
            records[part] = _record(part, forms[part], values, order, train, fit, minimax_rounds)
    return records


def _record(part, form_name, values, order, train, fit, minimax_rounds) -> dict:
    target = get_target(part)
    form = get_form(part, form_name)
    theta = np.array([values[f"{part}_{p}"] for p in form.params])
    valid = target.validation()
    together = ", ".join(p for p in ORDER_PARTS[order] if p != part)
    return {
        **fit_identity(target, form, theta, target.domain),
        "training": {"points": len(train), "grid": f"true BRDF, Fourier order {order}: {train.grid}"},
        "validation": {"grid": valid.grid, **validation_metrics(form, theta, valid, target.scale(valid))},
        "published": [],
        "optimizer": {
            **SOLVER_SETTINGS,
            "objective": (f"fitted{' with ' + together if together else ''} to the true BRDF's multiple scattering of "
                          f"Fourier order {order} (exact.multiple_scattering_modes, phase='true') in the runtime "
                          "structure, relative to the true f_r's minimum over phi; least squares, then Lawson minimax "
                          f"refinement ({minimax_rounds} rounds, best max error kept)"),
            "least_squares_steps": fit.l2_steps,
            "total_steps": fit.total_steps,
            "result": fit.result,
            "train_max_rel": fit.train_max,
            "train_rms_rel": fit.train_rms,
        },
        "claimed_accuracy": "none: a part of the runtime model fitted to the true BRDF, not to its target",
        "note": ("This part approximates the true BRDF through the runtime structure, not the three-term "
                 f"{part}: its validation figures say how far it moved from the three-term quantity "
                 "(fitlab.families.lambert_sphere.true_refit; docs/model.md, 'Parts fitted to the true BRDF')."),
        "data_sha256": data_hash(train, valid),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Fit the runtime model's parts to the true BRDF (orders 0 to 2) "
                                                 "and write their fit files.")
    parser.add_argument("--out", type=Path, required=True, help="folder for the fit files (made if missing)")
    parser.add_argument("--minimax-rounds", type=int, default=MINIMAX_ROUNDS)
    args = parser.parse_args(argv)
    if args.minimax_rounds < 0:
        parser.error("--minimax-rounds must be >= 0")
    records = fitted_parts(minimax_rounds=args.minimax_rounds, on_order=lambda o, f: print(
        f"order {o}: train max {f.train_max:.3e}, RMS {f.train_rms:.3e} ({f.seconds:.0f} s)", flush=True))
    written = write_fits({fit_path(args.out, r["target"], r["form"]): r for r in records.values()})
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
