r"""``fitlab refit``: fit a form of a target, validate it, write fits/NAME.json.

Everything that can fail is done before anything is written: parse the
request, load the data, fit, validate, then one atomic write.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path


from .. import __version__
from ..fits import DEFAULT_DOMAINS, FORMAT, form_from_fit, read_fit, write_fit
from ..forms import Form
from . import data as d
from .metrics import summary
from .solver import SOLVER_SETTINGS, FitResult, fit_form, fit_form_scipy
from .targets import TARGETS, get_target

__all__ = ["RefitResult", "refit", "resolve_form", "parse_domain", "fit_path", "MINIMAX_ROUNDS", "default_jobs"]

MINIMAX_ROUNDS = 40


def parse_domain(items, inputs) -> dict:
    """``["c=0.5:1", ...]`` -> {"c": (0.5, 1.0), ...}, checked against the inputs' domains."""
    domain = {name: DEFAULT_DOMAINS[name] for name in inputs}
    for item in items or ():
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        if not sep or not sep2:
            raise ValueError(f"--domain {item!r}: write NAME=LO:HI, e.g. c=0.5:1")
        if name not in domain:
            raise ValueError(f"--domain {item!r}: this target's inputs are {', '.join(inputs)}")
        try:
            lo_f, hi_f = float(lo), float(hi)
        except ValueError:
            raise ValueError(f"--domain {item!r}: LO and HI must be numbers") from None
        full_lo, full_hi = DEFAULT_DOMAINS[name]
        if not (full_lo <= lo_f < hi_f <= full_hi):
            raise ValueError(f"--domain {item!r}: need {full_lo:g} <= LO < HI <= {full_hi:g} for {name}")
        domain[name] = (lo_f, hi_f)
    return domain


def resolve_form(target_name: str, form_name: str | None, fits_dir: Path = Path("fits")) -> Form:
    """A target's form by name: from fitlab.forms, else (a form found by ``fitlab discover``) from
    the saved fit fits_dir/TARGET.FORM.json, which holds the form's expression."""
    target = get_target(target_name)
    form_name = form_name or target.default_form
    if form_name in target.forms:
        return target.forms[form_name]
    path = fit_path(fits_dir, target.name, form_name)
    if path.exists():
        return form_from_fit(read_fit(path))
    raise KeyError(
        f"target {target.name} has no form {form_name!r} (and there is no {path}); forms: {', '.join(target.forms)}"
    )


def fit_path(out: Path, target: str, form: str) -> Path:
    """fits/NAME.json for a target's default form, fits/NAME.FORM.json otherwise."""
    default = get_target(target).default_form
    return Path(out) / (f"{target}.json" if form == default else f"{target}.{form}.json")


def default_jobs() -> list[tuple[str, str]]:
    """(target, form) pairs ``fitlab refit --all`` fits: every form marked refit_by_default."""
    return [(t.name, f.name) for t in TARGETS.values() for f in t.forms.values() if f.refit_by_default]


@dataclass
class RefitResult:
    record: dict
    path: Path
    fit: FitResult
    scipy: FitResult | None = None


def _metrics(form, theta, ds, scale) -> dict:
    xs = [ds.inputs[n] for n in form.inputs]
    return summary(form.numpy_function(theta, *xs), ds.y, scale, ds.inputs)


def refit(
    target_name: str,
    form_name: str | None = None,
    *,
    out: Path = Path("fits"),
    domain_items=(),
    init: Path | None = None,
    form: Form | None = None,
    minimax: bool | None = None,
    compare_scipy: bool = False,
    write: bool = True,
    minimax_rounds: int | None = None,
    origin: dict | None = None,
    fits_dir: Path | None = None,
) -> RefitResult:
    """Fit ``form`` (default: the target's published shape; a :class:`Form` given as ``form``
    is fitted as it is) to the target's training set, validate it, and write (``write``) the
    record to ``out``; ``origin`` records where a form not in fitlab.forms came from.  A form
    named but not defined in fitlab.forms (a discovered one) is read from ``fits_dir``
    (default: ``out``)."""
    target = get_target(target_name)
    fits_dir = Path(out if fits_dir is None else fits_dir)
    form = form if form is not None else resolve_form(target.name, form_name, fits_dir)
    saved = fit_path(fits_dir, target.name, form.name)
    if origin is None and form.name not in target.forms and saved.exists():
        origin = read_fit(saved).get("origin")  # a discovered form stays one
    domain = parse_domain(domain_items, target.inputs)
    theta0 = None
    if init is not None:
        prior = read_fit(init)
        if (prior["target"], prior["form"]) != (target.name, form.name):
            raise ValueError(f"--init {init}: a fit of {prior['target']}/{prior['form']}, not {form.key}")
        theta0 = form.vector(prior["params"])
    minimax = target.minimax if minimax is None else minimax
    rounds = MINIMAX_ROUNDS if minimax_rounds is None else minimax_rounds

    train = target.training().restricted(domain)
    valid = target.validation().restricted(domain)
    if len(train) < 2 * len(form.free_params) or len(valid) == 0:
        raise ValueError(f"--domain leaves {len(train)} training and {len(valid)} validation points; widen it")

    weights = None if target.emphasis is None else target.emphasis(train)
    fit = fit_form(
        form, train, target.scale(train), theta0, minimax_rounds=rounds if minimax else 0, weights=weights
    )
    scipy_fit = fit_form_scipy(form, train, target.scale(train), theta0, weights=weights) if compare_scipy else None

    vscale = target.scale(valid)
    published = []
    for pform_name, preset in target.published:
        pform = target.forms[pform_name]
        published.append(
            {
                "form": pform_name,
                "preset": preset,
                "params": dict(zip(pform.params, pform.vector(preset).tolist())),
                "validation": _metrics(pform, pform.vector(preset), valid, vscale),
            }
        )
    objective = "relative least squares (" + target.error_measure.split(":")[0] + ")"
    if target.emphasis_text:
        objective += "; " + target.emphasis_text
    if minimax:
        objective += f"; then Lawson minimax refinement ({rounds} rounds, best max error kept)"
    record = {
        "format": FORMAT,
        "fitlab_version": __version__,
        "target": target.name,
        "target_description": target.description,
        "form": form.name,
        "form_description": form.description,
        "inputs": list(form.inputs),
        "expression": form.expression,
        "params": dict(zip(form.params, (float(x) for x in fit.theta))),
        "fixed": dict(form.fixed),
        "domain": {k: list(v) for k, v in domain.items()},
        "error_measure": target.error_measure,
        "training": {"points": len(train), "grid": train.grid},
        "validation": {"grid": valid.grid, **_metrics(form, fit.theta, valid, vscale)},
        "published": published,
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
        "data_sha256": d.data_hash(train, valid),
    }
    if origin is not None:
        record["origin"] = origin
    path = fit_path(out, target.name, form.name)
    if write:
        write_fit(path, record)
    return RefitResult(record, path, fit, scipy_fit)


def _fmt(x: float) -> str:
    if not math.isfinite(x):
        return "inf"
    return f"{x:.3e}"


def table(results: list[RefitResult], walls: list[float]) -> str:
    """The side-by-side table: each published preset, then the refit."""
    lines = [
        f"{'target':<10} {'form / preset':<30} {'max rel':>10} {'max rel*':>10} {'rms rel':>10} "
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
                f"{res.scipy.seconds:.2f} s ({res.scipy.l2_steps} evaluations); train max rel "
                f"{_fmt(res.fit.history[0][1])} vs {_fmt(res.scipy.train_max)}"
            )
    lines.append("max rel* = max rel without the target's exact zeros (where missing a zero is an infinite relative error)")
    return "\n".join(lines)


def timed_refit(*args, **kwargs) -> tuple[RefitResult, float]:
    t0 = time.perf_counter()
    res = refit(*args, **kwargs)
    return res, time.perf_counter() - t0

