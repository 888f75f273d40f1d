r"""The runtime model's parts fitted to the true BRDF (docs/model.md, "Parts fitted to the true BRDF").

The runtime structure f_r = max(0, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi) (:func:`..forms.runtime_terms`) comes from
the three-term half space, where fm0 is H0(mu_i) H0(mu_o) Q(mu_i, mu_o) over (mu_i + mu_o) less single
scattering, and so on: its parts H0, H1, H2, l, m, B, C, D, F are the three-term solution's.  The true BRDF
(the whole phase function in every collision, ``exact.brdf(..., phase="true")``) is not of that form, but close:
its orders 0 to 2 differ from the three-term ones by about 2e-3 of f_r at grazing, and its orders >= 3 are
2e-5 of f_r at most.  Here each order's parts are fitted jointly to that order of the true BRDF, in the
forms of the program's model "true" (:data:`..program.runtime.TRUE_FORMS`: H0, H1, H2 with the true BRDF's
grazing law), so that the same structure, at the same cost, approximates the true BRDF:

* stage 1, each order's parts fitted jointly to that order of the true BRDF (order 0: H0, B, C, D, F to fm0;
  order 1: H1, l, m to fm1; order 2: H2 to fm2), each residual relative to the true f_r's minimum over phi at
  its (mu_i, mu_o, c), by least squares from the three-term fits (:func:`start_values`, :func:`order_form`);
* stage 2, every part at once (:func:`joint_form`, the whole BRDF f_1 + fm0 + fm1 cos phi + fm2 cos 2phi) to
  the true BRDF of orders 0 to 2 at phi = k pi/4 (:data:`JOINT_PHI`), relative to f_r at each point, least
  squares then :data:`MINIMAX_ROUNDS` Lawson rounds: levelled jointly, the orders' errors cannot add at phi = 0
  and pi as they do when each order is levelled on its own.  Points with a cosine below :data:`GOAL_MU_MIN`
  (the accuracy goal's edge) weigh :data:`GRAZING_WEIGHT`: they keep the model sane down to mu = 1e-5 without
  spending the goal's domain on them;
* on :func:`..targets.datasets.true_orders_training` (a lattice apart from the audit's validation lattice and
  independent set), with :func:`fitlab.fit.solver.fit_form`;
* A and E stay exact (the structure holds them), and every form keeps its exact O(c) part, so the model is
  0 at c = 0 and its multiple scattering O(c^2).

:func:`fitted_parts` returns one fit record per part (the format of ``fitlab refit``'s files; ``validation``
measures the part against its own target, the three-term quantity, which it no longer approximates closely:
that figure says how far the fitted part moved).  ``python -m fitlab.families.lambert_sphere.program.true_refit --out
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
from fitlab.families.lambert_sphere.forms import ORDER2_PART, RUNTIME_PARTS, runtime_sum, runtime_terms
from fitlab.families.lambert_sphere.forms.brdf import SINGLE_FORWARD
from fitlab.families.lambert_sphere.program.runtime import RuntimeModel, runtime_model
from fitlab.families.lambert_sphere.program.spec import TRUE_MODEL
from fitlab.families.lambert_sphere.targets import TRUE
from fitlab.families.lambert_sphere.targets.datasets import true_orders_training
from fitlab.fit.refit import fit_identity, validation_metrics
from fitlab.fit.solver import SOLVER_SETTINGS, fit_form
from fitlab.forms import Form
from fitlab.forms.symbolic import lambdify_numpy, symbols
from fitlab.store import FitFileError, fit_path, fit_source, fits_folder, load, write_fits

__all__ = [
    "ORDER_PARTS",
    "TRUE_FITS",
    "TRUE_MODEL_NAME",
    "START_FORMS",
    "start_values",
    "order_form",
    "joint_form",
    "joint_training",
    "fitted_parts",
    "true_runtime_model",
    "MINIMAX_ROUNDS",
    "JOINT_PHI",
    "GOAL_MU_MIN",
    "GRAZING_WEIGHT",
]

#: the parts each Fourier order of the runtime structure is made of
ORDER_PARTS = {0: ("H0", "B", "C", "D", "F"), 1: ("H1", "l", "m"), 2: (ORDER2_PART,)}
#: the packaged fits of the parts fitted to the true BRDF, a folder that overlays the packaged fits
TRUE_FITS = fits_folder(None) / "true"
#: Lawson rounds of stage 2 (the joint fit), after its least squares.  Stage 1 has none: each order levelled on its
#: own puts its error's extremes at phi = 0 and pi, where the orders' errors add (30 rounds per order: 2.3e-3 on the
#: audit's true set for mu >= 1/64, against 5.9e-4 for least squares)
MINIMAX_ROUNDS = 30
#: the azimuths of stage 2's training points: the structure's orders 0 to 2 are fixed by three, five keep the
#: levelling from sitting between them
JOINT_PHI = np.linspace(0.0, np.pi, 5)
#: the accuracy goal's grazing edge (the max relative error over mu_i, mu_o in [0.01, 1])
GOAL_MU_MIN = 0.01
#: the weight in stage 2 of a training point with mu_i or mu_o below GOAL_MU_MIN (its error may be 1/weight times
#: the goal's before the levelling trades the goal's domain for it)
GRAZING_WEIGHT = 0.1


#: the name the audit and the report give the model of :data:`TRUE_FITS`
TRUE_MODEL_NAME = "refit to the true BRDF (fits/true)"


def true_runtime_model(fits_dir: Path | None = None) -> RuntimeModel:
    """The runtime model of the parts fitted to the true BRDF, from ``fits_dir`` (default :data:`TRUE_FITS`), in the
    forms of :data:`..program.runtime.TRUE_FORMS`, orders 0 to 2; every part must be in the folder (FitFileError names those that are not),
    the other fits the program needs come from the packaged ones."""
    folder = TRUE_FITS if fits_dir is None else Path(fits_dir)
    forms = _model_forms()
    # runtime_model falls back to the packaged fits for a part the folder lacks: here that would mix in a part
    # fitted to the mixed reference
    missing = [p for p in (*RUNTIME_PARTS, ORDER2_PART) if not fit_path(folder, p, forms[p]).is_file()]
    if missing:
        raise FitFileError(
            f"{folder}: no fit to the true BRDF of {', '.join(missing)} in the model's forms "
            f"({', '.join(fit_path(folder, p, forms[p]).name for p in missing)})"
        )
    m = runtime_model(fits_dir=folder, model=TRUE_MODEL)
    return RuntimeModel(TRUE_MODEL_NAME, m.expr, m.sources)


def _model_forms() -> dict:
    """{part: form} of the program's model of the parts fitted to the true BRDF."""
    return dict(program_spec("lambert_sphere").model(TRUE_MODEL).forms)


#: the form whose packaged fit (to the part's own three-term target) starts a form that has none: the same
#: parameters, and those it lacks start at 0
START_FORMS = {"log_exp_true": "log_exp"}


def start_values(part: str, form_name: str) -> dict:
    """{param: value} that the fit of ``part`` in ``form_name`` starts from: the packaged fit of that form to the part's
    own target (the three-term quantity), or of its :data:`START_FORMS` form, whose parameters it shares."""
    form = get_form(part, form_name)
    source = load(fit_source(None, part, START_FORMS.get(form_name, form_name)))
    return {p: float(source.params.get(p, 0.0)) for p in form.params}


def _parts(forms: dict, free: tuple) -> tuple[dict, list, dict, dict]:
    """(parts, params, fixed, start) of the runtime structure: each part in ``free`` as its form with parameters
    named ``part_param`` (start: :func:`start_values`), every other part its form at its start values."""
    parts, params, fixed, start = {}, [], {}, {}
    for part in (*RUNTIME_PARTS, ORDER2_PART):
        form = get_form(part, forms[part])
        values = start_values(part, forms[part])
        if part not in free:
            parts[part] = form.expr.xreplace({sp.Symbol(p, real=True): sp.Float(v) for p, v in values.items()})
            continue
        rename = {sp.Symbol(p, real=True): sp.Symbol(f"{part}_{p}", real=True) for p in form.params}
        parts[part] = form.expr.xreplace(rename)
        params += [f"{part}_{p}" for p in form.params]
        fixed.update({f"{part}_{p}": v for p, v in form.fixed.items()})
        start.update({f"{part}_{p}": v for p, v in values.items()})
    return parts, params, fixed, start


def order_form(order: int, forms: dict | None = None) -> tuple[Form, dict]:
    """The runtime structure's Fourier order ``order`` (fm0, fm1 or fm2 of :func:`..forms.runtime_terms`) as one
    form in (mu_i, mu_o, c) whose parameters are its parts' (named ``part_param``), and the start vector by
    name (:func:`start_values`).  ``forms``: {part: form}, default :data:`..program.runtime.TRUE_FORMS`."""
    forms = {**_model_forms(), **(forms or {})}
    parts, params, fixed, start = _parts(forms, ORDER_PARTS[order])
    expr = runtime_terms(parts)[f"m{order}"]
    form = Form(
        f"fm{order}_true",
        "runtime_parts",
        ("mu_i", "mu_o", "c"),
        tuple(params),
        expr,
        start=start,
        fixed=fixed,
        description=f"order {order} of the runtime structure, its parts' forms: "
        + ", ".join(f"{p} {forms[p]}" for p in ORDER_PARTS[order]),
    )
    return form, start


def joint_form(forms: dict | None = None) -> tuple[Form, dict]:
    """The runtime structure f_1 + fm0 + fm1 cos phi + fm2 cos 2phi (:func:`..forms.runtime_terms`, without the
    max(0, .) and the energy scale) as one form in (mu_i, mu_o, phi, c) whose parameters are every part's
    (named ``part_param``), and the start vector by name (:func:`start_values`)."""
    forms = {**_model_forms(), **(forms or {})}
    parts, params, fixed, start = _parts(forms, (*RUNTIME_PARTS, ORDER2_PART))
    expr = runtime_sum(parts)
    form = Form(
        "f_true",
        "runtime_parts",
        ("mu_i", "mu_o", "phi", "c"),
        tuple(params),
        expr,
        start=start,
        fixed=fixed,
        description="the runtime structure, its parts' forms: "
        + ", ".join(f"{p} {forms[p]}" for p in (*RUNTIME_PARTS, ORDER2_PART)),
    )
    return form, start


def _training(order: int) -> tuple[Dataset, np.ndarray]:
    ds = true_orders_training()
    return Dataset(ds.inputs, ds.aux[f"fm{order}"], ds.grid), ds.aux["scale"]


def joint_training() -> tuple[Dataset, np.ndarray]:
    """Stage 2's training set and weights: the true BRDF of orders 0 to 2, f_1 + fm0 + fm1 cos phi + fm2 cos 2phi
    (single scattering exact, the orders of :func:`..targets.datasets.true_orders_training`; the orders >= 3
    it leaves out are 2e-5 of f_r at most) at every (mu_i, mu_o, c) of that set and phi in :data:`JOINT_PHI`;
    weights 1, and
    :data:`GRAZING_WEIGHT` where mu_i or mu_o is below :data:`GOAL_MU_MIN`."""
    ds = true_orders_training()
    n = len(ds)
    mi, mo, c = (np.tile(np.asarray(ds.inputs[k], dtype=float), JOINT_PHI.size) for k in ("mu_i", "mu_o", "c"))
    phi = np.repeat(JOINT_PHI, n)
    fm0, fm1, fm2 = (np.tile(ds.aux[f"fm{m}"], JOINT_PHI.size) for m in range(3))
    single = lambdify_numpy(symbols(("mu_i", "mu_o", "phi", "c")), SINGLE_FORWARD)
    y = single(mi, mo, phi, c) + fm0 + fm1 * np.cos(phi) + fm2 * np.cos(2 * phi)
    inputs = {"mu_i": mi, "mu_o": mo, "phi": phi, "c": c}
    grid = f"true BRDF, orders 0 to 2, phi = k pi/{JOINT_PHI.size - 1} at {ds.grid}"
    weights = np.where(np.minimum(mi, mo) < GOAL_MU_MIN, GRAZING_WEIGHT, 1.0)
    return Dataset(inputs, y, grid), weights


def fitted_parts(forms: dict | None = None, minimax_rounds: int = MINIMAX_ROUNDS, on_stage=None) -> dict:
    """{part: fit record} of every part of the runtime structure fitted to the true BRDF (module docstring:
    stage 1 by order, stage 2 jointly with ``minimax_rounds`` Lawson rounds).  ``on_stage(name, result)`` is
    called after each order's fit and after the joint fit (a progress hook)."""
    forms = {**_model_forms(), **(forms or {})}
    values = {}
    for order in ORDER_PARTS:
        form, start = order_form(order, forms)
        train, scale = _training(order)
        fit = fit_form(form, train, scale, form.vector(start), minimax_rounds=0)
        if on_stage is not None:
            on_stage(f"order {order}", fit)
        values.update(zip(form.params, (float(x) for x in fit.theta)))
    form, _ = joint_form(forms)
    train, weights = joint_training()
    fit = fit_form(form, train, np.abs(train.y), form.vector(values), minimax_rounds=minimax_rounds, weights=weights)
    if on_stage is not None:
        on_stage("joint", fit)
    values = dict(zip(form.params, (float(x) for x in fit.theta)))
    return {
        part: _record(part, forms[part], values, train, fit, minimax_rounds)
        for names in ORDER_PARTS.values()
        for part in names
    }


def _record(part, form_name, values, train, fit, minimax_rounds) -> dict:
    target = get_target(part)
    form = get_form(part, form_name)
    theta = np.array([values[f"{part}_{p}"] for p in form.params])
    valid = target.validation()
    return {
        **fit_identity(target, form, theta, target.domain),
        "physics": TRUE,
        "training": {"points": len(train), "grid": train.grid},
        "validation": {"grid": valid.grid, **validation_metrics(form, theta, valid, target.scale(valid))},
        "published": [],
        "optimizer": {
            **SOLVER_SETTINGS,
            "objective": (
                "fitted with every other part of the runtime structure to the true BRDF (exact.brdf, "
                "phase='true', its multiple scattering's Fourier orders 0 to 2), relative to f_r; each "
                "order's parts by least squares first, then all jointly: least squares, then Lawson "
                f"minimax refinement ({minimax_rounds} rounds, best max error kept), points with a cosine "
                f"below {GOAL_MU_MIN} weighted {GRAZING_WEIGHT}"
            ),
            "least_squares_steps": fit.l2_steps,
            "total_steps": fit.total_steps,
            "result": fit.result,
            "train_max_rel": fit.train_max,
            "train_rms_rel": fit.train_rms,
        },
        "claimed_accuracy": "none: a part of the runtime model fitted to the true BRDF, not to its target",
        "note": (
            "This part approximates the true BRDF through the runtime structure, not the three-term "
            f"{part}: its validation figures say how far it moved from the three-term quantity "
            "(fitlab.families.lambert_sphere.program.true_refit; "
            "docs/model.md, 'Parts fitted to the true BRDF')."
        ),
        "data_sha256": data_hash(train, valid),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description="Fit the runtime model's parts to the true BRDF (orders 0 to 2) and write their fit files."
    )
    parser.add_argument("--out", type=Path, required=True, help="folder for the fit files (made if missing)")
    parser.add_argument("--minimax-rounds", type=int, default=MINIMAX_ROUNDS)
    args = parser.parse_args(argv)
    if args.minimax_rounds < 0:
        parser.error("--minimax-rounds must be >= 0")
    records = fitted_parts(
        minimax_rounds=args.minimax_rounds,
        on_stage=lambda name, f: print(
            f"{name}: train max {f.train_max:.3e}, RMS {f.train_rms:.3e} ({f.seconds:.0f} s)", flush=True
        ),
    )
    written = write_fits({fit_path(args.out, r["target"], r["form"]): r for r in records.values()})
    for path in written:
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
