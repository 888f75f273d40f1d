r"""``discover``: library -> sparse candidates -> refitted, validated forms -> Pareto front.

1. :class:`~fitlab.discover.regression.SparseRegression` finds sparse supports of
   each library's linearised model on the target's training set (STLSQ threshold
   sweep and the FROLS path); a target's libraries pool their candidates.
2. A candidate is kept (at most ``max_terms`` terms) when it is on the front of
   term count against linearised training error, or on the front of operation
   count against that error: a refit costs seconds, a linear solve microseconds.
3. Each is refitted in its nonlinear form by :func:`fitlab.fit.refit.refit`
   (optimistix least squares on the target's error measure, then Lawson
   minimax where the target asks for it) and validated on the target's
   validation set.
4. The front: candidates no other beats on (terms, error) or (operations,
   error), error being the validation max relative error (RMS for targets
   whose max is pinned, ``Target.minimax`` false).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fitlab.core import Target, get_target
from fitlab.discover.library import Library, get_libraries
from fitlab.discover.refine import arranged, candidate_form, form_name, operation_count
from fitlab.discover.regression import DEFAULT_THRESHOLDS, Candidate, SparseRegression
from fitlab.fit.metrics import relative_errors
from fitlab.fit.refit import RefitResult, preset_metrics, refit
from fitlab.report.pareto import pareto_front
from fitlab.store import fit_files, fits_folder, read_fit

__all__ = ["Discovered", "Discovery", "discover", "pareto_front", "front_metric"]


@dataclass
class Discovered:
    """One refitted candidate."""

    candidate: Candidate
    name: str
    terms: int
    operations: int
    record: dict  # the fit record, as fitlab refit writes it (with "origin")
    seconds: float

    @property
    def validation(self) -> dict:
        return self.record["validation"]


@dataclass
class Discovery:
    target: str
    libraries: tuple  # the Library objects searched, primary first
    metric: str  # "max_rel" or "rms_rel"
    candidates: list  # every Candidate the regression found
    refined: list  # Discovered, in order of terms
    front: list  # names of the Discovered on the Pareto front
    reference: list = field(default_factory=list)  # published presets and saved fits: dicts (label, terms, ops, error)
    seconds: float = 0.0
    #: every support the regression found that is not among ``refined``: dicts (numerator, denominator, terms,
    #: found_by, library, linear_error, reason), in the regression's order
    dropped: list = field(default_factory=list)

    def library_of(self, candidate: Candidate) -> Library:
        return next(lib for lib in self.libraries if lib.name == candidate.library)

    def get(self, name: str) -> Discovered:
        for d in self.refined:
            if d.name == name:
                return d
        raise KeyError(f"no discovered form {name!r}; on the front: {', '.join(self.front)}")


def library_tag(libraries, candidate: Candidate) -> str:
    """The candidate's library name when it is not the target's primary (first) library, else ""."""
    return "" if candidate.library == libraries[0].name else candidate.library


def front_metric(target_name: str | Target) -> str:
    target = target_name if isinstance(target_name, Target) else get_target(target_name)
    return "max_rel" if target.minimax else "rms_rel"


def _linear_errors(reg: SparseRegression, target, train) -> list[float]:
    scale = target.scale(train)
    out = []
    for cand in reg.candidates_:
        with np.errstate(all="ignore"):
            err = relative_errors(reg.predict(train.inputs, cand), train.y, scale)
        err = err[np.isfinite(train.y) & (scale > 0)]
        out.append(float(np.max(err)) if target.minimax else float(np.sqrt(np.mean(err**2))))
    return out


def discover(
    target_name: str | Target,
    *,
    libraries: tuple[Library, ...] | None = None,
    thresholds=DEFAULT_THRESHOLDS,
    max_terms: int = 12,
    minimax_rounds: int = 20,
    fits_dir: Path | None = None,
    progress: bool = True,
) -> Discovery:
    """Run the search for ``target_name`` over ``libraries`` (default: all of the target's); nothing
    is written (see :func:`fitlab.discover.save`).  ``target_name`` may be an unregistered
    :class:`fitlab.core.Target` (a user's table, :mod:`fitlab.discover.user`): then ``libraries`` are given,
    and the front has no reference points."""

    t0 = time.perf_counter()
    target = target_name if isinstance(target_name, Target) else get_target(target_name)
    libraries = tuple(libraries or get_libraries(target.name))
    for lib in libraries:
        if lib.target != target.name:
            raise ValueError(f"library {lib.name} is for {lib.target}, not {target.name}")
    if len({lib.name for lib in libraries}) != len(libraries):
        raise ValueError("libraries must have distinct names")
    if max_terms < 1:
        raise ValueError("max_terms must be at least 1")
    by_name = {lib.name: lib for lib in libraries}
    metric = front_metric(target)
    train = target.training()
    candidates, pool, linear, dropped = [], [], {}, {}
    for lib in libraries:
        reg = SparseRegression(lib, thresholds=thresholds, frols_steps=max_terms + 2).fit(
            train.inputs, train.y, target.scale(train)
        )
        candidates += reg.candidates_
        for cand, err in zip(reg.candidates_, _linear_errors(reg, target, train)):
            linear[id(cand)] = err
            if cand.n_terms > max_terms:
                dropped[id(cand)] = f"{cand.n_terms} terms, more than max_terms ({max_terms})"
            elif not np.isfinite(err):
                dropped[id(cand)] = "its linearised fit is not finite on the training rows"
            else:
                pool.append((cand, err))
    if not pool:
        raise ValueError(f"{target.name}: the regression found no finite model with at most {max_terms} terms")
    ops = [operation_count(arranged(by_name[cand.library], cand.num, cand.den)) for cand, _ in pool]
    keep = set(pareto_front([(cand.n_terms, e) for cand, e in pool], infinite_errors=True)) | set(
        pareto_front([(o, e) for o, (_, e) in zip(ops, pool)], infinite_errors=True)
    )
    chosen = [pool[i][0] for i in sorted(keep)]
    for i, (cand, _) in enumerate(pool):
        if i not in keep:
            dropped[id(cand)] = _dominated(i, pool, ops)

    refined = []
    for cand in tqdm(chosen, desc=f"discover {target.name}", unit="form", disable=not progress):
        library = by_name[cand.library]
        name = form_name(cand, library_tag(libraries, cand))
        form = candidate_form(library, cand, name)
        t1 = time.perf_counter()
        try:
            res: RefitResult = refit(
                target, form, minimax_rounds=minimax_rounds,
                origin={"method": "fitlab discover", "library": library.name, "found_by": cand.found_by,
                        "numerator": list(cand.num), "denominator": list(cand.den)},
            )  # fmt: skip
        except Exception as exc:  # noqa: BLE001 - a candidate whose refit fails (non-finite start) is dropped
            dropped[id(cand)] = f"its refit failed: {type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
            continue
        rec = res.record
        theta = {k: v for k, v in rec["params"].items()}
        a = {label: theta[f"a{k + 1}"] for k, label in enumerate(cand.num)}
        b = {label: theta[f"b{k + 1}"] for k, label in enumerate(cand.den)}
        refined.append(Discovered(cand, name, cand.n_terms, operation_count(arranged(library, a, b)), rec,
                                  time.perf_counter() - t1))  # fmt: skip
    if not refined:
        raise ValueError(f"{target.name}: every candidate's refit failed")
    errs = [d.validation[metric] for d in refined]
    on_front = set(pareto_front([(d.terms, e) for d, e in zip(refined, errs)], infinite_errors=True))
    on_front |= set(pareto_front([(d.operations, e) for d, e in zip(refined, errs)], infinite_errors=True))
    front = [refined[i].name for i in sorted(on_front, key=lambda i: (refined[i].terms, errs[i]))]
    reference = reference_points(target.name, fits_dir) if target.family else []  # a registered target's
    gone = [{"numerator": list(c.num), "denominator": list(c.den), "terms": c.n_terms, "found_by": c.found_by,
             "library": c.library, "linear_error": linear[id(c)], "reason": dropped[id(c)]}
            for c in candidates if id(c) in dropped]  # fmt: skip
    return Discovery(target.name, libraries, metric, candidates, refined, front, reference,
                     time.perf_counter() - t0, gone)  # fmt: skip


def _dominated(i: int, pool: list, ops: list) -> str:
    """Why candidate ``pool[i]`` (candidate, linearised error) is on neither linearised front: a candidate with
    no more terms and one with no more operations (``ops``), each of no larger error and not equal to it on
    both counts (the first of each in the pool; one candidate when it is both)."""

    def beats(j: int, size) -> bool:
        return size(j) <= size(i) and pool[j][1] <= pool[i][1] and (size(j), pool[j][1]) != (size(i), pool[i][1])

    def terms(j):
        return pool[j][0].n_terms

    def operations(j):
        return ops[j]

    def sizes(j) -> str:
        return f"{_count(terms(j), 'term')}, {_count(operations(j), 'operation')}"

    by = [next((j for j in range(len(pool)) if j != i and beats(j, size)), None) for size in (terms, operations)]
    found = list(dict.fromkeys(j for j in by if j is not None))
    if not found:  # equal on both counts to one listed before it: the fronts keep the first
        return "its sizes and linearised error equal those of a candidate kept"
    beaten = " and by ".join(f"{pool[j][0].found_by} ({sizes(j)}, error {pool[j][1]:.2e})" for j in found)
    return f"not on the linearised fronts ({sizes(i)}, error {pool[i][1]:.2e}): beaten by {beaten}"


def _count(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def reference_points(target_name: str, fits_dir: Path | None = None) -> list[dict]:
    """The published presets and every saved fit of the target not found by discover: label,
    free parameters, operations, validation max and RMS relative error."""
    target = get_target(target_name)
    out = []
    for form_name_, preset in target.published:
        form = target.forms[form_name_]
        m = preset_metrics(target, form, preset)
        out.append({"label": f"{form_name_} / {preset}", "kind": "published", "terms": len(form.free_params),
                    "operations": operation_count(form.substituted(preset)), "max_rel": m["max_rel"],
                    "rms_rel": m["rms_rel"], "max_rel_nonzero": m["max_rel_nonzero"]})  # fmt: skip
    for path in fit_files(fits_folder(fits_dir), target.name):
        rec = read_fit(path)
        if rec.get("origin") or rec["target"] != target.name:
            continue
        form = target.forms.get(rec["form"])
        if form is None:
            continue
        v = rec["validation"]
        out.append({"label": f"{rec['form']} / refit", "kind": "refit", "terms": len(form.free_params),
                    "operations": operation_count(form.substituted(rec["params"])), "max_rel": v["max_rel"],
                    "rms_rel": v["rms_rel"], "max_rel_nonzero": v["max_rel_nonzero"]})  # fmt: skip
    return out
