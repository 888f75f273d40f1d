"""``fitlab refit``: refit a published form (or a richer one) to the exact data, and write the fit files.

:func:`fitlab.fit.refit.refit` reads and writes nothing: this module checks every option, the
start (``--init``) and the output folder before any fit starts, resolves the form and the origin
of a discovered form, and writes the fits (all of them as one unit) only after every fit is done,
validated and kept by :func:`fitlab.fit.refit.refit_verdict`: a refit worse than its start or
than the published preset of its form, or with a non-finite error, is a failure (exit status 1)
and replaces nothing.  Nor does a refit replace a better fit already in ``--out`` (:func:`kept_fit`)
unless ``--force``.  Ctrl-C before the fits are in place leaves every old file as it was (exit status
130); after that, the command ends as it would have (:func:`fitlab._interrupt.hold`).
"""

from __future__ import annotations

from pathlib import Path

from tqdm import tqdm

from fitlab import _interrupt as interrupt
from fitlab.cli._common import (
    Once,
    RunFailure,
    UsageError,
    add_data,
    add_fits,
    add_quiet,
    describe,
    fits_input,
    input_file,
    one_line,
    output_folder,
    say,
    use_data,
    write_failure,
)
from fitlab.codegen import model_form
from fitlab.core import did_you_mean, get_target, target_names, targets
from fitlab.fit.metrics import worse
from fitlab.fit.refit import (
    check_domain,
    default_jobs,
    measure_word,
    refit_stages,
    refit_verdict,
    table,
    timed_refit,
    validation_metrics,
)
from fitlab.fit.solver import FitError
from fitlab.store import (
    FitFileError,
    TableError,
    fit_path,
    fit_source,
    form_from_fit,
    read_fit,
    resolve_form,
    strict_json,
    write_fits,
)

__all__ = ["add_arguments", "run", "parse_domain", "kept_fit", "listing_text"]


def add_arguments(p) -> None:
    describe(p, "Fit a form of a target to the target's exact training set, validate it on the denser validation "
                "set beside the published presets, and write TARGET[.FORM].json into --out. Of two fits, the one "
                "with the smaller max error is the better (at the same max, the one with the smaller RMS). A refit "
                "worse than its start or the published preset of its form, or with a non-finite error, fails (exit "
                "status 1) and replaces nothing. Nor does a refit replace a fit already in --out that is better on "
                "the same validation set or that was fitted over another --domain: it says so in one line and exits "
                "1, unless --force. Ctrl-C before the fit is written leaves the old file as it was "
                "(exit status 130).",
             "fitlab refit --target H0 --out /tmp/fits")  # fmt: skip
    p.add_argument("--target", action=Once, metavar="NAME", help=f"what to fit: {', '.join(target_names())}")
    p.add_argument("--form", action=Once,
                   help="which form of the target (default: the form the generated code prints, so that "
                        "`fitlab codegen --fits OUT` prints the refit; see --list)")  # fmt: skip
    p.add_argument("--all", action="store_true", help="refit every target (every form marked for it)")
    p.add_argument("--out", default="fits", help="folder for the fit JSON (default: fits, below the current folder)")
    add_fits(p, "folder the forms saved by `fitlab discover` are read from")
    add_data(p)
    p.add_argument(
        "--domain", action="append", metavar="NAME=LO:HI", help="restrict an input, e.g. c=0.5:1 (once per input)"
    )
    p.add_argument("--init", action=Once, type=Path, help="start from a saved fit of the same target and form")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the fit in --out even when it is better than the refit, or fitted over another domain",
    )
    p.add_argument("--no-minimax", action="store_true", help="least squares only, no minimax refinement")
    p.add_argument("--compare-scipy", action="store_true", help="also solve the least-squares stage with scipy")
    p.add_argument("--list", action="store_true", help="list targets and forms")
    p.add_argument("--json", action="store_true", help="print a machine-readable summary (JSON) instead of the table")
    add_quiet(p)


def _jobs(args) -> list[tuple]:
    """Every check of the request, before any fit: [(target, form, start, origin, domain)]; UsageError."""

    jobs = _requested(args)
    for target, form, *_ in jobs:
        path = fit_path(Path(args.out), target.name, form.name)
        if path.is_dir():
            raise UsageError(f"--out {args.out}: {path} is a folder, where the fit will be written")
    return jobs


def _requested(args) -> list[tuple]:

    if args.all == bool(args.target):
        raise UsageError("give --target NAME (see --list) or --all")
    if args.all and (args.form or args.domain or args.init):
        raise UsageError("--form, --domain and --init go with --target, not --all")
    if args.target not in (None, *target_names()):  # names only: no family is imported for them
        raise UsageError(
            f"unknown target {args.target!r}{did_you_mean(args.target, target_names(), '--list names them')}"
        )
    fits = fits_input(args, required=False)
    use_data(args)
    if args.init is not None:
        input_file(args.init, "--init")
    output_folder(args.out, "--out")
    try:
        if args.all:
            return [(get_target(t), get_target(t).forms[f], None, None, None) for t, f in default_jobs()]
        target = get_target(args.target)
        domain = parse_domain(args.domain, target)
        form = resolve_form(target.name, args.form or model_form(target.name), fits)
        origin = None
        saved = fit_source(fits, target.name, form.name)  # where resolve_form read it: --fits over the packaged fits
        if form.name not in target.forms and saved.exists():
            origin = read_fit(saved).get("origin")  # a discovered form stays one
        start = None
        if args.init is not None:
            prior = read_fit(args.init)
            if (prior["target"], prior["form"]) != (target.name, form.name):
                raise ValueError(f"--init {args.init}: a fit of {prior['target']}/{prior['form']}, not {form.key}")
            clash = [k for k, v in form.fixed.items() if k in prior["params"] and prior["params"][k] != v]
            if clash:  # an older fit of a form that now fixes a parameter: refused here, not at the write
                k = clash[0]
                raise ValueError(
                    f"--init {args.init}: {form.key} fixes {k} = {form.fixed[k]:g}, the file has "
                    f"{k} = {prior['params'][k]:g} (a fit of an older version of the form); leave out --init"
                )
            start = prior["params"]
        train = target.training().restricted(domain)
        if len(train) < 2 * len(form.free_params) or len(target.validation().restricted(domain)) == 0:
            raise ValueError(
                f"--domain leaves {len(train)} training points (and too few validation points) "
                f"for {len(form.free_params)} free parameters; widen it"
            )
        return [(target, form, start, origin, domain)]
    except (KeyError, ValueError, FitFileError, TableError) as exc:
        raise UsageError(one_line(exc)) from None


def _start_metrics(target, form, start, domain) -> dict:
    """The validation error of the refit's starting point (``--init``'s parameters or the form's start)."""

    valid = target.validation().restricted(check_domain(target, domain))
    theta = form.vector(start if start is not None else form.start_values)
    return validation_metrics(form, theta, valid, target.scale(valid))


def listing_text() -> str:
    """What ``fitlab refit --list`` prints: every target, its description and its forms, the one the generated
    code prints marked (the registry's, every family imported; cached by fitlab's code, :func:`fitlab.cache.cached_text`)."""
    lines = []
    for t in targets().values():
        default = model_form(t.name)
        forms = ", ".join(f + (" (default)" if f == default else "") for f in t.forms)
        lines.append(f"{t.name:<10} {t.description}\n{'':<10} forms: {forms}")
    return "\n".join(lines) + "\n"


def run(args) -> int:
    if args.list:
        from fitlab.cache import cached_text

        print(cached_text("listing-refit", listing_text), end="")
        return 0
    jobs = _jobs(args)  # every usage error before any work

    results, walls, verdicts = [], [], []
    try:
        for target, form, start, origin, domain in tqdm(jobs, desc="refit", unit="fit",
                                                         disable=args.quiet or len(jobs) == 1):  # fmt: skip
            minimax = False if args.no_minimax else None
            # one job: a bar over its stages (exact data, least squares, minimax rounds, validation)
            stages = tqdm(total=refit_stages(target, minimax), desc=f"refit {form.key}", unit="stage", leave=False,
                          disable=args.quiet or len(jobs) > 1)  # fmt: skip

            def on_step(stage, bar=stages):
                interrupt.check()  # between stages: a Ctrl-C Python could not raise stops the refit here
                bar.set_postfix_str(stage, refresh=False)
                bar.update()

            try:
                res, wall = timed_refit(
                    target,
                    form,
                    domain=domain,
                    start=start,
                    origin=origin,
                    minimax=minimax,
                    compare_scipy=args.compare_scipy,
                    on_step=on_step,
                )
            finally:
                stages.close()
            results.append(res)
            walls.append(wall)
            verdicts.append(refit_verdict(res, _start_metrics(target, form, start, domain)))
    except (FitFileError, TableError) as exc:
        raise UsageError(one_line(exc)) from None
    except (FitError, ValueError, ArithmeticError) as exc:
        raise RunFailure(f"{form.key}: the fit failed: {one_line(exc)}") from None
    paths = [fit_path(Path(args.out), r.record["target"], r.record["form"]) for r in results]
    notes = {}
    for i, (path, res, job) in enumerate(zip(paths, results, jobs)):
        if verdicts[i] is None and not args.force:  # a better fit already there stays
            verdicts[i], notes[path] = kept_fit(path, res, job[0])
    failures = [v for v in verdicts if v is not None]
    interrupt.check()
    with interrupt.hold(final=True):  # Ctrl-C from here: refused by the write's check, or after it and too late
        if not failures:  # every fit done, validated and kept: only now write, all as one unit
            try:
                write_fits({path: res.record for path, res in zip(paths, results)})
            except OSError as exc:
                raise write_failure(args.out, exc) from None
        if args.json:
            print(strict_json(_summary(results, walls, verdicts, paths, written=not failures)), end="")
        else:
            print(table(results, walls))
        if failures:
            more = f" (and {len(failures) - 1} more)" if len(failures) > 1 else ""
            raise RunFailure(f"{failures[0]}{more}; nothing written")
        for path in paths:
            say(args, f"wrote {path}{notes.get(path) or ''}")
    return 0


def _domain_text(domain) -> str:
    return ", ".join(f"{k}={float(lo):g}:{float(hi):g}" for k, (lo, hi) in domain.items())


def kept_fit(path: Path, result, target) -> tuple[str | None, str | None]:
    """Whether the fit already at ``path`` stays instead of ``result`` (a refit of ``target``):
    (reason, None) when it stays, (None, note) when the refit may replace it (``note``: what the
    ``wrote`` line adds, or None).

    It stays when it is a readable fit of the same target and form that is better on the refit's own
    validation set (measured again there, from the file's expression and parameters, not its stated
    figures; :func:`fitlab.fit.metrics.worse` says what better is), or that was fitted over another domain (not
    comparable).  A file that is not a readable fit is replaced, and the note says so."""
    path = Path(path)
    if not path.exists():
        return None, None
    rec = result.record
    key = f"{rec['target']}/{rec['form']}"
    try:
        old = read_fit(path, target=rec["target"])
        if (old["target"], old["form"]) != (rec["target"], rec["form"]):
            raise FitFileError(f"a fit of {old['target']}/{old['form']}, not {key}")
    except FitFileError as exc:
        return None, f" (replacing a file that was not a readable fit of {key}: {one_line(exc)})"
    mine = {k: (float(lo), float(hi)) for k, (lo, hi) in rec["domain"].items()}
    theirs = {k: (float(lo), float(hi)) for k, (lo, hi) in old["domain"].items()}
    if mine != theirs:
        return (
            f"{key}: {path} holds a fit over {_domain_text(theirs)}, the refit is over {_domain_text(mine)}; "
            f"not comparable, so it is kept (--force replaces it)"
        ), None
    valid = target.validation().restricted(mine)
    form = form_from_fit(old)
    measured = validation_metrics(form, form.vector(old["params"]), valid, target.scale(valid))
    new = rec["validation"]
    if not worse(new, measured):  # a figure the old fit does not give (NaN) counts as infinite
        return None, None
    _g = "{:.3e}".format
    w = measure_word(target.error_measure)
    return (
        f"{key}: the refit (max {w} {_g(new['max_rel'])}, RMS {_g(new['rms_rel'])}) is worse than the fit in "
        f"{path} (max {w} {_g(measured['max_rel'])}, RMS {_g(measured['rms_rel'])}, measured again on the same "
        f"validation set), which is kept (--force replaces it)"
    ), None


def _summary(results, walls, verdicts, paths, written: bool) -> dict:
    fits = []
    for res, wall, verdict, path in zip(results, walls, verdicts, paths):
        rec = res.record
        fits.append({
            "target": rec["target"], "form": rec["form"], "path": str(path), "written": written,
            "failure": verdict, "wall_s": wall, "params": rec["params"], "domain": rec["domain"],
            "validation": {k: rec["validation"][k] for k in ("max_rel", "max_rel_nonzero", "rms_rel", "points")},
            "published": [{"form": p["form"], "preset": p["preset"],
                           "validation": {k: p["validation"][k] for k in ("max_rel", "max_rel_nonzero", "rms_rel")}}
                          for p in rec["published"]],
        })  # fmt: skip
    return {"ok": all(v is None for v in verdicts), "written": written, "fits": fits}


def parse_domain(items, target) -> dict:
    """``["c=0.5:1", ...]`` -> {"c": (0.5, 1.0), ...}, checked against the target's domain; an input
    given twice is refused (ValueError), not silently the last one."""
    domain = dict(target.domain)
    seen = set()
    for item in items or ():
        name, sep, rng = item.partition("=")
        lo, sep2, hi = rng.partition(":")
        name = name.strip()
        if not sep or not sep2:
            raise ValueError(f"--domain {item!r}: write NAME=LO:HI, e.g. c=0.5:1")
        if name in seen:
            raise ValueError(f"--domain {item!r}: {name} given twice; give each input once")
        seen.add(name)
        try:
            lo_f, hi_f = float(lo), float(hi)
        except ValueError:
            raise ValueError(f"--domain {item!r}: LO and HI must be numbers") from None
        try:  # the bounds, the one rule refit itself applies (NaN fails too)
            domain[name] = check_domain(target, {name: (lo_f, hi_f)})[name]
        except ValueError as exc:
            raise ValueError(f"--domain {item!r}: {exc}") from None
    return domain
