r"""Refit: fit a form of a target to its training set and validate it on its validation set.

:func:`refit` takes a target, a form, a domain and starting values and returns
the record a fit file holds; it reads and writes nothing (``fitlab refit`` and
:mod:`fitlab.store` do).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass

from fitlab import __version__
from fitlab.core import Dataset, Target, data_hash, get_target, targets
from fitlab.fit.metrics import summary, worse
from fitlab.fit.solver import SOLVER_SETTINGS, FitResult, fit_form, fit_form_scipy
from fitlab.forms import Form
from fitlab.store import FORMAT

__all__ = [
    "RefitResult",
    "refit",
    "fit_identity",
    "fit_record",
    "refit_stages",
    "check_domain",
    "validation_metrics",
    "preset_metrics",
    "published_rows",
    "MINIMAX_ROUNDS",
    "default_jobs",
    "table",
    "refit_verdict",
]

MINIMAX_ROUNDS = 40


def check_domain(target: Target, domain: Mapping[str, tuple[float, float]] | None) -> dict:
    """The target's domain with ``domain``'s intervals in place of its inputs' whole ranges; each must lie
    inside the target's domain (ValueError otherwise)."""
    full = target.domain
    out = dict(full)
    for name, interval in (domain or {}).items():
        if name not in full:
            raise ValueError(f"domain: {target.name}'s inputs are {', '.join(target.inputs)}, not {name!r}")
        lo, hi = (float(x) for x in interval)
        full_lo, full_hi = full[name]
        if not (full_lo <= lo < hi <= full_hi):  # NaN fails too
            raise ValueError(f"domain {name}={lo:g}:{hi:g}: need {full_lo:g} <= LO < HI <= {full_hi:g} for {name}")
        out[name] = (lo, hi)
    return out


def default_jobs() -> list[tuple[str, str]]:
    """(target, form) pairs ``fitlab refit --all`` fits: every form marked refit_by_default."""
    return [(t.name, f.name) for t in targets().values() for f in t.forms.values() if f.refit_by_default]


@dataclass
class RefitResult:
    """A refit: the fit file's record, the optimiser's result and (``compare_scipy``) scipy's."""

    record: dict
    fit: FitResult
    scipy: FitResult | None = None


def validation_metrics(form, theta, ds, scale) -> dict:
    """Max and RMS error of ``form`` with parameters ``theta`` on dataset ``ds`` (``scale``: the error's divisor)."""
    xs = [ds.inputs[n] for n in form.inputs]
    return summary(form.numpy_function(theta, *xs), ds.y, scale, ds.inputs)


def preset_metrics(target: Target | str, form: Form | str, preset: str, ds=None) -> dict:
    """Max and RMS error (:func:`validation_metrics`) of a published preset of ``form`` on the target's
    validation set, or on ``ds`` (a :class:`fitlab.core.Dataset` of the target, e.g. a restricted one)."""
    target = get_target(target) if isinstance(target, str) else target
    form = target.forms[form] if isinstance(form, str) else form
    ds = target.validation() if ds is None else ds
    return validation_metrics(form, form.vector(preset), ds, target.scale(ds))


def fit_identity(target: Target, form: Form, theta, domain: Mapping[str, tuple[float, float]]) -> dict:
    """The fields of a fit record that say what was fitted: format and version, the target and the form (names,
    descriptions, inputs, expression), the parameters ``theta`` (a full vector, in the form's order), the fixed
    ones, the ``domain``, the target's error measure and the physics of its values (a maker that fits other physics
    says so; the rest, how it was fitted and measured, is the maker's)."""
    return {
        "format": FORMAT,
        "fitlab_version": __version__,
        "target": target.name,
        "target_description": target.description,
        "form": form.name,
        "form_description": form.description,
        "inputs": list(form.inputs),
        "expression": form.expression,
        "params": dict(zip(form.params, (float(x) for x in theta))),
        "fixed": dict(form.fixed),
        "domain": {k: list(v) for k, v in domain.items()},
        "error_measure": target.error_measure,
        "physics": target.physics,
    }


def refit(
    target: Target | str,
    form: Form | str | None = None,
    *,
    domain: Mapping[str, tuple[float, float]] | None = None,
    start: Mapping[str, float] | None = None,
    minimax: bool | None = None,
    compare_scipy: bool = False,
    minimax_rounds: int | None = None,
    origin: dict | None = None,
    on_step=None,
) -> RefitResult:
    """Fit ``form`` (a :class:`Form`, the name of a registered form, or None: the target's default
    form) to the target's training set restricted to ``domain`` ({input: (lo, hi)}, default the
    target's whole domain), starting from ``start`` (parameter values; default the form's start),
    validate it on the validation set, and return the record a fit file holds.  ``origin`` records
    where a form not registered by its family came from (``fitlab discover``).  Nothing is read or
    written here: the CLI and the store do that.  ``on_step(stage)``, when given, is called as each stage
    ends: "exact data", "least squares", each "minimax K/N", "validation" (:func:`refit_stages` counts them)."""
    target = get_target(target) if isinstance(target, str) else target
    form = target.forms[form or target.default_form] if not isinstance(form, Form) else form
    if form.target != target.name:
        raise ValueError(f"form {form.key} is not a form of {target.name}")
    domain = check_domain(target, domain)
    theta0 = None if start is None else form.vector(start)
    minimax = target.minimax if minimax is None else minimax
    rounds = MINIMAX_ROUNDS if minimax_rounds is None else minimax_rounds

    train = target.training().restricted(domain)
    valid = target.validation().restricted(domain)
    if len(train) < 2 * len(form.free_params) or len(valid) == 0:
        raise ValueError(f"domain {domain} leaves {len(train)} training and {len(valid)} validation points; widen it")
    if on_step is not None:
        on_step("exact data")

    weights = None if target.emphasis is None else target.emphasis(train)
    tscale = target.scale(train)
    fit = fit_form(
        form,
        train,
        tscale,
        theta0,
        minimax_rounds=rounds if minimax else 0,
        weights=weights,
        on_step=on_step,
    )
    scipy_fit = fit_form_scipy(form, train, tscale, theta0, weights=weights) if compare_scipy else None

    record = fit_record(target, form, fit, train, valid, domain, rounds if minimax else 0)
    if origin is not None:
        record["origin"] = origin
    if on_step is not None:
        on_step("validation")
    return RefitResult(record, fit, scipy_fit)


def fit_record(
    target: Target,
    form: Form,
    fit: FitResult,
    train: Dataset,
    valid: Dataset,
    domain: Mapping[str, tuple[float, float]],
    minimax_rounds: int,
) -> dict:
    """The record a fit file holds of ``fit`` (the solver's result) of ``form`` to ``train``, validated on
    ``valid``, over ``domain``; ``minimax_rounds``: the Lawson rounds that followed least squares (0: none)."""
    vscale = target.scale(valid)
    objective = "relative least squares (" + target.error_measure.split(":")[0] + ")"
    if target.emphasis_text:
        objective += "; " + target.emphasis_text
    if minimax_rounds:
        objective += f"; then Lawson minimax refinement ({minimax_rounds} rounds, best max error kept)"
    return {
        **fit_identity(target, form, fit.theta, domain),
        "training": {"points": len(train), "grid": train.grid},
        "validation": {"grid": valid.grid, **validation_metrics(form, fit.theta, valid, vscale)},
        "published": published_rows(target, valid, vscale),
        "optimizer": {
            **SOLVER_SETTINGS,
            "objective": objective,
            "least_squares_steps": fit.l2_steps,
            "total_steps": fit.total_steps,
            "result": fit.result,
            "train_max_rel": fit.train_max,
            "train_rms_rel": fit.train_rms,
        },
        "claimed_accuracy": target.claimed,
        "note": target.note,
        "data_sha256": data_hash(train, valid),
    }


def published_rows(target: Target, valid: Dataset, vscale) -> list[dict]:
    """The ``published`` rows of a fit record: each of the target's published presets (form, preset, its
    parameters) measured on ``valid``, the record's validation set, with its error scale ``vscale``
    (``target.scale(valid)``)."""
    rows = []
    for pform_name, preset in target.published:
        pform = target.forms[pform_name]
        rows.append(
            {
                "form": pform_name,
                "preset": preset,
                "params": dict(zip(pform.params, pform.vector(preset).tolist())),
                "validation": validation_metrics(pform, pform.vector(preset), valid, vscale),
            }
        )
    return rows


def refit_stages(target: Target | str, minimax: bool | None = None, minimax_rounds: int | None = None) -> int:
    """How many times :func:`refit` calls its ``on_step`` for ``target`` (at most: a minimax refinement
    whose residuals all vanish stops early)."""
    target = get_target(target) if isinstance(target, str) else target
    minimax = target.minimax if minimax is None else minimax
    return 3 + ((MINIMAX_ROUNDS if minimax_rounds is None else minimax_rounds) if minimax else 0)


def measure_word(error_measure: str) -> str:
    """The short name of a target's error measure (:attr:`fitlab.core.Target.error_measure`) in tables and
    messages: "abs" for an absolute error, "rel" for one relative to the exact value or to a stated scale, "err"
    for any other."""
    kind = error_measure.split(":")[0].strip().lower()
    return "abs" if kind.startswith("absolute") else "rel" if kind.startswith("relative") else "err"


def refit_verdict(result: RefitResult, start_metrics: Mapping | None = None) -> str | None:
    """Whether a refit may be kept: None if so, else the reason (one line).

    A refit fails when its validation error (max rel* or RMS) is not finite, or when it is worse
    (:func:`fitlab.fit.metrics.worse`, the rule every comparison of two fits uses) than a reference on the same
    validation set: its starting point (``start_metrics``, the :func:`validation_metrics` of the ``--init``
    parameters or of the form's start) or a published preset of the same form (the record's ``published``
    rows).  The max error decides first: a refit with the smaller max and the larger RMS (the minimax refit
    of H0 against the paper's preset) is kept, one with the larger max fails whatever its RMS; one that
    misses an exact zero of the target (max rel infinite) fails where the reference keeps it."""
    rec = result.record
    v = rec["validation"]
    w = measure_word(rec["error_measure"])
    _g = "{:.3e}".format  # nan and inf as themselves
    mine = (float(v["max_rel_nonzero"]), float(v["rms_rel"]))
    if not all(math.isfinite(x) for x in mine):
        return (
            f"{rec['target']}/{rec['form']}: the refit's validation error is not finite "
            f"(max {w}* {_g(mine[0])}, RMS {_g(mine[1])})"
        )
    references = []
    if start_metrics is not None:
        references.append(("its starting point", start_metrics))
    for p in rec.get("published", ()):
        if p["form"] == rec["form"]:
            references.append((f"the published preset {p['preset']}", p["validation"]))
    for label, m in references:
        if not worse(v, m):
            continue
        if not math.isfinite(float(v["max_rel"])) and math.isfinite(float(m["max_rel"])):
            return (
                f"{rec['target']}/{rec['form']}: the refit misses an exact zero of the target (max {w} "
                f"{_g(float(v['max_rel']))}) that {label} keeps (max {w} {_g(float(m['max_rel']))})"
            )
        return (
            f"{rec['target']}/{rec['form']}: the refit (max {w} {_g(float(v['max_rel']))}, max {w}* {_g(mine[0])}, "
            f"RMS {_g(mine[1])}) is worse than {label} (max {w} {_g(float(m['max_rel']))}, max {w}* "
            f"{_g(float(m['max_rel_nonzero']))}, RMS {_g(float(m['rms_rel']))}) on the validation set"
        )
    return None


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        return "inf"
    return f"{x:.3e}"


def table(results: list[RefitResult], walls: list[float]) -> str:
    """The side-by-side table: each published preset, then the refit; the columns named by the targets' error
    measure (:func:`measure_word`: max abs for the Fresnel family's absolute errors, max rel for relative ones),
    and each measure stated in full below."""
    measures: dict[str, list[str]] = {}
    for res in results:
        measures.setdefault(res.record["error_measure"], []).append(res.record["target"])
    words = {measure_word(m) for m in measures}
    w = words.pop() if len(words) == 1 else "err"
    lines = [
        f"{'target':<10} {'form / preset':<30} {'max ' + w:>10} {'max ' + w + '*':>10} {'rms ' + w:>10} "
        f"{'steps':>7} {'wall s':>7}  worst point of the refit",
    ]
    for res, wall in zip(results, walls):
        rec = res.record
        for p in rec["published"]:
            v = p["validation"]
            lines.append(
                f"{rec['target']:<10} {p['form'] + ' / ' + p['preset']:<30} {_fmt(v['max_rel']):>10} "
                f"{_fmt(v['max_rel_nonzero']):>10} {_fmt(v['rms_rel']):>10} {'':>7} {'':>7}"
            )
        v = rec["validation"]
        worst = ", ".join(f"{k}={val:.4g}" for k, val in v["worst"].items() if k not in ("exact", "approx"))
        lines.append(
            f"{rec['target']:<10} {rec['form'] + ' / refit':<30} {_fmt(v['max_rel']):>10} "
            f"{_fmt(v['max_rel_nonzero']):>10} {_fmt(v['rms_rel']):>10} {rec['optimizer']['total_steps']:>7} "
            f"{wall:>7.2f}  {worst}"
        )
        if res.scipy is not None:
            lines.append(
                f"{'':<10} least-squares stage: optimistix LM {res.fit.l2_seconds:.2f} s incl. JIT "
                f"({res.fit.l2_steps} steps); scipy least_squares (MINPACK LM, finite differences) "
                f"{res.scipy.seconds:.2f} s ({res.scipy.l2_steps} evaluations); train max {w} "
                f"{_fmt(res.fit.history[0][1])} vs {_fmt(res.scipy.train_max)}"
            )
    lines.append(
        f"max {w}* = max {w} without the target's exact zeros (where missing a zero is an infinite relative error; "
        f"the same as max {w} for an absolute error)"
    )
    for measure, names in measures.items():
        lines.append(f"error of {', '.join(dict.fromkeys(names))}: {measure}")
    return "\n".join(lines)


def timed_refit(*args, **kwargs) -> tuple[RefitResult, float]:
    t0 = time.perf_counter()
    res = refit(*args, **kwargs)
    return res, time.perf_counter() - t0
